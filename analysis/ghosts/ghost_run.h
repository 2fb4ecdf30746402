#pragma once
// veil ghosts as a value: a lens (or scene) in, the ranked ghost table and its images out.
//
//   SceneSpec + GhostRunSpec
//     --prepareGhostRun--> the scene: the default scene of a bare lens (lens/default_scene.h),
//       --field beams, --pixels
//     --runGhostAnalysis--> the coating what-if's baseline ranking, then the overrides
//       (coating_whatif.h),
//       the sequential estimate (ghost_tracer.h), the Monte Carlo check (ghost_monte_carlo.h)
//     --> GhostRun: the analysis and its report (ghost_report.h)
//     --writeGhostFiles--> ghosts.json, ghosts.csv, ghosts.md, the Monte Carlo images
//         (images/ghost_NN.exr and .png, ghosts_all, nominal) and path pictures of the top
//         ghosts (paths/ghost_NN.svg and .png, all_ghosts)
//
// Nothing here prints.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "analysis/ghosts/ghost_monte_carlo.h"
#include "analysis/ghosts/ghost_report.h"
#include "analysis/ghosts/ghost_tracer.h"
#include "analysis/reports/progress.h"

namespace veil {

struct SceneSpec;
class GlassCatalog;
class PreparedScene;

struct GhostRunSpec {
    std::string scene;  // as the user named it (the report)
    GhostOptions options;
    std::vector<std::pair<double, double>> fieldsDeg;  // beams replacing the sources; empty: keep
    std::vector<std::string> coatings;                 // what-if: GLOB=PROPERTY
    int pixels = 0;  // detector pixels along the longer side (square pixels); 0: the scene's
    uint64_t monteCarloRays = 10000;  // per source; 0: the sequential estimate alone
    uint64_t seed = 1;
    // The most memory the Monte Carlo check's images may take; 0: the machine's.
    double maxMemoryBytes = 0.0;
    ProgressSink progress;  // the Monte Carlo check's "Monte Carlo" events
};

struct GhostRun {
    std::unique_ptr<PreparedScene> scene;
    bool defaultScene = false;
    double imageShiftMm = 0.0;  // default scene: lens file image -> paraxial image
    GhostAnalysis analysis;
    GhostMonteCarlo monteCarlo;  // images null without the check
    int detector = 0;            // the detector ranked on (index)
    GhostReport report;
};

// The scene, built once (its notes, run.scene->geometry().notes, are the caller's to show before
// the analysis runs).
GhostRun prepareGhostRun(SceneSpec scene, const GlassCatalog& catalog, const GhostRunSpec& spec);
// The analysis and its report on the prepared run.
void runGhostAnalysis(GhostRun& run, const GlassCatalog& catalog, const GhostRunSpec& spec);

struct GhostFilesSpec {
    bool images = true;  // the Monte Carlo images and the path pictures
    double decades = 3.0;  // PNG log range
    int top = 10;          // path pictures of the first `top` ghosts (0: none)
    int pathRays = 200;    // emitted rays per path picture
    uint64_t seed = 1;
    // The path pictures' search, ghost by ghost (may be empty).
    ProgressSink progress;
};

// Into `folder` (created as needed); returns the files in the order written.
std::vector<std::filesystem::path> writeGhostFiles(const GhostRun& run,
                                                   const std::filesystem::path& folder,
                                                   const GhostFilesSpec& spec);

}  // namespace veil
