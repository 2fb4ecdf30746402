#include "analysis/runs/render_run.h"

#include <memory>

#include "analysis/criteria/criterion_names.h"
#include "analysis/criteria/render_criteria.h"
#include "lensdata/errors.h"

namespace veil {

size_t findDetector(const TraceSetup& trace, const std::string& name) {
    if (name.empty()) return 0;
    std::string names;
    for (size_t d = 0; d < trace.images.size(); ++d) {
        names += (d ? ", " : "") + trace.images[d].geometry().name;
        if (trace.images[d].geometry().name == name) return d;
    }
    throw ParseError({"--detector", 1, 1},
                     "no detector '" + name + "' in the scene (it has " + names + ")");
}

double RenderPassTotals::total() const {
    double t = 0.0;
    for (double c : components) t += c;
    return t;
}

std::string runRenderPasses(const PreparedScene& scene, const RenderRunSpec& spec,
                            const std::function<void(int pass, const RenderPassTotals&)>& onPass) {
    const TraceSetup& trace = scene.trace();
    const TransportScene& ts = trace.transport;
    if (trace.images.empty())
        throw ModelError(scene.file().path.string(), "the scene has no detector to render");
    const DetectorImage& detector = trace.images[findDetector(trace, spec.detector)];
    RenderOptions options = spec.options;
    if (options.initialRadiusMm <= 0.0) options.initialRadiusMm = defaultInitialRadius(ts);
    options.check();
    std::unique_ptr<RenderCriteria> criteria;
    if (!spec.where.empty()) {
        const NameTable names = criterionNames(*ts.scene, ts);
        std::vector<CompiledCriterion> compiled;
        for (size_t i = 0; i < spec.where.size(); ++i)
            compiled.push_back(
                compileCriterion(spec.where[i], names, "--where " + std::to_string(i + 1)));
        criteria = std::make_unique<RenderCriteria>(std::move(compiled), names);
    }
    const ExitAperture aperture = exitApertureFor(*ts.scene, detector.geometry());
    const Renderer renderer(ts, detector, aperture, options, criteria.get());
    RenderState state(detector.geometry(), options.initialRadiusMm, options.alpha,
                      static_cast<int>(spec.where.size()));
    for (int k = 1; k <= spec.passes; ++k) {
        const RenderPass pass = renderer.runPass(k, state.radiusMm(), state.learned());
        state.add(pass);
        RenderPassTotals totals;
        totals.pass = &pass;
        for (int c = 0; c < kRenderComponents; ++c)
            for (double v : pass.pixels[static_cast<size_t>(c)])
                totals.components[static_cast<size_t>(c)] += v;
        for (const auto& byComponent : pass.criteria) {
            double sum = 0.0;
            for (const auto& pixels : byComponent)
                for (double v : pixels) sum += v;
            totals.criteria.push_back(sum);
        }
        onPass(k, totals);
    }
    return detector.geometry().name;
}

}  // namespace veil
