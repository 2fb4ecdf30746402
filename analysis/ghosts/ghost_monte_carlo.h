#pragma once
// The Monte Carlo check of a ghost analysis: one forward split run binned by every ghost's
// criterion (ghost_paths.h), pruned online.

#include <cstdint>
#include <functional>
#include <memory>

#include "analysis/criteria/criterion_images.h"
#include "analysis/ghosts/ghost_tracer.h"
#include "analysis/reports/progress.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

// One forward split run binned by the ghosts' criteria (and the nominal image's, first),
// pruned online: a branch is traced only while one of the criteria can still match it.
struct GhostMonteCarloOptions {
    uint64_t raysPerSource = 20000;
    // Split mode; minRelativeFlux 1e-9 (pruning bounds the tree); the transport's blocks of
    // 256 rays, so the few thousand rays a ghost table needs spread over the cores.
    TransportOptions transport;
    ProgressSink progress;  // "Monte Carlo" events, the rays done of every source's
    GhostMonteCarloOptions() { transport.minRelativeFlux = 1e-9; }
};

struct GhostMonteCarlo {
    uint64_t emittedRays = 0;  // all sources
    double seconds = 0.0;
    FluxBudget budget;
    // images->images()[0][d]: the nominal image; [1 + g][d]: ghost g of the analysis order;
    // [1 + ghosts][d]: all ghosts together (allGhostsCriterion), with its own error bars.
    std::unique_ptr<CriterionImages> images;
    double flux(size_t layer, int detector) const;
    double relativeError(size_t layer, int detector) const;  // of flux (1 sigma)
};

GhostMonteCarlo runGhostMonteCarlo(const SceneGeometry& geometry, const SceneTransport& transport,
                                   const GhostAnalysis& analysis, const GhostMonteCarloOptions& o);

}  // namespace veil
