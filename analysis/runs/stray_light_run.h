#pragma once
// A stray light run as a value: a spec in, a result out, independent of the command line.
//
//   PreparedScene + StrayLightSpec (rays per source, transport options, path criteria, online
//   pruning, a per-ray consumer such as the ray database)
//     --runStrayLight--> StrayLightResult: the flux budget, every detector's image, the
//       criterion layers (one per criterion plus "rest"), and report() -> the rows every
//       output format prints: flux per detector and per criterion with relative errors;
//       summary() and text(), what veil trace writes and prints
//     --writeTraceFiles--> DETECTOR.exr, DETECTOR[.whereK|.rest].png, summary.json
//
// Criteria are compiled against the scene before the first ray is traced: a typo costs
// nothing. `veil trace` is this plus writing images and the summary; studies (sweeps, point
// source transmittance) compose runs.

#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/criteria/criterion_images.h"
#include "analysis/reports/image_output.h"
#include "analysis/reports/progress.h"
#include "analysis/runs/trace_checkpoint.h"

namespace veil {

class PreparedScene;

struct StrayLightSpec {
    std::string scene;  // the scene as the user named it (the summary); empty: the file's path
    uint64_t raysPerSource = 0;
    // transport.ranks: the rays split over MPI ranks (tracer/runtime/ranks.h); every rank calls
    // runStrayLight, and the result is complete on rank 0 only.
    TransportOptions transport;
    // Path criteria (docs/criteria.md): one detector layer each, plus "rest".
    std::vector<std::string> where;
    // Cull branches once no criterion can match them (needs at least one criterion; then only
    // the criterion layers are complete).
    bool prune = false;
    // Opens a per-ray consumer (the ray database) once the spec has been checked, just
    // before the first ray, so a bad spec writes nothing; the consumer is then called once
    // per emitted ray with its history, from worker threads (histories are recorded).
    std::function<RayCallback()> openConsumer;
    // "trace" events, the rays done of every source's (from one thread; may be empty).
    ProgressSink progress;
    // The most memory the run may take (traceMemoryBytes); 0: the machine's.
    double maxMemoryBytes = 0.0;
    // Checkpoints (one process; analysis/runs/trace_checkpoint.h): the run's state written to
    // `checkpoint` after a block of rays, at most every checkpointSeconds (0: after every
    // block); with resume the run goes on from that file, to the result it would have had.
    std::filesystem::path checkpoint;
    double checkpointSeconds = 60.0;
    bool resume = false;
    // The per-ray consumer's part of a checkpoint (the ray database's mark), taken with each;
    // on resume given back before openConsumer is called. consumerKey names the consumer in
    // the run's fingerprint ("" for none).
    std::function<ConsumerMark()> consumerMark;
    std::function<void(const ConsumerMark&)> restoreConsumer;
    std::string consumerKey;
};

// One row of the report: a detector's total or one of its criterion layers.
struct StrayLightRow {
    std::string detector;
    std::string layer;           // "" for the detector's total, "where1", ..., "rest"
    std::string criterion;       // the criterion's text; "none of the above" for "rest"
    double flux = 0.0;           // W or lm
    double relativeError = 0.0;  // 1 sigma; NaN where no ray arrived
};

struct StrayLightResult {
    FluxBudget budget;
    std::vector<DetectorImage> images;        // one per detector
    std::unique_ptr<CriterionImages> layers;  // null without criteria
    uint64_t emittedRays = 0;
    uint64_t resumedFromRay = 0;  // resumed: the first ray traced again (not in summary())
    std::string fluxUnit;  // "W" or "lm"
    double seconds = 0.0;  // wall time of the trace
    double memoryBytes = 0.0;  // the estimate checked before the trace (traceMemoryBytes)
    // What the run was, for its reports.
    std::string scene;
    uint64_t raysPerSource = 0, seed = 0;
    bool prune = false;
    std::vector<std::string> detectorObjects;  // per detector: the object it records on

    // Detector d's images by layer name, in the order of its EXR: the image ("" alone, "all"
    // beside criteria), then where1, where2, ... and rest.
    std::vector<std::pair<std::string, const DetectorImage*>> imageLayers(size_t d) const;
    // Per detector: its total, then its criterion layers in order (when there are criteria).
    std::vector<StrayLightRow> report() const;
    // What veil trace writes as summary.json: the flux budget and every detector's flux with
    // its error, split by criterion.
    nlohmann::json summary() const;
    // What veil trace prints: the budget, then the detectors.
    std::string text() const;
};

// One EXR per detector (its total, "all", and its criterion layers), a PNG of each, and
// summary.json, into `folder` (created as needed); returns them in that order. `scale`: the
// PNGs' colour scale (auto by default; PreviewScale).
std::vector<std::filesystem::path> writeTraceFiles(const StrayLightResult& result,
                                                   const std::filesystem::path& folder,
                                                   const PreviewScale& scale = {});

// About how many bytes a trace holds at its peak beyond what the process holds before it: per
// detector its image and, with criteria, one image per criterion and the rest (each 24 bytes a
// pixel), plus the copy its PNG is scaled on; the rays in flight are a few blocks' logs,
// whatever the ray count. runStrayLight checks it against the machine's memory (or
// maxMemoryBytes) before the first ray.
double traceMemoryBytes(const std::vector<DetectorImage>& detectors, size_t criteria);

// Throws ParseError for a criterion that does not parse or names nothing in the scene, and
// ModelError when the scene has no source or prune is asked without criteria, before tracing.
StrayLightResult runStrayLight(const PreparedScene& scene, const StrayLightSpec& spec);

// The spec's rays in `batches` runs with the seeds seed, seed + 1, ... (the first
// raysPerSource % batches runs one ray more): the common random numbers of the studies
// (sweep, pst), whose errors come from the spread of the batch values. Each batch's result
// goes to `onBatch` in order.
void runStrayLightBatches(const PreparedScene& scene, const StrayLightSpec& spec, int batches,
                          const std::function<void(int batch, const StrayLightResult&)>& onBatch);

// The mean of batch values and its standard error from their spread (NaN error below two
// values, NaN mean for none).
struct BatchMean {
    double value = 0.0;
    double error = 0.0;
};
BatchMean batchMean(const std::vector<double>& values);

}  // namespace veil
