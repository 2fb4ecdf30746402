// Closest-hit rate on the seed's 6-lens 360 mm lens with mechanics
// (examples/lenses/longfocus_360mm.toml, default [mechanics]).
//
//   build/bench/veil_closest_hit_bench --benchmark_min_time=2
//
// Each benchmark runs at three mechanics chord tolerances (argument in micrometres: 10 is the
// default 0.01 mm), which shows what the tessellation knob costs at query time.
//
// BM_SceneClosestHit: Scene::closestHit (exact lens faces in double plus Embree over the
// mechanics meshes, refined in double) for a fixed set of rays from random points inside
// the lens's bounding box toward random directions. BM_RawEmbree: the baseline measured in
// the same process, rtcIntersect1 on an Embree scene holding the same meshes alone, for the
// same rays, no exact faces and no double refinement. Their ratio is the price of the exact
// optics.

#include <benchmark/benchmark.h>

#include <map>
#include <memory>
#include <random>

#include "bench/raw_embree.h"
#include "geometry/embree_scene.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"

namespace {

using namespace veil;

struct Fixture {
    SceneGeometry setup;
    std::vector<Ray> rays;
    std::unique_ptr<EmbreeScene> raw;
};

// The scene at a given mechanics chord tolerance (um), built once per tolerance.
const Fixture& longFocus(int chordToleranceUm = 10) {
    static std::map<int, std::unique_ptr<Fixture>> cache;
    auto& slot = cache[chordToleranceUm];
    if (slot) return *slot;
    slot = std::make_unique<Fixture>([&] {
        const GlassCatalog& catalog = GlassCatalog::builtIn();
        SceneSpec file =
            readSceneFile(VEIL_SOURCE_DIR "/examples/lenses/longfocus_360mm.toml", catalog);
        MechanicsSpec spec;
        spec.chordToleranceMm = 1e-3 * chordToleranceUm;
        // The bore polygon is inscribed: the clearance must exceed the chord error.
        spec.barrel.clearanceMm = std::max(0.05, 1.5 * spec.chordToleranceMm);
        file.mechanics = spec;
        Fixture fx{buildSceneGeometry(file, catalog), {}, nullptr};
        const Bounds3 b = fx.setup.scene.bounds();
        std::mt19937_64 rng(7);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::normal_distribution<double> n;
        for (int i = 0; i < 4096; ++i) {
            const Vec3 o(b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                         b.lo.z + u(rng) * (b.hi.z - b.lo.z));
            fx.rays.push_back({o, glm::normalize(Vec3(n(rng), n(rng), n(rng)))});
        }
        fx.raw = std::make_unique<EmbreeScene>(fx.setup.scene.meshes());
        return fx;
    }());
    return *slot;
}

void BM_SceneClosestHit(benchmark::State& state) {
    const Fixture& f = longFocus(static_cast<int>(state.range(0)));
    long long rays = 0, hits = 0;
    for (auto _ : state) {
        for (const Ray& r : f.rays) {
            const auto h = f.setup.scene.closestHit(r);
            hits += h.has_value();
            ++rays;
        }
    }
    state.counters["rays_per_s"] =
        benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(rays);
    size_t triangles = 0;
    for (const TriangleMesh& m : f.setup.scene.meshes()) triangles += m.triangles.size();
    state.counters["triangles"] = static_cast<double>(triangles);
}
// Argument: the mechanics chord tolerance in micrometres (10 = the default 0.01 mm).
BENCHMARK(BM_SceneClosestHit)->Arg(10)->Arg(100)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_RawEmbree(benchmark::State& state) {
    const Fixture& f = longFocus(static_cast<int>(state.range(0)));
    long long rays = 0, hits = 0;
    for (auto _ : state) {
        hits += bench::rawEmbreeHits(*f.raw, f.rays);
        rays += static_cast<long long>(f.rays.size());
    }
    state.counters["rays_per_s"] =
        benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(rays);
}
BENCHMARK(BM_RawEmbree)->Arg(10)->Arg(100)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
