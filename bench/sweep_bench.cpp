// Time per variant of a sweep (analysis/studies/sweep.h): a property-only edit, which reuses the
// first variant's geometry, against a geometry edit, which rebuilds the scene (lens solids,
// mechanics meshed and checked with CGAL, the Embree scene), each against the trace alone in
// the same process.
//
//   build/bench/veil_sweep_bench --benchmark_min_time=1
//
// The scene is examples/scenes/longfocus_360mm_sun.toml; every variant traces 2000 rays in
// 4 batches (split mode, the default transport). BM_SweepPropertyVariant sweeps the mounts'
// reflectance over three values, BM_SweepGeometryVariant the retaining rings' width; each
// reports `seconds_per_variant`, the mean over the second and third variants (the first one
// builds in both), and BM_TraceOnly the same rays traced on a scene built outside the
// timed loop. Results and the command are in docs/performance.md.

#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>

#include "analysis/runs/stray_light_run.h"
#include "analysis/studies/sweep.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"

namespace {

using namespace veil;

const char* kScene = VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml";
constexpr uint64_t kRays = 2000;
constexpr int kBatches = 4;

void sweepVariants(benchmark::State& state, const std::string& vary) {
    const std::filesystem::path folder =
        std::filesystem::temp_directory_path() / "veil_sweep_bench";
    double seconds = 0.0, variants = 0.0;
    for (auto _ : state) {
        std::filesystem::remove_all(folder);  // no resume: every variant is measured
        SweepSpec spec;
        spec.scene = kScene;
        spec.axes = {parseSweepAxis(vary)};
        spec.raysPerSource = kRays;
        spec.batches = kBatches;
        spec.folder = folder;
        const SweepResult r = runSweep(spec, GlassCatalog::builtIn());
        for (size_t k = 1; k < r.variants.size(); ++k) {
            if (!r.variants[k].error.empty()) state.SkipWithError(r.variants[k].error.c_str());
            seconds += r.variants[k].seconds;
            variants += 1.0;
        }
    }
    std::filesystem::remove_all(folder);
    state.counters["seconds_per_variant"] = seconds / std::max(variants, 1.0);
}

}  // namespace

void BM_SweepPropertyVariant(benchmark::State& state) {
    sweepVariants(state, "properties.black_anodized.scatter.reflectance=0.05,0.06,0.07");
}
BENCHMARK(BM_SweepPropertyVariant)->Unit(benchmark::kSecond);

void BM_SweepGeometryVariant(benchmark::State& state) {
    sweepVariants(state, "mechanics.retainers.width_mm=2.0,2.1,2.2");
}
BENCHMARK(BM_SweepGeometryVariant)->Unit(benchmark::kSecond);

// The baseline: the same rays and batches traced on a scene prepared outside the loop.
void BM_TraceOnly(benchmark::State& state) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const auto prepared = PreparedScene::read(kScene, catalog);
    double seconds = 0.0, runs = 0.0;
    for (auto _ : state) {
        const auto start = std::chrono::steady_clock::now();
        for (int b = 0; b < kBatches; ++b) {
            StrayLightSpec spec;
            spec.raysPerSource = kRays / kBatches;
            spec.transport.seed = 1 + static_cast<uint64_t>(b);
            benchmark::DoNotOptimize(runStrayLight(*prepared, spec).budget.detected);
        }
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        runs += 1.0;
    }
    state.counters["seconds_per_variant"] = seconds / std::max(runs, 1.0);
}
BENCHMARK(BM_TraceOnly)->Unit(benchmark::kSecond);

BENCHMARK_MAIN();
