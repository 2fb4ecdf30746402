#include "analysis/runs/stray_light_run.h"

#include <chrono>
#include <cmath>
#include <limits>

#include "analysis/criteria/criterion_names.h"

namespace veil {

std::vector<StrayLightRow> StrayLightResult::report() const {
    std::vector<StrayLightRow> rows;
    for (size_t d = 0; d < images.size(); ++d) {
        const DetectorImage& img = images[d];
        const std::string name = img.geometry().name;
        rows.push_back({name, "", "", img.totalFlux(), img.totalRelativeError(emittedRays)});
        if (!layers) continue;
        for (size_t c = 0; c <= layers->criterionCount(); ++c) {
            const DetectorImage& layer = layers->images()[c][d];
            const bool rest = c == layers->criterionCount();
            rows.push_back({name, rest ? "rest" : "where" + std::to_string(c + 1),
                            rest ? "none of the above" : layers->text(c), layer.totalFlux(),
                            layer.totalRelativeError(emittedRays)});
        }
    }
    return rows;
}

StrayLightResult runStrayLight(const PreparedScene& scene, const StrayLightSpec& spec) {
    const TraceSetup& ts = scene.trace();
    StrayLightResult result;
    result.emittedRays = spec.raysPerSource * ts.transport.sources.size();
    result.fluxUnit = ts.transport.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
    if (spec.prune && spec.where.empty())
        throw ModelError(scene.file().path.string(), "pruning needs at least one criterion");

    TransportOptions options = spec.transport;
    if (!spec.where.empty()) {
        const NameTable names = criterionNames(scene.scene(), ts.transport);
        std::vector<CompiledCriterion> compiled;
        for (size_t i = 0; i < spec.where.size(); ++i)
            compiled.push_back(
                compileCriterion(spec.where[i], names, "--where " + std::to_string(i + 1)));
        result.layers = std::make_unique<CriterionImages>(spec.where, std::move(compiled),
                                                          ts.images, ts.transport.detectorOfObject);
    }
    std::unique_ptr<CriteriaFilter> filter;
    if (spec.prune) {
        filter = std::make_unique<CriteriaFilter>(result.layers->criteria());
        options.filter = filter.get();
    }
    const RayCallback extra = spec.openConsumer ? spec.openConsumer() : RayCallback{};
    RayCallback onRay;
    if (result.layers || extra) {
        options.recordHistories = true;
        RayCallback layerCallback = result.layers ? result.layers->callback() : RayCallback{};
        onRay = [layerCallback, extra](uint64_t i, const PathHistory& h) {
            if (layerCallback) layerCallback(i, h);
            if (extra) extra(i, h);
        };
    }
    const auto start = std::chrono::steady_clock::now();
    TraceResult traced = traceNonsequential(ts.transport, ts.images, spec.raysPerSource, options,
                                            spec.progress, onRay);
    if (result.layers) result.layers->finish(options.ranks);
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.budget = traced.budget;
    result.images = std::move(traced.detectors);
    return result;
}

void runStrayLightBatches(const PreparedScene& scene, const StrayLightSpec& spec, int batches,
                          const std::function<void(int batch, const StrayLightResult&)>& onBatch) {
    const uint64_t n = static_cast<uint64_t>(batches);
    for (uint64_t b = 0; b < n; ++b) {
        StrayLightSpec run = spec;
        run.raysPerSource = spec.raysPerSource / n + (b < spec.raysPerSource % n ? 1 : 0);
        run.transport.seed = spec.transport.seed + b;
        onBatch(static_cast<int>(b), runStrayLight(scene, run));
    }
}

BatchMean batchMean(const std::vector<double>& v) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (v.empty()) return {nan, nan};
    double sum = 0.0;
    for (double x : v) sum += x;
    const double m = sum / static_cast<double>(v.size());
    if (v.size() < 2) return {m, nan};
    double ss = 0.0;
    for (double x : v) ss += (x - m) * (x - m);
    return {m, std::sqrt(ss / static_cast<double>(v.size() - 1) / static_cast<double>(v.size()))};
}

}  // namespace veil
