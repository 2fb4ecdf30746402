// The veil command line as a function: builds the subcommands (each in its own file:
// info_command.cpp, ...), parses, runs one, and turns exceptions into messages and exit codes
//   0 success, 1 bad input or model (the message names file:line:col or the object), 2 usage.
// main() is this on argv; the Python module runs it in-process with rethrow on.

#include "cli/app.h"

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <functional>
#include <iostream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "cli/commands.h"
#include "cli/ghosts_command.h"
#include "cli/paths_command.h"
#include "cli/render_command.h"
#include "cli/trace_command.h"
#include "lensdata/errors.h"
#include "tracer/runtime/ranks.h"

namespace veil::cli {

namespace {

// Edit distance, for "did you mean" on a mistyped command.
size_t distance(const std::string& a, const std::string& b) {
    std::vector<size_t> row(b.size() + 1);
    for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
    for (size_t i = 1; i <= a.size(); ++i) {
        size_t diagonal = row[0];
        row[0] = i;
        for (size_t j = 1; j <= b.size(); ++j) {
            const size_t up = row[j];
            row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] != b[j - 1])});
            diagonal = up;
        }
    }
    return row[b.size()];
}

// A failure: the message and the exit code. Across ranks the failing rank ends the whole job
// (abortRanks), rank 0 with its message as usual; another rank first gives rank 0 two seconds
// (a bad input fails every rank alike, and rank 0's message is the one to read), then writes
// its own, naming itself, to the standard error it kept.
int fail(const std::string& message, int code) {
    const Ranks world = Ranks::world();
    if (world.single()) {
        std::cerr << "veil: error: " << message << "\n";
        return code;
    }
    if (world.root()) {
        std::cerr << "veil: error: " << message << std::endl;
    } else {
        std::this_thread::sleep_for(std::chrono::seconds(2));
        std::fprintf(stderr, "veil: error (rank %d of %d): %s\n", world.rank(), world.size(),
                     message.c_str());
        std::fflush(stderr);
    }
    abortRanks(code);
}

// The commands that split their work over the ranks of an mpirun job (docs/scaling.md).
bool runsOnRanks(const std::string& command) {
    return command == "trace" || command == "render" || command == "sweep" || command == "pst";
}

// A subcommand: how its options are declared and how it runs, over options it owns.
struct Subcommand {
    std::function<void(CLI::App&)> declare;
    std::function<int(const CommonOptions&)> run;
};

template <class Options>
Subcommand subcommand(void (*declare)(CLI::App&, Options&),
                      int (*run)(const CommonOptions&, const Options&)) {
    auto options = std::make_shared<Options>();
    return {[options, declare](CLI::App& app) { declare(app, *options); },
            [options, run](const CommonOptions& common) { return run(common, *options); }};
}

// Every command of veil, by name, in the order --help lists them.
std::vector<std::pair<std::string, Subcommand>> subcommands() {
    return {{"info", subcommand(addInfoCommand, runInfo)},
            {"layout", subcommand(addLayoutCommand, runLayout)},
            {"export", subcommand(addExportCommand, runExport)},
            {"export-lens", subcommand(addExportLensCommand, runExportLens)},
            {"trace", subcommand(addTraceCommand, runTrace)},
            {"rays", subcommand(addRaysCommand, runRays)},
            {"paths", subcommand(addPathsCommand, runPaths)},
            {"view", subcommand(addViewCommand, runView)},
            {"ghosts", subcommand(addGhostsCommand, runGhosts)},
            {"render", subcommand(addRenderCommand, runRender)},
            {"sweep", subcommand(addSweepCommand, runSweepCommand)},
            {"pst", subcommand(addPstCommand, runPstCommand)},
            {"objects", subcommand(addObjectsCommand, runObjectsCommand)},
            {"scatter", subcommand(addScatterCommand, runScatterCommand)},
            {"glare", subcommand(addGlareCommand, runGlareCommand)}};
}

// The message for a first word that is no command (empty when it is one): the nearest
// command, at most two edits away.
std::string unknownCommand(const CLI::App& app, const std::string& word) {
    std::string best;
    size_t bestDistance = 3;
    for (const CLI::App* sub : app.get_subcommands({})) {
        if (sub->get_name() == word) return "";
        const size_t d = distance(word, sub->get_name());
        if (d < bestDistance) {
            bestDistance = d;
            best = sub->get_name();
        }
    }
    std::string message = "unknown command '" + word + "'";
    if (!best.empty()) message += "; did you mean '" + best + "'?";
    return message;
}

// The options of veil itself, before the command: --glass-catalog and --set.
void declareCommon(CLI::App& app, CommonOptions& common) {
    app.require_subcommand(1);
    // Options a subcommand does not know (--glass-catalog) are the main command's, wherever
    // they stand on the line.
    app.fallthrough();
    app.add_option("--glass-catalog", common.glassCatalogs,
                   "extra AGF glass catalog file (repeatable; VEIL_GLASS_PATH works too)")
        ->check(CLI::ExistingFile);
    app.add_option("--set", common.sets,
                   "KEY=VALUE: edit the scene (or its lens) file as it is read, as sweep's "
                   "--vary does (repeatable)");
}

}  // namespace

void parseCommandWords(const std::vector<std::string>& words, CommonOptions& common,
                       const std::function<void(CLI::App&)>& declare) {
    CLI::App app{"veil"};
    declareCommon(app, common);
    declare(app);
    std::vector<std::string> reversed(words.rbegin(), words.rend());  // CLI11 takes them so
    try {
        app.parse(reversed);
    } catch (const CLI::ParseError& e) {
        throw UsageError(e.what());
    }
}

int runCommandLine(const std::vector<std::string>& args, bool rethrow) {
    std::vector<char*> argvStore;
    for (const std::string& a : args) argvStore.push_back(const_cast<char*>(a.c_str()));
    const int argc = static_cast<int>(argvStore.size());
    char** argv = argvStore.data();
    setCommandLine(argc, argv);
    CLI::App app{"veil: optical design kernel for stray light and ghost analysis"};
    CommonOptions common;
    declareCommon(app, common);
    app.set_version_flag("--version", std::string("veil ") + kVeilVersion);
    const auto commands = subcommands();
    for (const auto& [name, command] : commands) command.declare(app);
    if (argc > 1 && argv[1][0] != '-') {
        const std::string message = unknownCommand(app, argv[1]);
        if (!message.empty() && rethrow) throw UsageError(message);
        if (!message.empty()) {
            std::cerr << "veil: error: " << message << "\nRun veil --help for the commands.\n";
            return 2;
        }
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (rethrow && e.get_exit_code() != 0) throw UsageError(e.what());
        if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
        // The option parser's own errors (a value out of its range, a missing argument) are
        // said as every other error is.
        std::cerr << "veil: error: " << e.what()
                  << "\nRun veil --help, or veil COMMAND --help, for the options.\n";
        return 2;
    }
    try {
        for (CLI::App* sub : app.get_subcommands())
            if (!Ranks::world().single() && !runsOnRanks(sub->get_name()))
                throw UsageError("veil " + sub->get_name() +
                                 " runs in one process: start it without mpirun (veil trace, "
                                 "render, sweep and pst split their work over the ranks)");
        for (CLI::App* sub : app.get_subcommands())
            for (const auto& [name, command] : commands)
                if (sub->get_name() == name) return command.run(common);
    } catch (const UsageError& e) {
        if (rethrow) throw;
        return fail(e.what(), 2);
    } catch (const ParseError& e) {
        if (rethrow) throw;
        // An option's value (the error names the option, "--time-limit", "-o") is a bad
        // command line; a file's, bad input.
        return fail(e.what(), e.loc().file.rfind('-', 0) == 0 ? 2 : 1);
    } catch (const std::exception& e) {
        if (rethrow) throw;
        return fail(e.what(), 1);
    }
    return 2;
}

}  // namespace veil::cli
