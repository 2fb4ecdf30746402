// Automated ghost analysis (analysis/ghosts/ghosts.h) on the seed's 6-lens 360 mm lens
// (examples/lenses/longfocus_360mm.toml), a bare lens file set up as `veil ghosts` does:
// readSceneFile -> addDefaultGhostScene (a collimated 1 W source per system field filling the
// first surface, an absorbing stop plate, the detector on the image surface) -> buildSceneGeometry
// -> prepareTransport.
//
//   build/bench/veil_ghosts_bench --benchmark_repetitions=3
//
// BM_GhostsAllPairsSequential/F/T: GhostTracer::analyse() with the default GhostOptions (the
// 66 two-reflection ghosts and the nominal path, grid 64 across each beam, every wavelength)
// on T threads (tbb::global_control). F = 5: the five system fields (the CLI's default
// scene); F = 1: the on-axis field only (setFieldSources). T = 1 is timed in CPU time (of
// the benchmark thread: robust when other jobs share the cores), T = 2 in wall time with
// the CPU column summed over the process's threads. Counters:
//   ghosts, sources;
//   grid_rays_per_s: GhostSourceResult::raysTraced summed over the nominal path, every ghost
//     and every source (the grid rays of all paths, as if each path were traced on its own);
//   ray_surfaces_per_s: the surface intersections actually attempted
//     (GhostAnalysis::raySurfaceSteps: two-reflection paths share their beginnings, each ray
//     forward once, from each first reflection backward once, from each second reflection to
//     the detector; the image counts as a surface), in the unit of the baseline.
//
// BM_NominalSequential/F: the baseline in the same process. traceSequential
// (tracer/sequential/sequential_trace.h) on the same SequentialModel, for the same grid of rays
// (GhostTracer::gridRays: the same launch points, every wavelength), nominal path, apertures
// clipped; ray-surfaces counted exactly (SequentialRayResult::surface: the surfaces each ray
// reached, the failing one included).
//
// BM_GhostMonteCarloTo5pct/F/T/B: runGhostMonteCarlo (one pruned split run binned by the 67
// criteria) with 16 rays per source, doubled until the top-ranked ghost's relative error
// (GhostMonteCarlo::relativeError(1, detector), 1 sigma) is at most 5 %. Each attempt is a
// fresh run with seed 1 (so the result is reproducible). Counters: rays_per_source and
// rays_needed (all sources) of the first run that reached 5 %; seconds (that run's own wall
// time, GhostMonteCarlo::seconds: the cost of a run sized right the first time) and
// cpu_seconds (that run's CPU time, all threads: equal to the wall time of one thread on an
// otherwise idle core); search_seconds (all attempts); rel_error reached; rays_per_source_at_5pct
// (that run's error extrapolated by 1/sqrt(N) to exactly 5 %); segments_per_ray. T = threads; B =
// TransportOptions::raysPerBlock (0 = the default, 256, as veil ghosts runs it). The label names
// the top ghost.

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <chrono>
#include <ctime>
#include <map>
#include <memory>

#include "analysis/ghosts/ghost_monte_carlo.h"
#include "analysis/lens/default_scene.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace {

using namespace veil;

// CPU time of the whole process (all threads), seconds.
double processCpuSeconds() {
    timespec t{};
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Fixture {
    SceneSpec file;
    std::unique_ptr<SceneGeometry> setup;
    SceneTransport trace;
    std::unique_ptr<GhostTracer> tracer;
    GhostAnalysis analysis;     // one analyse() run, for the Monte Carlo
    std::vector<Ray> gridRays;  // the nominal grid for the baseline, with its wavelengths
    std::vector<int> gridWavelength;
};

// fields: 5 = the system fields (default scene), 1 = on axis only.
const Fixture& lens(int fields) {
    static std::map<int, std::unique_ptr<Fixture>> cache;
    auto& slot = cache[fields];
    if (slot) return *slot;
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    auto fx = std::make_unique<Fixture>();
    fx->file = readSceneFile(VEIL_SOURCE_DIR "/examples/lenses/longfocus_360mm.toml", catalog);
    addDefaultGhostScene(fx->file, catalog);
    if (fields == 1) setFieldSources(fx->file, catalog, {{0.0, 0.0}});
    fx->setup = std::make_unique<SceneGeometry>(buildSceneGeometry(fx->file, catalog));
    fx->trace = prepareTransport(fx->file, *fx->setup, catalog);
    fx->tracer = std::make_unique<GhostTracer>(*fx->setup, fx->trace, catalog, GhostOptions{});
    fx->analysis = fx->tracer->analyse();

    for (size_t k = 0; k < fx->trace.view.sources.size(); ++k)
        for (const auto& [ray, w] : fx->tracer->gridRays(static_cast<int>(k))) {
            fx->gridRays.push_back(ray);
            fx->gridWavelength.push_back(w);
        }
    slot = std::move(fx);
    return *slot;
}

void BM_GhostsAllPairsSequential(benchmark::State& state) {
    const Fixture& f = lens(static_cast<int>(state.range(0)));
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              static_cast<size_t>(state.range(1)));
    double rays = 0, steps = 0;
    size_t ghosts = 0;
    for (auto _ : state) {
        const GhostAnalysis a = f.tracer->analyse();
        ghosts = a.ghosts.size();
        steps += static_cast<double>(a.raySurfaceSteps);
        for (const GhostSourceResult& s : a.nominal.sources) rays += s.raysTraced;
        for (const GhostEstimate& g : a.ghosts)
            for (const GhostSourceResult& s : g.sources) rays += s.raysTraced;
    }
    using C = benchmark::Counter;
    state.counters["ghosts"] = static_cast<double>(ghosts);
    state.counters["sources"] = static_cast<double>(f.trace.view.sources.size());
    state.counters["grid_rays_per_s"] = C(rays, C::kIsRate);
    state.counters["ray_surfaces_per_s"] = C(steps, C::kIsRate);
}
BENCHMARK(BM_GhostsAllPairsSequential)->Args({5, 1})->Args({1, 1})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_GhostsAllPairsSequential)
    ->Args({5, 2})
    ->UseRealTime()
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kMillisecond);

void BM_NominalSequential(benchmark::State& state) {
    const Fixture& f = lens(static_cast<int>(state.range(0)));
    const SequentialModel& model = f.tracer->model();
    double rays = 0, raySurfaces = 0, ok = 0;
    for (auto _ : state) {
        for (size_t k = 0; k < f.gridRays.size(); ++k) {
            const SequentialRayResult r =
                traceSequential(model, f.gridWavelength[k], f.gridRays[k]);
            benchmark::DoNotOptimize(r.ray.origin);
            raySurfaces += r.surface;
            ok += r.ok() ? 1.0 : 0.0;
        }
        rays += static_cast<double>(f.gridRays.size());
    }
    using C = benchmark::Counter;
    state.counters["rays_per_s"] = C(rays, C::kIsRate);
    state.counters["ray_surfaces_per_s"] = C(raySurfaces, C::kIsRate);
    state.counters["ok_fraction"] = ok / std::max(rays, 1.0);
    state.counters["surfaces_per_ray"] = raySurfaces / std::max(rays, 1.0);
}
BENCHMARK(BM_NominalSequential)->Arg(5)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_GhostMonteCarloTo5pct(benchmark::State& state) {
    const Fixture& f = lens(static_cast<int>(state.range(0)));
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism,
                              static_cast<size_t>(state.range(1)));
    const int det = f.tracer->detectorIndex();
    for (auto _ : state) {
        const auto start = std::chrono::steady_clock::now();
        uint64_t perSource = 16;
        double err = kInfinity, seconds = 0.0, cpuSeconds = 0.0, segments = 0.0;
        uint64_t emitted = 0;
        for (; perSource <= (uint64_t{1} << 22); perSource *= 2) {
            GhostMonteCarloOptions o;
            o.raysPerSource = perSource;
            o.transport.seed = 1;
            if (state.range(2) > 0)
                o.transport.raysPerBlock = static_cast<uint64_t>(state.range(2));
            const double cpu0 = processCpuSeconds();
            const GhostMonteCarlo mc = runGhostMonteCarlo(*f.setup, f.trace, f.analysis, o);
            cpuSeconds = processCpuSeconds() - cpu0;
            err = mc.relativeError(1, det);
            seconds = mc.seconds;
            emitted = mc.emittedRays;
            segments = static_cast<double>(mc.budget.segments);
            if (err <= 0.05) break;
        }
        if (!f.analysis.ghosts.empty()) state.SetLabel("top: " + f.analysis.ghosts[0].path.label);
        state.counters["rays_per_source"] = static_cast<double>(perSource);
        state.counters["rays_needed"] = static_cast<double>(emitted);
        state.counters["rays_per_source_at_5pct"] =
            static_cast<double>(perSource) * (err / 0.05) * (err / 0.05);
        state.counters["seconds"] = seconds;
        state.counters["cpu_seconds"] = cpuSeconds;
        state.counters["rays_per_s"] = static_cast<double>(emitted) / seconds;
        state.counters["segments_per_ray"] = segments / static_cast<double>(emitted);
        state.counters["rel_error"] = err;
        state.counters["search_seconds"] =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    }
}
// A run splits into blocks of raysPerBlock rays for the reduction, so a run of fewer rays
// than one block stays on one thread whatever the thread count: B = 128 (5 fields) and 32
// (one field) show what 2 threads give when the run is split.
BENCHMARK(BM_GhostMonteCarloTo5pct)
    ->Args({5, 1, 0})
    ->Args({5, 2, 0})
    ->Args({5, 2, 4096})
    ->Args({1, 1, 0})
    ->Args({1, 2, 0})
    ->Args({1, 2, 4096})
    ->Iterations(1)
    ->UseRealTime()
    ->MeasureProcessCPUTime()
    ->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
