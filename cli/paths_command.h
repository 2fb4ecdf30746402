#pragma once
// veil paths: the first N ray paths matching a criterion, drawn over the 2D layout.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>
#include <vector>

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

}  // namespace veil::cli
