// Nonsequential Monte Carlo rate on one core: the seed's 6-lens 360 mm lens with its
// mechanics and the Sun 7 degrees off axis (examples/scenes/longfocus_360mm_sun.toml:
// uncoated faces split at every interface, 5 % Lambertian mounts, ground-glass lens edges,
// 10 % Lambertian stop edge), default transport options (split mode, branches below 1e-4 of
// their ray's flux culled).
//
//   build/bench/veil_nonsequential_bench --benchmark_min_time=5
//
// BM_TraceSun7: rays/s (emitted) and segments/s. BM_RawEmbree: the baseline measured in the
// same process, rtcIntersect1 on an Embree scene holding the same mechanics meshes alone,
// for random rays inside the lens (one query = one segment's worth of work at best).

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <mutex>
#include <random>

#include "analysis/criteria/criterion_images.h"
#include "analysis/criteria/criterion_names.h"
#include "bench/raw_embree.h"
#include "geometry/embree_scene.h"
#include "geometry/scene.h"
#include "lensdata/glass_catalog.h"
#include "tracer/records/path_history.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/scene/scene_transport.h"

namespace {

using namespace veil;

struct Fixture {
    SceneSpec file;
    std::unique_ptr<SceneGeometry> setup;
    SceneTransport trace;
    std::unique_ptr<EmbreeScene> raw;
    std::vector<Ray> rays;
    // The rays of the tracer's own segments (from recorded histories of 200 emitted rays),
    // with the object and triangle each starts on and the medium it travels in.
    std::vector<Ray> segmentRays;
    std::vector<std::pair<int, int>> segmentStarts;
    std::vector<int> segmentMedia;
};

const Fixture& sun7() {
    static const std::unique_ptr<Fixture> f = [] {
        const GlassCatalog& catalog = GlassCatalog::builtIn();
        auto fx = std::make_unique<Fixture>();
        fx->file =
            readSceneFile(VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml", catalog);
        fx->setup = std::make_unique<SceneGeometry>(buildSceneGeometry(fx->file, catalog));
        fx->trace = prepareTransport(fx->file, *fx->setup, catalog);
        fx->raw = std::make_unique<EmbreeScene>(fx->setup->scene.meshes());
        const Bounds3 b = fx->setup->scene.bounds();
        std::mt19937_64 rng(7);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::normal_distribution<double> n;
        for (int i = 0; i < 4096; ++i) {
            const Vec3 o(b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                         b.lo.z + u(rng) * (b.hi.z - b.lo.z));
            fx->rays.push_back({o, glm::normalize(Vec3(n(rng), n(rng), n(rng)))});
        }
        TransportOptions o;
        o.recordHistories = true;
        o.seed = 99;
        std::mutex m;
        traceNonsequential(
            fx->trace.view, fx->trace.images, 200, o, {}, [&](uint64_t, const PathHistory& h) {
                std::lock_guard lock(m);
                for (const PathNode& node : h.nodes()) {
                    const EventType t = node.type;
                    if (t == EventType::Exit || t == EventType::DetectorHit ||
                        t == EventType::SurfaceAbsorb || t == EventType::Culled)
                        continue;
                    fx->segmentRays.push_back({node.position, node.direction});
                    fx->segmentStarts.emplace_back(t == EventType::Emit ? -1 : node.object,
                                                   t == EventType::Emit ? -1 : node.face);
                    fx->segmentMedia.push_back(node.medium);
                }
            });
        return fx;
    }();
    return *f;
}

// The timed loop of the Sun traces: `raysPerIteration` rays with a new seed each iteration
// on `threads` threads, rates as counters.
void traceSun7(benchmark::State& state, size_t threads, uint64_t raysPerIteration,
               const TransportOptions& options) {
    const Fixture& f = sun7();
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    TransportOptions o = options;
    uint64_t seed = 1;
    double rays = 0, segments = 0;
    for (auto _ : state) {
        o.seed = seed++;
        const TraceResult r = traceNonsequential(f.trace.view, f.trace.images, raysPerIteration, o);
        rays += static_cast<double>(r.budget.rays);
        segments += static_cast<double>(r.budget.segments);
    }
    state.counters["rays_per_s"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
    state.counters["segments_per_s"] = benchmark::Counter(segments, benchmark::Counter::kIsRate);
    state.counters["segments_per_ray"] = segments / std::max(rays, 1.0);
}

void BM_TraceSun7(benchmark::State& state) { traceSun7(state, 1, 500, TransportOptions{}); }
BENCHMARK(BM_TraceSun7)->Unit(benchmark::kMillisecond);

// The same trace on 1 and 2 threads (argument), wall time: 1024 rays per iteration in blocks
// of 128 so both threads get work (the result is the same for any thread count).
void BM_TraceSun7Threads(benchmark::State& state) {
    TransportOptions o;
    o.raysPerBlock = 128;
    traceSun7(state, static_cast<size_t>(state.range(0)), 1024, o);
}
BENCHMARK(BM_TraceSun7Threads)->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// Online pruning for a ghost analysis that ignores scatter: `fresnel{2} and not scatter`
// (two-reflection ghosts without any diffuse event). Argument 0: the criterion evaluated on
// the histories after each ray (every branch traced); 1: branches culled as soon as the
// criterion is false. The criterion image is the same within Monte Carlo error
// (tests/analysis/runs/transport_test.cpp, PruningKeepsTheCriterionFluxAndTracesLess).
void BM_TraceSun7Ghosts(benchmark::State& state) {
    const Fixture& f = sun7();
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    const NameTable names = criterionNames(f.setup->scene, f.trace.view);
    const std::vector<std::string> texts = {"fresnel{2} and not scatter"};
    const std::vector<CompiledCriterion> compiled = {compile(parseCriterion(texts[0]), names)};
    uint64_t seed = 1;
    double rays = 0, segments = 0;
    for (auto _ : state) {
        CriterionImages split(texts, compiled, f.trace.images, f.trace.view.detectorOfObject);
        CriteriaFilter filter(split.criteria());
        TransportOptions o;
        o.seed = seed++;
        o.recordHistories = true;
        o.filter = state.range(0) ? &filter : nullptr;
        const TraceResult r =
            traceNonsequential(f.trace.view, f.trace.images, 500, o, {}, split.callback(true));
        split.finish();
        rays += static_cast<double>(r.budget.rays);
        segments += static_cast<double>(r.budget.segments);
    }
    state.counters["rays_per_s"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
    state.counters["segments_per_ray"] = segments / std::max(rays, 1.0);
}
BENCHMARK(BM_TraceSun7Ghosts)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_RawEmbree(benchmark::State& state) {
    const Fixture& f = sun7();
    double rays = 0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(bench::rawEmbreeHits(*f.raw, f.rays));
        rays += static_cast<double>(f.rays.size());
    }
    state.counters["rays_per_s"] = benchmark::Counter(rays, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_RawEmbree)->Unit(benchmark::kMicrosecond);

}  // namespace

// The tracer's own segment rays (starting on the surface they left): Scene::closestHit as
// the tracer calls it, and raw rtcIntersect1 on the mechanics meshes alone for the same rays.
// Their ratio is the price of the exact faces and the double-precision refinement on the
// rays that matter; segments/s of BM_TraceSun7 over this closestHit rate is the share of
// the tracer's time spent outside the closest hit.
// Argument 0: every segment ray; 1: those travelling in glass (a sealed medium, the exact
// faces alone); 2: the others (in air: the exact faces, then the triangles); 3: those in air
// leaving a mesh; 4: those in air leaving an exact face or a source.
void BM_SegmentRaysClosestHit(benchmark::State& state) {
    const Fixture& f = sun7();
    const Scene& scene = f.setup->scene;
    const auto wanted = [arg = state.range(0)](bool glass, bool onMesh) {
        switch (arg) {
            case 0:
                return true;
            case 1:
                return glass;
            case 2:
                return !glass;
            case 3:
                return !glass && onMesh;
            default:
                return !glass && !onMesh;
        }
    };
    std::vector<size_t> chosen;
    for (size_t i = 0; i < f.segmentRays.size(); ++i) {
        const int so = f.segmentStarts[i].first;
        const bool onMesh = so >= 0 && std::holds_alternative<MeshRef>(scene.object(so).geometry);
        if (wanted(scene.sealed(f.segmentMedia[i]), onMesh)) chosen.push_back(i);
    }
    long long rays = 0, hits = 0;
    for (auto _ : state) {
        for (size_t i : chosen) {
            const auto h = scene.closestHit(f.segmentRays[i], kInfinity, f.segmentStarts[i].first,
                                            f.segmentStarts[i].second, f.segmentMedia[i]);
            hits += h.has_value();
        }
        rays += static_cast<long long>(chosen.size());
    }
    state.counters["rays_per_s"] =
        benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(rays);
    state.counters["rays"] = static_cast<double>(chosen.size());
}
BENCHMARK(BM_SegmentRaysClosestHit)->DenseRange(0, 4)->Unit(benchmark::kMillisecond);

void BM_SegmentRaysRawEmbree(benchmark::State& state) {
    const Fixture& f = sun7();
    long long rays = 0, hits = 0;
    for (auto _ : state) {
        hits += bench::rawEmbreeHits(*f.raw, f.segmentRays);
        rays += static_cast<long long>(f.segmentRays.size());
    }
    state.counters["rays_per_s"] =
        benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(rays);
}
BENCHMARK(BM_SegmentRaysRawEmbree)->Unit(benchmark::kMillisecond);

BENCHMARK_MAIN();
