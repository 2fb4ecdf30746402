// The renderer against forward Monte Carlo on the image of diffuse stray light: both run for
// the same wall time on the same scene, the light selected by the same criterion (default
// `scatter`: every path with a scatter event), and each gives its mean relative pixel error
// over the pixels the render lights (at least 1 % of its mean pixel value, RenderState's
// definition; forwardLitError says how forward Monte Carlo's is predicted from its hits).
// From each method's error rate the time to a target error follows: forward
// Monte Carlo's error falls as t^-1/2, the progressive renderer's as t^(-alpha/2) (its
// variance as n^-alpha). The equal-time images are written side by side for the docs.
//
//   build/bench/veil_render_vs_trace_bench [scene] [seconds per method] [png folder] [criterion]
//
// Defaults: examples/scenes/longfocus_360mm_sun.toml, 60 s, no images ("" also: none),
// `scatter`. Results and the command
// are in docs/performance.md.

#include <tbb/global_control.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "analysis/criteria/criterion_names.h"
#include "analysis/criteria/render_criteria.h"
#include "analysis/reports/image_output.h"
#include "analysis/runs/stray_light_run.h"
#include "lensdata/glass_catalog.h"
#include "tracer/records/detector.h"
#include "tracer/render/render.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/transport/interaction.h"

namespace {

using namespace veil;

double now() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

// Forward Monte Carlo's mean relative pixel error over the pixels the reference lights (at
// least 1 % of its mean pixel value), predicted from its hits: a pixel expecting n_p hits of
// the run's weight spread kappa = <w^2> / <w>^2 has relative error sqrt(kappa / n_p), with
// n_p = hits x (the reference's share of the flux in p). Pixels the run left empty count
// with the error their share predicts, not as zero. Treating the hits as independent
// ignores the branches of one ray landing together: it favours forward Monte Carlo.
std::pair<double, int> forwardLitError(const DetectorImage& forward, const DetectorImage& ref) {
    double hits = 0.0, w = 0.0, w2 = 0.0;
    for (int p = 0; p < forward.pixelCount(); ++p) {
        hits += static_cast<double>(forward.counts()[static_cast<size_t>(p)]);
        w += forward.fluxes()[static_cast<size_t>(p)];
        w2 += forward.fluxesSquared()[static_cast<size_t>(p)];
    }
    const double kappa = w2 * hits / (w * w);
    const int pixels = ref.pixelCount();
    const double threshold = RenderState::kLitFraction * ref.totalFlux() / pixels;
    double sum = 0.0;
    int lit = 0;
    for (int p = 0; p < pixels; ++p) {
        const double v = ref.flux(p);
        if (!(v > 0.0) || v < threshold) continue;
        sum += std::sqrt(kappa / (hits * v / ref.totalFlux()));
        ++lit;
    }
    return {lit ? sum / lit : INFINITY, lit};
}

// The renderer's error after n passes, from its passes: a pass's variance is A (the view
// points' sampling, the same every pass) plus B k^(1 - alpha) (the photon density estimate,
// growing as the radius shrinks, r_k^2 ~ k^(alpha - 1)), so the mean of n passes has
// variance A / n + B S_n / n^2 with S_n = sum_{k <= n} k^(1 - alpha). A and B (>= 0) are
// fitted by least squares to e_n^2 n = A + B S_n / n over the passes from kFirstPass on (the
// errors of fewer passes are too noisy); the passes to a target error follow. B alone is
// the t^(-alpha/2) rate; A alone t^(-1/2).
struct VarianceModel {
    static constexpr int kFirstPass = 4;
    double a = 0.0, b = 0.0;
    static double s(int n, double alpha) {
        double sum = 0.0;
        for (int k = 1; k <= n; ++k) sum += std::pow(double(k), 1.0 - alpha);
        return sum;
    }
    double variance(double n, double alpha) const {
        // S_n for non-integer n by its integral's growth: S_n ~ n^(2 - alpha) / (2 - alpha).
        const int whole = static_cast<int>(n);
        const double sn = n < 1e6 ? s(whole, alpha) : std::pow(n, 2.0 - alpha) / (2.0 - alpha);
        return a / n + b * sn / (n * n);
    }
    double passesTo(double target, double alpha) const {
        double hi = 1.0;
        while (variance(hi, alpha) > target * target && hi < 1e12) hi *= 2.0;
        double lo = hi / 2.0;
        for (int i = 0; i < 60; ++i) {
            const double mid = 0.5 * (lo + hi);
            (variance(mid, alpha) > target * target ? lo : hi) = mid;
        }
        return hi;
    }
};

VarianceModel fitVarianceModel(const std::vector<double>& errors, double alpha) {
    std::vector<double> x, y;
    for (int n = VarianceModel::kFirstPass; n <= static_cast<int>(errors.size()); ++n) {
        x.push_back(VarianceModel::s(n, alpha) / n);
        y.push_back(errors[static_cast<size_t>(n - 1)] * errors[static_cast<size_t>(n - 1)] * n);
    }
    VarianceModel m;
    const double count = static_cast<double>(x.size());
    if (count < 2) return m;
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (size_t i = 0; i < x.size(); ++i) {
        sx += x[i];
        sy += y[i];
        sxx += x[i] * x[i];
        sxy += x[i] * y[i];
    }
    m.b = (count * sxy - sx * sy) / (count * sxx - sx * sx);
    m.a = (sy - m.b * sx) / count;
    if (m.b < 0.0) {  // no growth seen: view points only
        m.b = 0.0;
        m.a = sy / count;
    } else if (m.a < 0.0) {  // photons only
        m.a = 0.0;
        m.b = sxy / sxx;
    }
    return m;
}

}  // namespace

int main(int argc, char** argv) {
    const std::string scenePath =
        argc > 1 ? argv[1]
                 : std::string(VEIL_SOURCE_DIR) + "/examples/scenes/longfocus_360mm_sun.toml";
    const double budget = argc > 2 ? std::stod(argv[2]) : 60.0;
    const std::string pngDir = argc > 3 ? argv[3] : "";
    const std::string where = argc > 4 ? argv[4] : "scatter";
    const double target = 0.05;

    const auto scene = PreparedScene::read(scenePath, GlassCatalog::builtIn());
    const SceneTransport& trace = scene->transport();
    const TransportView& ts = trace.view;
    const DetectorImage& detector = trace.images.front();

    // Forward Monte Carlo without bias: split mode, no minimum flux, Russian roulette below
    // 1 % (veil trace's default cull at 1e-4 drops the scatter of weak ghost branches, a
    // fifth of the Sun example's scattered light); a short run sizes the one that fills
    // the budget.
    StrayLightSpec spec;
    spec.where = {where};
    spec.transport.minRelativeFlux = 0.0;
    spec.transport.rouletteRelativeFlux = 0.01;
    spec.raysPerSource = 10000;
    double t0 = now();
    runStrayLight(*scene, spec);
    const double perRay = (now() - t0) / spec.raysPerSource;
    spec.raysPerSource = static_cast<uint64_t>(budget / perRay);
    t0 = now();
    const StrayLightResult forward = runStrayLight(*scene, spec);
    const double forwardSeconds = now() - t0;
    const DetectorImage& forwardImage = forward.layers->images()[0][0];

    // The renderer, passes until the same budget is spent.
    const NameTable names = criterionNames(*ts.scene, ts);
    std::vector<CompiledCriterion> compiled{compileCriterion(where, names)};
    const RenderCriteria criteria(std::move(compiled), names);
    RenderOptions ro;
    ro.initialRadiusMm = defaultInitialRadius(ts);
    // The measured image is scattered light only: the photons that split every branch for the
    // sources' visible light (--ghost-photons) would cost without adding to it.
    ro.ghostPhotonsPerPass = 1;
    const Renderer renderer(ts, detector, exitApertureFor(*ts.scene, detector.geometry()), ro,
                            &criteria);
    RenderState state(detector.geometry(), ro.initialRadiusMm, ro.alpha, 1);
    t0 = now();
    std::vector<double> errors;  // after pass n (index n - 1)
    while (now() - t0 < budget || state.passes() < 2) {
        state.add(renderer.runPass(state.passes() + 1, state.radiusMm(), state.learned()));
        errors.push_back(state.criterionMeanRelativeError(0));
    }
    const double renderSeconds = now() - t0;
    const VarianceModel model = fitVarianceModel(errors, ro.alpha);
    const double renderError = state.criterionMeanRelativeError(0);
    const DetectorImage renderImage = state.criterionTotal(0);
    const auto [forwardError, forwardLit] = forwardLitError(forwardImage, renderImage);

    // No hit at all (a dark scene): forward Monte Carlo's time to the target is bounded from
    // below. Fewer than 3 hits were expected in the run (95 % confidence for none seen), and
    // the target needs at least 1 / target^2 hits in each lit pixel.
    const bool forwardFound = forwardImage.totalFlux() > 0.0;
    const double forwardTo = forwardFound ? forwardSeconds * std::pow(forwardError / target, 2.0)
                                          : forwardSeconds * forwardLit / (target * target) / 3.0;
    const double renderTo = renderSeconds * std::pow(renderError / target, 2.0 / ro.alpha);
    const double renderModelTo = renderSeconds / state.passes() * model.passesTo(target, ro.alpha);
    std::printf("scene %s, light '%s', %d threads; lit pixels: the render's image's, for both\n",
                scenePath.c_str(), where.c_str(),
                static_cast<int>(tbb::global_control::active_value(
                    tbb::global_control::max_allowed_parallelism)));
    std::printf(
        "| method | run | time (s) | flux (W) | mean pixel error | lit pixels | "
        "time to %.0f %% (extrapolated) |\n| --- | --- | ---: | --- | ---: | ---: | ---: |\n",
        100 * target);
    if (forwardFound)
        std::printf("| veil trace | %llu rays | %.1f | %.4e +- %.1f %% | %.1f %% | %d | %.3g s |\n",
                    static_cast<unsigned long long>(forward.emittedRays), forwardSeconds,
                    forwardImage.totalFlux(),
                    100 * forwardImage.totalRelativeError(forward.emittedRays), 100 * forwardError,
                    forwardLit, forwardTo);
    else
        std::printf("| veil trace | %llu rays | %.1f | 0 (no hit) | - | %d | > %.3g s |\n",
                    static_cast<unsigned long long>(forward.emittedRays), forwardSeconds,
                    forwardLit, forwardTo);
    std::printf(
        "| veil render | %d passes | %.1f | %.4e +- %.1f %% | %.1f %% | %d | %.3g s |\n",
        state.passes(), renderSeconds, renderImage.totalFlux(),
        100 * std::sqrt(renderImage.totalVariance(state.passes())) / renderImage.totalFlux(),
        100 * renderError, forwardLit, renderTo);
    std::printf(
        "render is %s%.3gx faster to %.0f %% mean pixel error (the renderer at "
        "t^-alpha/2)\n",
        forwardFound ? "" : "more than ", forwardTo / renderTo, 100 * target);
    std::printf(
        "renderer's variance fitted over passes %d..%d as A/n + B S_n/n^2 (S_n = sum k^(1 - "
        "alpha)): A %.4g, B %.4g; its error at %d passes %.1f %% (measured %.1f %%); time to "
        "%.0f %% %.3g s: %s%.3gx faster\n",
        VarianceModel::kFirstPass, state.passes(), model.a, model.b, state.passes(),
        100 * std::sqrt(model.variance(state.passes(), ro.alpha)), 100 * renderError, 100 * target,
        renderModelTo, forwardFound ? "" : "more than ", forwardTo / renderModelTo);

    if (!pngDir.empty()) {
        std::filesystem::create_directories(pngDir);
        PreviewOptions po;
        po.scale.decades = 3.0;
        po.title = "veil trace, " + std::to_string(static_cast<int>(forwardSeconds)) +
                   " s: scattered light";
        po.emittedRays = forward.emittedRays;
        writeDetectorPng(std::filesystem::path(pngDir) / "render_equal_time_trace.png",
                         forwardImage, po);
        po.title = "veil render, " + std::to_string(static_cast<int>(renderSeconds)) +
                   " s: scattered light";
        po.emittedRays = static_cast<uint64_t>(state.passes());
        writeDetectorPng(std::filesystem::path(pngDir) / "render_equal_time_render.png",
                         renderImage, po);
    }
    return 0;
}
