// veil: the command-line front end. Subcommands live in their own files (info_command.cpp,
// ...); this file only wires them up and turns exceptions into messages and exit codes:
//   0 success, 1 bad input or model (message names file:line:col or the object), 2 usage.

#include <CLI/CLI.hpp>
#include <algorithm>
#include <iostream>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/ghosts_command.h"
#include "cli/paths_command.h"
#include "cli/render_command.h"
#include "lensdata/errors.h"

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

}  // namespace

int main(int argc, char** argv) {
    veil::cli::setCommandLine(argc, argv);
    CLI::App app{"veil: optical design kernel for stray light and ghost analysis"};
    app.require_subcommand(1);
    // Options a subcommand does not know (--glass-catalog) are the main command's, wherever
    // they stand on the line.
    app.fallthrough();
    app.set_version_flag("--version", std::string("veil ") + veil::cli::kVeilVersion);
    veil::cli::CommonOptions common;
    app.add_option("--glass-catalog", common.glassCatalogs,
                   "extra AGF glass catalog file (repeatable; VEIL_GLASS_PATH works too)")
        ->check(CLI::ExistingFile);

    veil::cli::InfoOptions info;
    veil::cli::addInfoCommand(app, info);
    veil::cli::LayoutOptions layout;
    veil::cli::addLayoutCommand(app, layout);
    veil::cli::ExportOptions exportOptions;
    veil::cli::addExportCommand(app, exportOptions);
    veil::cli::TraceOptions traceOptions;
    veil::cli::addTraceCommand(app, traceOptions);
    veil::cli::RaysOptions raysOptions;
    veil::cli::addRaysCommand(app, raysOptions);
    veil::cli::PathsOptions pathsOptions;
    veil::cli::addPathsCommand(app, pathsOptions);
    veil::cli::ViewOptions viewOptions;
    veil::cli::addViewCommand(app, viewOptions);
    veil::cli::GhostsOptions ghostsOptions;
    veil::cli::addGhostsCommand(app, ghostsOptions);
    veil::cli::RenderCommandOptions renderOptions;
    veil::cli::addRenderCommand(app, renderOptions);
    veil::cli::SweepOptions sweepOptions;
    veil::cli::addSweepCommand(app, sweepOptions);
    veil::cli::PstOptions pstOptions;
    veil::cli::addPstCommand(app, pstOptions);
    veil::cli::ObjectsOptions objectsOptions;
    veil::cli::addObjectsCommand(app, objectsOptions);

    // A first word that is no command and no option: name the nearest command.
    if (argc > 1 && argv[1][0] != '-') {
        const std::string word = argv[1];
        std::string best;
        size_t bestDistance = 3;  // at most two edits away
        bool known = false;
        for (const CLI::App* sub : app.get_subcommands({})) {
            known |= sub->get_name() == word;
            const size_t d = distance(word, sub->get_name());
            if (d < bestDistance) {
                bestDistance = d;
                best = sub->get_name();
            }
        }
        if (!known) {
            std::cerr << "veil: error: unknown command '" << word << "'";
            if (!best.empty()) std::cerr << "; did you mean '" << best << "'?";
            std::cerr << "\nRun veil --help for the commands.\n";
            return 2;
        }
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    try {
        for (CLI::App* sub : app.get_subcommands()) {
            if (sub->get_name() == "info") return veil::cli::runInfo(common, info);
            if (sub->get_name() == "layout") return veil::cli::runLayout(common, layout);
            if (sub->get_name() == "export") return veil::cli::runExport(common, exportOptions);
            if (sub->get_name() == "trace") return veil::cli::runTrace(common, traceOptions);
            if (sub->get_name() == "rays") return veil::cli::runRays(common, raysOptions);
            if (sub->get_name() == "paths") return veil::cli::runPaths(common, pathsOptions);
            if (sub->get_name() == "view") return veil::cli::runView(common, viewOptions);
            if (sub->get_name() == "ghosts") return veil::cli::runGhosts(common, ghostsOptions);
            if (sub->get_name() == "render") return veil::cli::runRender(common, renderOptions);
            if (sub->get_name() == "sweep") return veil::cli::runSweepCommand(common, sweepOptions);
            if (sub->get_name() == "pst") return veil::cli::runPstCommand(common, pstOptions);
            if (sub->get_name() == "objects")
                return veil::cli::runObjectsCommand(common, objectsOptions);
        }
    } catch (const veil::ParseError& e) {
        std::cerr << "veil: error: " << e.what() << "\n";
        return 1;
    } catch (const veil::ModelError& e) {
        std::cerr << "veil: error: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "veil: error: " << e.what() << "\n";
        return 1;
    }
    return 2;
}
