#pragma once
// veil paths: the first N ray paths matching a criterion, drawn over the 2D layout.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <string>

#include "cli/commands.h"

namespace veil::cli {

struct PathsOptions {
    std::string file;
    std::string where;
    int first = 300;
    std::string output = "paths.svg";
    std::string png;  // default: the output with .png
    double rays = 1e6;
    std::string colour = "flux";
    uint64_t seed = 1;
    int threads = 0;
    int widthPx = 2000;
    double batch = 20000;
    std::string mode = "split";
    double minRelativeFlux = 1e-4;
    bool noMechanics = false;
};
void addPathsCommand(CLI::App& app, PathsOptions& options);
int runPaths(const CommonOptions& common, const PathsOptions& options);

}  // namespace veil::cli
