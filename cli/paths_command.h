#pragma once
// veil paths: the first N ray paths matching a criterion, drawn over the 2D layout.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

#include "analysis/pictures/path_picture.h"
#include "cli/commands.h"

namespace veil::cli {

struct PathsOptions {
    std::string file;
    std::string where;
    int first = 300;
    std::string output;  // folder: paths.svg, paths.png; default ./paths
    std::vector<std::string> fields;
    uint64_t rays = 1000000;  // per source, at most
    std::string colour = "flux";
    uint64_t seed = 1;
    int threads = 0;
    int widthPx = 2000;
    uint64_t batch = 20000;
    std::string mode = "split";
    double minRelativeFlux = 1e-4;
    bool noMechanics = false;
    bool json = false;
    bool quiet = false;
};
void addPathsCommand(CLI::App& app, PathsOptions& options);
int runPaths(const CommonOptions& common, const PathsOptions& options);

// Shared by the commands that draw selected paths (paths, view): --colour, --mode and
// --min-flux, and the selection they and -n, --first, --batch and --seed ask for.
void addPathDrawingOptions(CLI::App* sub, std::string& colour, std::string& mode,
                           double& minRelativeFlux);
PathSelectionOptions pathSelectionOptions(const SceneTransport& transport, const std::string& where,
                                          int first, uint64_t raysPerSource, uint64_t batch,
                                          uint64_t seed, const std::string& mode,
                                          double minRelativeFlux);

}  // namespace veil::cli
