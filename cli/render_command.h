#pragma once
// veil render: diffuse stray light images by bidirectional stochastic ray tracing with photon
// maps, progressive until a target error, a time limit or a pass count (tracer/render/render.h,
// docs/render.md).

#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "analysis/runs/render_run.h"
#include "cli/commands.h"
#include "cli/options.h"

namespace veil::cli {

struct RenderCommandOptions {
    std::string file;
    std::string output;  // folder; default ./render (or the --resume folder)
    std::string resume;  // folder of a run to continue
    double targetError = 0.05;
    // The image the target error applies to: total, visible, direct, caustic, secondary or
    // where<k> (the k-th --where criterion's image).
    std::string targetOn = "stray";
    std::string timeLimit = "10m";
    int passes = 0;  // 0: no pass limit
    std::string detector;
    // Per source per pass: "auto" (100000 in the first pass, then balanced against the view
    // points: RenderOptions::balancePhotons) or a count for every pass.
    std::string photons = "auto";
    uint64_t ghostPhotons = 16384;  // of those, following every specular branch
    std::string visiblePhotons = "auto";  // more, depositing the visible light alone
    uint64_t raysPerPixel = 16;
    uint64_t tileRays = uint64_t{1} << 21;  // RenderOptions::tileRays
    uint64_t maxMemory = 0;  // bytes; 0: the machine's (RenderRunSpec::maxMemoryBytes)
    double radiusMm = 0.0;  // 0: automatic
    double alpha = 2.0 / 3.0;
    double roulette = 0.1;
    int areaSamples = 16;  // rim correction probes per view point
    double guide = 0.5;    // guided share of the pixel rays (RenderOptions::guideFraction)
    double photonGuide = 0.5;  // guided share of the photons (RenderOptions::photonGuideFraction)
    double scatterGuide = 0.5;      // guided share of their scatters (scatterGuideFraction)
    double weightWindow = 0.0;      // RenderOptions::weightWindow (0: off)
    double followLobesBelow = 0.0;  // degrees (RenderOptions::followLobesBelowDeg)
    double splatLobesBelow = 15.0;  // degrees (RenderOptions::splatLobesBelowDeg)
    int lobeSplats = 1024;          // RenderOptions::lobeSplats
    double aimedSplats = 0.5;       // RenderOptions::aimedSplats
    int partDirections = 32;        // RenderOptions::partDirections
    std::string connect = "on";     // RenderOptions::connectThroughLens
    std::string ghostRoutes = "on";  // RenderOptions::ghostRoutes
    uint64_t partSamples = 65536;   // RenderOptions::partSamples
    uint64_t partPhotons = 16384;   // RenderOptions::partPhotons
    std::string backward = "random";
    std::string photonPoints = "sobol";
    double minWeight = 1e-4;
    std::vector<std::string> where;  // path criteria: one image per criterion
    bool prune = false;              // stop paths no criterion can match
    std::vector<std::string> fields;
    int threads = 0;
    uint64_t seed = 1;
    bool json = false;
    bool quiet = false;
    PreviewFlags preview;  // --decades, --range
};
void addRenderCommand(CLI::App& app, RenderCommandOptions& options);
int runRender(const CommonOptions& common, const RenderCommandOptions& options);

// veil render's steps, shared by the executable and the Python module: the options checked
// into a spec before the scene is read; where the files go; the run on a prepared scene with
// its files written. Nothing here prints.
RenderRunSpec renderSpec(const RenderCommandOptions& options);
// -o, else the --resume folder, else ./render; none (empty) for --json without either.
std::filesystem::path renderFolder(const RenderCommandOptions& options);
struct RenderCommandRun {
    RenderResult result;
    WrittenFiles written;  // rank 0's files; none without a folder
};
// The run, its checkpoint after every pass and its files in `folder` (none when empty).
RenderCommandRun renderIntoFolder(const PreparedScene& scene, RenderRunSpec spec,
                                  const RenderCommandOptions& options,
                                  const std::filesystem::path& folder);

// "90s", "10m", "1h30m", "2h", "45" (seconds) -> seconds; "0" or "none": no limit (infinity).
// nullopt for anything else.
std::optional<double> parseDuration(const std::string& text);

}  // namespace veil::cli
