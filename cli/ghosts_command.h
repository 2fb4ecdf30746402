#pragma once
// veil ghosts: automated ghost analysis (analysis/ghosts/ghosts.h).

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "cli/commands.h"

namespace veil::cli {

struct GhostsOptions {
    std::string file;
    int order = 2;
    int top = 10;
    std::vector<std::string> fields;    // "x,y" degrees (or object mm for a finite object)
    std::vector<std::string> coatings;  // GLOB=PROPERTY
    bool json = false;
    std::string output;  // folder; default ./ghosts
    int grid = 64;
    uint64_t rays = 10000;  // Monte Carlo rays per source; 0: sequential estimate only
    int paths = 200;
    uint64_t seed = 1;
    int threads = 0;
    bool quiet = false;
    std::string detector;
    double nearFocusMm = 0.0;
    double minFourthOrder = 1e-7;
    bool noImages = false;
    double decades = 3.0;  // PNG log range
    int pixels = 0;  // detector pixels along the longer side for the ghost images; 0 = the scene's
    uint64_t maxMemory = 0;  // bytes; 0: the machine's (GhostRunSpec::maxMemoryBytes)
};
void addGhostsCommand(CLI::App& app, GhostsOptions& options);
int runGhosts(const CommonOptions& common, const GhostsOptions& options);

}  // namespace veil::cli
