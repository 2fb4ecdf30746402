#pragma once
// A render as a value: the one progressive loop of veil render, of the studies that render
// (sweep, pst, objects, glare) and of Python.
//
//   PreparedScene + RenderRunSpec (options, detector, criteria, stop rules, checkpoint)
//     --RenderRun (checks everything, builds the renderer; resumes a checkpoint)-->
//     --run(): pass after pass until a stop rule holds-->  per pass: RenderPassEvent
//                                                         (the studies' per-pass totals),
//                                                         a ProgressEvent
//     --> RenderResult: the images (total, components, criteria), the summary, the report
//     --writeRenderFiles()--> DETECTOR.exr, DETECTOR[.component|.whereK].png, summary.json
//
// The method and every knob: tracer/render/render.h and docs/render.md. Pass k draws the same
// random streams (passSeed) in every scene: two scenes rendered with the same spec share their
// random numbers, as the sweeps' batches do. The mean of the passes is the estimate and the
// spread of the passes its error (RenderState). Nothing here prints.
//
// Across ranks (spec.ranks): every rank makes the same RenderRun and calls run(); each pass
// splits over them; rank 0 decides when to stop, writes the checkpoint and alone gets the
// events and a result with images (the others' results are empty).

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/reports/image_output.h"
#include "analysis/reports/progress.h"
#include "tracer/render/render.h"
#include "tracer/runtime/ranks.h"

namespace veil {

struct SceneTransport;
class PreparedScene;

class RenderCriteria;

// The image a target error applies to: the total, one component, or criterion k's image.
struct RenderTarget {
    std::optional<RenderComponent> component;
    int criterion = -1;          // 0-based; -1 = none
    bool stray = true;           // the stray light (RenderState::strayLight)
    std::string text = "stray";  // as written: stray, total, visible, ..., where<k>
    // "stray", "total", a component's name, or where<k> (1-based, k <= criteria); ParseError
    // at --target-on otherwise.
    static RenderTarget parse(const std::string& text, size_t criteria);
};

// What ends a run; checked before every pass, the first that holds ends it.
struct RenderStopRules {
    double targetError = 0.0;  // the target's mean relative pixel error (from 2 passes); 0: none
    RenderTarget target;
    double timeLimitSeconds = std::numeric_limits<double>::infinity();
    int passes = 0;  // passes in all, a resumed run's included; 0 = no limit
};

struct RenderRunSpec {
    RenderOptions options;  // initialRadiusMm 0: defaultInitialRadius() of the scene
    std::string detector;   // empty: the first
    std::vector<std::string> where;  // path criteria on the joined path (render --where)
    RenderStopRules stop;
    std::filesystem::path checkpoint;  // written after every pass (atomically); empty: none
    std::filesystem::path resume;      // a checkpoint to continue; empty: a new run
    std::string scene;  // the scene as the user named it (reports; errors name the file)
    Ranks ranks = Ranks::alone();
    ProgressSink progress;  // "render" events after every pass; may be empty
    // The most memory the render may take (renderMemoryBytes, render.h); 0: the machine's
    // (its physical memory, or its container's limit).
    double maxMemoryBytes = 0.0;
};

// The per-pass totals the studies measure with: the flux on the detector per component and
// per criterion (all components).
struct RenderPassTotals {
    std::array<double, kRenderComponents> components{};
    std::vector<double> criteria;
    double total() const;
};
RenderPassTotals passTotals(const RenderPass& pass);

// After every pass, on rank 0.
struct RenderPassEvent {
    int pass = 0;                    // 1-based, a resumed run's passes counted
    const RenderPass* rendered = nullptr;  // the pass itself, during the call only
    const RenderState* state = nullptr;    // every pass so far
    double seconds = 0.0;            // since run() started
};

struct RenderResult {
    std::string scene, detector, unit;  // unit: "W" or "lm"
    RenderRunSpec spec;                 // as run (its initial radius resolved)
    ExitAperture aperture;
    RenderState state;                  // the accumulators: images on demand
    int passesBefore = 0;               // a resumed run's passes
    double seconds = 0.0;               // this run's wall clock
    double memoryBytes = 0.0;           // the estimate checked before the run (renderMemoryBytes)
    std::string stopReason;             // "target error reached", "pass limit reached", ...
    bool passCut = false;               // the time limit cut a pass under way, which was left out
    double emittedFlux = 0.0;
    // This run's totals over its passes.
    uint64_t photons = 0, gathers = 0, viewPoints = 0, prunedBranches = 0, prunedPhotons = 0;
    uint64_t backwardSegments = 0, photonSegments = 0, connectionRays = 0;
    uint64_t lastPhotonsPerSource = 0;           // the photons per source of this run's last pass
    uint64_t lastVisiblePerSource = 0;           // and its visible photons per source
    uint64_t viewPointWork = 0, photonWork = 0;  // RenderPass's, summed
    double backwardSeconds = 0.0, photonSeconds = 0.0;
    // The points drawn on small lit parts (tracer/render/part_light.h), those that reached a
    // pixel, the rays they traced and their wall clock.
    uint64_t partSamples = 0, partFound = 0, partRays = 0;
    double partSeconds = 0.0;
    RankTraffic traffic;
    bool root = true;  // false on ranks other than 0 (no images)

    int passes() const { return state.passes(); }
    double targetError() const;  // the stop rules' target image's mean relative error now
    // The run's images by layer name, in the order of its EXR: total, the components
    // (visible, direct, caustic, secondary), then per criterion whereK and its components
    // (whereK.visible, ...), then stray (the total without the image-forming light) and
    // image (the image-forming light).
    std::vector<std::pair<std::string, DetectorImage>> imageLayers() const;
    // The summary veil render writes as summary.json (and prints with --json).
    nlohmann::json summary() const;
    // The report veil render prints: fluxes with errors, passes and why the run stopped.
    // `folder`: where a run short of its target continues from (--resume).
    std::string text(const std::string& folder) const;
};

class RenderRun {
  public:
    // Checks the scene, the options and the criteria, builds the renderer and reads the
    // checkpoint to resume, before any pass: ParseError for a criterion, a detector name or
    // a missing checkpoint; ModelError for a scene with no source, no detector or nothing
    // that scatters; std::runtime_error for a checkpoint of another scene or options.
    RenderRun(const PreparedScene& scene, RenderRunSpec spec);
    ~RenderRun();
    RenderRun(const RenderRun&) = delete;
    RenderRun& operator=(const RenderRun&) = delete;

    // The fingerprint of what determines the numbers (scene, detector, options, criteria);
    // a checkpoint resumes only under the same one.
    uint64_t fingerprint() const { return fingerprint_; }
    // About how much memory the run takes at its peak (renderMemoryBytes).
    double memoryBytes() const { return memoryBytes_; }
    const RenderRunSpec& spec() const { return spec_; }
    int passesDone() const { return state_.passes(); }  // before run(): a resumed run's

    // Passes until a stop rule holds. `onPass` after every pass on rank 0 (may be empty).
    // ModelError when the time limit ends the run before its first pass. Once per RenderRun.
    RenderResult run(const std::function<void(const RenderPassEvent&)>& onPass = {});

  private:
    std::string stopReason(double seconds) const;

    const PreparedScene& scene_;
    RenderRunSpec spec_;
    const DetectorImage* detector_ = nullptr;
    std::unique_ptr<RenderCriteria> criteria_;
    ExitAperture aperture_;
    std::unique_ptr<Renderer> renderer_;
    uint64_t fingerprint_ = 0;
    double memoryBytes_ = 0.0;  // renderMemoryBytes of the run
    RenderState state_;
};

// The index of the detector named `name` among trace.images (empty: the first, 0); ParseError
// at --detector naming the scene's detectors when none has that name.
size_t findDetector(const SceneTransport& transport, const std::string& name);

// The files of a finished run into `folder`, which must exist: DETECTOR.exr (layers total,
// visible, direct, caustic, secondary, and whereK with its components), DETECTOR.png and a
// PNG per lit component and per criterion, summary.json. Returns them in that order.
// `scale`: the PNGs' colour scale (auto by default; PreviewScale).
std::vector<std::filesystem::path> writeRenderFiles(const RenderResult& result,
                                                    const std::filesystem::path& folder,
                                                    const PreviewScale& scale = {});

}  // namespace veil
