// veil: the command-line front end. Subcommands live in their own files (info_command.cpp,
// ...); this file only wires them up and turns exceptions into messages and exit codes:
//   0 success, 1 bad input or model (message names file:line:col or the object), 2 usage.

#include <CLI/CLI.hpp>
#include <iostream>

#include "cli/commands.h"
#include "cli/ghosts_command.h"
#include "cli/paths_command.h"
#include "lensdata/errors.h"

int main(int argc, char** argv) {
    CLI::App app{"veil: optical design kernel for stray light and ghost analysis"};
    app.require_subcommand(1);
    app.set_version_flag("--version", "veil 0.1.0");
    veil::cli::CommonOptions common;
    app.add_option("--glass-catalog", common.glassCatalogs,
                   "extra AGF glass catalog file (repeatable; VEIL_GLASS_PATH works too)")
        ->check(CLI::ExistingFile);

    veil::cli::InfoOptions info;
    veil::cli::addInfoCommand(app, common, info);
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
    veil::cli::GhostsOptions ghostsOptions;
    veil::cli::addGhostsCommand(app, ghostsOptions);

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
            if (sub->get_name() == "ghosts") return veil::cli::runGhosts(common, ghostsOptions);
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
