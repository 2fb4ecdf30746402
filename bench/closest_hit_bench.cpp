// Closest-hit rate on the seed's 6-lens 360 mm lens with mechanics
// (examples/lenses/longfocus_360mm.toml, default [mechanics]).
//
//   build/bench/veil_closest_hit_bench --benchmark_min_time=2
//
// BM_SceneClosestHit: Scene::closestHit (exact lens faces in double plus Embree over the
// mechanics meshes, refined in double) for a fixed set of rays from random points inside
// the lens's bounding box toward random directions. BM_RawEmbree: the baseline measured in
// the same process, rtcIntersect1 on an Embree scene holding the same meshes alone, for the
// same rays, no exact faces and no double refinement. Their ratio is the price of the exact
// optics.

#include <benchmark/benchmark.h>
#include <embree3/rtcore.h>

#include <random>

#include "analysis/scene_setup.h"
#include "geometry/embree_meshes.h"

namespace {

using namespace veil;

struct Fixture {
    SceneSetup setup;
    std::vector<Ray> rays;
    std::unique_ptr<EmbreeMeshes> raw;
};

const Fixture& longFocus() {
    static const Fixture f = [] {
        const GlassCatalog& catalog = GlassCatalog::builtIn();
        SceneFile file =
            readSceneFile(VEIL_SOURCE_DIR "/examples/lenses/longfocus_360mm.toml", catalog);
        file.mechanics = MechanicsSpec{};
        Fixture fx{buildScene(file, catalog), {}, nullptr};
        const Bounds3 b = fx.setup.scene.bounds();
        std::mt19937_64 rng(7);
        std::uniform_real_distribution<double> u(0.0, 1.0);
        std::normal_distribution<double> n;
        for (int i = 0; i < 4096; ++i) {
            const Vec3 o(b.lo.x + u(rng) * (b.hi.x - b.lo.x), b.lo.y + u(rng) * (b.hi.y - b.lo.y),
                         b.lo.z + u(rng) * (b.hi.z - b.lo.z));
            fx.rays.push_back({o, glm::normalize(Vec3(n(rng), n(rng), n(rng)))});
        }
        fx.raw = std::make_unique<EmbreeMeshes>(fx.setup.scene.meshes());
        return fx;
    }();
    return f;
}

void BM_SceneClosestHit(benchmark::State& state) {
    const Fixture& f = longFocus();
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
}
BENCHMARK(BM_SceneClosestHit)->Unit(benchmark::kMicrosecond);

void BM_RawEmbree(benchmark::State& state) {
    const Fixture& f = longFocus();
    RTCScene scene = static_cast<RTCScene>(f.raw->rawScene());
    long long rays = 0, hits = 0;
    for (auto _ : state) {
        for (const Ray& r : f.rays) {
            RTCIntersectContext ctx;
            rtcInitIntersectContext(&ctx);
            RTCRayHit rh{};
            rh.ray.org_x = static_cast<float>(r.origin.x);
            rh.ray.org_y = static_cast<float>(r.origin.y);
            rh.ray.org_z = static_cast<float>(r.origin.z);
            rh.ray.dir_x = static_cast<float>(r.direction.x);
            rh.ray.dir_y = static_cast<float>(r.direction.y);
            rh.ray.dir_z = static_cast<float>(r.direction.z);
            rh.ray.tnear = 0.0f;
            rh.ray.tfar = std::numeric_limits<float>::infinity();
            rh.ray.mask = ~0u;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &ctx, &rh);
            hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
            ++rays;
        }
    }
    state.counters["rays_per_s"] =
        benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = static_cast<double>(hits) / static_cast<double>(rays);
}
BENCHMARK(BM_RawEmbree)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
