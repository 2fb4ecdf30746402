#pragma once
// Forward nonsequential Monte Carlo transport through a Scene.
//
// Every emitted ray is followed from its source through the scene: at each hit the surface's
// optical property splits the flux into channels (specular reflection, refraction, diffuse
// reflection and transmission, absorption). Two ways to follow them:
//   split   every non-empty channel becomes a branch carrying its share of the flux (the
//           default: ghosts live in the weak reflected branches, and splitting sees them all);
//           branches deeper than maxSplitDepth splits are culled;
//   random  one channel is chosen with probability proportional to its share, and the ray
//           carries the whole non-absorbed flux on.
// After every bounce, in both modes and whether the surface split the flux or kept one
// channel (an opaque diffuse mount has only its scatter channel), a branch below
// minRelativeFlux of its ray's emitted flux either plays Russian roulette, when
// rescueRelativeFlux > 0: it survives with probability flux / rescue, carrying the rescue flux
// (unbiased; veil trace's default, rescue 1e-2), or is cut (biased: its flux is lost, counted
// as culled and as cut). A branch below rouletteRelativeFlux plays Russian roulette too,
// carrying that threshold's flux. So a ray bouncing inside a 1 % black mount stops after two
// or three bounces at 1e-4, not after a hundred at 1e-38 W.
//
// Every surface interaction is the shared step of tracer/transport/interaction.h; this pass carries
// flux forward and records the events.
//
// Bookkeeping: emitted = detected + absorbed + escaped + culled + dropped, exactly (up to
// rounding) when roulette is off; with roulette the survivors' gain is reported separately so
// the balance still closes: emitted + rouletteGain = detected + absorbed + escaped + culled +
// dropped. Dropped flux (a channel with no direction, tracer/transport/interaction.h) is counted by
// reason and never booked as absorbed: a lossless scene absorbs exactly nothing.
//
// Determinism: ray i draws its random numbers from CounterRng(seed, i), and per-ray results
// are collected over fixed blocks of rays, traced in parallel, and added to the images in block
// order (tbb::parallel_pipeline with a serial in-order last stage), so every thread count gives
// bitwise the same detector images and budget. A block keeps a log of its hits, not an image:
// memory is the images plus a few blocks' logs, whatever the ray count.

#include <cstdint>
#include <functional>
#include <ostream>
#include <vector>

#include "geometry/scene.h"
#include "tracer/light/source.h"
#include "tracer/records/detector.h"
#include "tracer/runtime/ranks.h"
#include "tracer/surfaces/media.h"
#include "tracer/surfaces/optical_property.h"
#include "tracer/transport/branch_filter.h"
#include "tracer/transport/interaction.h"

namespace veil {

class PathHistory;

struct TransportOptions {
    enum class Mode { Split, Random };
    Mode mode = Mode::Split;
    double minRelativeFlux = 1e-4;      // below this share (every bounce): roulette or cut
    double rescueRelativeFlux = 0.0;    // > 0: roulette below minRelativeFlux, kept at this
                                        // share; 0: cut (biased)
    int maxSplitDepth = 64;             // split mode: cull deeper branches
    double rouletteRelativeFlux = 0.0;  // 0 = no Russian roulette
    int maxSegments = 1000;             // per branch
    uint64_t seed = 1;
    // Rays per reduction block. Blocks are traced in parallel and added in block order, so
    // the result is the same for any thread or rank count; the block size is part of the
    // result (the budget's sums change in their last bits with it). 256 keeps the few
    // thousand rays of a slow scene on every core (a run of fewer rays than one block is one
    // thread's work) and costs nothing per block measurable (docs/performance.md).
    uint64_t raysPerBlock = 256;
    // Record every ray's path history (tracer/records/path_history.h) and hand it to the onRay
    // callback of traceNonsequential(). Costs a node append per event.
    bool recordHistories = false;
    // Online pruning (may be null): branches whose filter state turns false are culled with
    // CullReason::Criterion. Only what the filter may want is traced to the end.
    const BranchFilter* filter = nullptr;
    // The ranks the rays are split over (tracer/runtime/ranks.h): blocks by index, the images and
    // the budget complete on rank 0 only, bitwise those of one process. onRay is called on the rank
    // that traced the ray.
    Ranks ranks = Ranks::alone();
};
std::ostream& operator<<(std::ostream& os, const TransportOptions& o);

struct FluxBudget {
    double emitted = 0.0;
    double detected = 0.0;
    double absorbedSurface = 0.0;
    double absorbedVolume = 0.0;
    double escaped = 0.0;
    double culled = 0.0;
    // Of culled, the flux cut without roulette (below minRelativeFlux without rescue, beyond
    // maxSplitDepth or maxSegments): light lost to the estimate, the most the detectors can
    // lack (roulette's losses are paid back by its survivors).
    double cut = 0.0;
    double dropped = 0.0;  // channels without a direction (tracer/transport/interaction.h)
    double rouletteGain = 0.0;
    uint64_t droppedBranches[kDropReasons] = {};  // by DropReason
    uint64_t prunedBranches = 0;  // culled by the online filter (CullReason::Criterion)
    uint64_t rays = 0;
    uint64_t segments = 0;
    uint64_t branches = 0;
    double absorbed() const { return absorbedSurface + absorbedVolume; }
    // (emitted + rouletteGain) - (detected + absorbed + escaped + culled + dropped)
    double imbalance() const;
    void merge(const FluxBudget& o);
};
std::ostream& operator<<(std::ostream& os, const FluxBudget& b);

struct TraceResult {
    FluxBudget budget;
    std::vector<DetectorImage> detectors;
};

// Traces `raysPerSource` rays from every source. `detectors` are the empty images to fill
// (one per detector, in detectorOfObject's numbering). `progress` (may be empty) is called
// from one thread with the number of rays done so far.
// With options.recordHistories, onRay(rayIndex, history) is called once per emitted ray,
// from worker threads, concurrently: it must be thread-safe (RayDatabaseWriter::add is).
using RayCallback = std::function<void(uint64_t, const PathHistory&)>;

// A trace that stops and goes on (veil trace's checkpoints; one process only).
struct TraceContinuation {
    // Resumed: the rays below `added` are in `budget` and `images` already. Tracing starts at
    // ray `start` (a multiple of the block size, at most `added`): the rays from there on are
    // traced again for onRay's consumers, whose own marks may lie behind `added`, and the
    // blocks below `added` are not added again. `images` empty: a new trace.
    uint64_t start = 0, added = 0;
    FluxBudget budget;
    std::vector<DetectorImage> images;
    // Called in block order after each block is added (and after each block below `added`):
    // the rays added so far, the budget and the images.
    std::function<void(uint64_t added, const FluxBudget&, const std::vector<DetectorImage>&)>
        afterBlock;
};

// `continuation` (may be null): resume from a checkpoint (its images are moved from), and take
// checkpoints; throws
// std::invalid_argument with several ranks, or a start that is no block boundary.
TraceResult traceNonsequential(const TransportView& ts, const std::vector<DetectorImage>& detectors,
                               uint64_t raysPerSource, const TransportOptions& options,
                               const std::function<void(uint64_t)>& progress = {},
                               const RayCallback& onRay = {},
                               TraceContinuation* continuation = nullptr);

}  // namespace veil
