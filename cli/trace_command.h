#pragma once
// veil trace and veil rays: the forward Monte Carlo run (analysis/runs/stray_light_run.h) and
// statistics re-run from its ray database.

#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "analysis/runs/stray_light_run.h"
#include "cli/commands.h"
#include "cli/options.h"

namespace veil::cli {

struct TraceOptions {
    std::string file;
    uint64_t rays = 0;
    std::string output;  // folder; default ./trace
    std::vector<std::string> fields;
    int threads = 0;
    uint64_t seed = 1;
    TransportFlags transport;
    bool json = false;
    bool quiet = false;
    std::string saveRays;            // ray database file to write
    bool eventsOnly = false;         // the database without positions and directions
    std::vector<std::string> where;  // path criteria: one image per criterion plus the rest
    bool prune = false;              // cull branches once every --where criterion is false
    PreviewFlags preview;            // --decades, --range
    uint64_t maxMemory = 0;          // bytes; 0: the machine's (StrayLightSpec::maxMemoryBytes)
    std::string resume;              // folder of a killed run to go on with (its trace.checkpoint)
    double checkpointSeconds = 60.0;  // a checkpoint at most this often (0: after every block)
};
void addTraceCommand(CLI::App& app, TraceOptions& options);
int runTrace(const CommonOptions& common, const TraceOptions& options);

struct RaysOptions {
    std::string file;
    std::vector<std::string> where;  // criteria re-evaluated on the saved histories
    bool json = false;
    bool quiet = false;
};
void addRaysCommand(CLI::App& app, RaysOptions& options);
int runRays(const CommonOptions& common, const RaysOptions& options);

// veil trace's steps, shared by the executable and the Python module: the options checked
// into a spec before the scene is read; the ray database sized against the free disk (the
// note to show, empty without --save-rays); the run with its files written into `folder`
// (none when empty). Nothing here prints.
StrayLightSpec traceSpec(const TraceOptions& options);
std::string checkRayDatabase(const PreparedScene& scene, const StrayLightSpec& spec,
                             const TraceOptions& options);
struct TraceCommandRun {
    StrayLightResult result;
    WrittenFiles written;  // rank 0's files
};
TraceCommandRun traceIntoFolder(const PreparedScene& scene, StrayLightSpec spec,
                                const TraceOptions& options, const std::filesystem::path& folder);

}  // namespace veil::cli
