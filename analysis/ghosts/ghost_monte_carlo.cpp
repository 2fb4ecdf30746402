#include "analysis/ghosts/ghost_monte_carlo.h"

#include <chrono>

#include "analysis/criteria/criterion_names.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_transport.h"

namespace veil {

double GhostMonteCarlo::flux(size_t layer, int detector) const {
    return images ? images->images()[layer][detector].totalFlux() : 0.0;
}

double GhostMonteCarlo::relativeError(size_t layer, int detector) const {
    return images ? images->images()[layer][detector].totalRelativeError(emittedRays) : kInfinity;
}

GhostMonteCarlo runGhostMonteCarlo(const SceneGeometry& setup, const SceneTransport& trace,
                                   const GhostAnalysis& analysis, const GhostMonteCarloOptions& o) {
    const auto start = std::chrono::steady_clock::now();
    const NameTable names = criterionNames(setup.scene, trace.view);
    std::vector<std::string> texts{analysis.nominal.path.criterion};
    for (const GhostEstimate& g : analysis.ghosts) texts.push_back(g.path.criterion);
    texts.push_back(analysis.allGhostsCriterion);
    std::vector<CompiledCriterion> compiled;
    for (size_t i = 0; i < texts.size(); ++i) {
        const std::string source = i == 0 ? "nominal"
                                   : i == texts.size() - 1
                                       ? "all ghosts"
                                       : "ghost " + analysis.ghosts[i - 1].path.label;
        compiled.push_back(compileCriterion(texts[i], names, source));
    }
    GhostMonteCarlo mc;
    mc.images =
        std::make_unique<CriterionImages>(texts, std::move(compiled), trace.images,
                                          trace.view.detectorOfObject, trace.view.nextDetector);
    const CriteriaFilter filter(mc.images->criteria());
    TransportOptions to = o.transport;
    to.mode = TransportOptions::Mode::Split;
    to.recordHistories = true;
    to.filter = &filter;
    std::function<void(uint64_t)> progress;
    if (o.progress) {
        const uint64_t total = o.raysPerSource * trace.view.sources.size();
        progress = [&o, total](uint64_t done) { o.progress({"Monte Carlo", done, total}); };
        progress(0);
    }
    const TraceResult r = traceNonsequential(trace.view, trace.images, o.raysPerSource, to,
                                             progress, mc.images->callback(to.ranks.single()));
    mc.images->finish();
    mc.budget = r.budget;
    mc.emittedRays = o.raysPerSource * trace.view.sources.size();
    mc.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return mc;
}

}  // namespace veil
