// Sequential real-ray rate on the 50 mm f/2 double Gauss (examples/lenses/double_gauss_50mm.toml).
//
//   build/bench/veil_sequential_bench --benchmark_min_time=2
//
// BM_SequentialDoubleGauss traces a fixed hexapolar bundle at the edge field through every
// surface (real aiming is done once, outside the timed loop) and reports ray-surfaces per
// second on one core. BM_SphereKernel is the baseline measured in the same process: the bare
// sphere intersection + normal + Snell refraction on one surface, the least work one
// ray-surface can cost. Their ratio is the tracer's overhead per surface.

#include <benchmark/benchmark.h>

#include <cmath>

#include "analysis/lens/spot.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/lens_file.h"
#include "lensdata/prescription.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace {

using namespace veil;

struct Fixture {
    SequentialModel model;
    std::vector<Ray> rays;
    int surfacesPerRay = 0;
};

const Fixture& doubleGauss() {
    static const Fixture f = [] {
        const GlassCatalog& catalog = GlassCatalog::builtIn();
        const Prescription p =
            readLensFile(VEIL_SOURCE_DIR "/examples/lenses/double_gauss_50mm.toml", catalog);
        Fixture fx{SequentialModel::build(p, catalog), {}, 0};
        const RayAimer aimer(fx.model, AimMode::Real);
        const Field& edge = p.system.fields.back();
        for (const Vec2& pp : hexapolarPupil(20)) {
            const AimedRay a = aimer.aim(edge, pp.x, pp.y, fx.model.primaryWavelength());
            if (a.status == RayStatus::Ok) fx.rays.push_back(a.ray);
        }
        fx.surfacesPerRay = fx.model.imageIndex();
        return fx;
    }();
    return f;
}

void BM_SequentialDoubleGauss(benchmark::State& state) {
    const Fixture& f = doubleGauss();
    const int w = f.model.primaryWavelength();
    long long raySurfaces = 0;
    for (auto _ : state) {
        for (const Ray& r : f.rays) {
            const SequentialRayResult res = traceSequential(f.model, w, r);
            benchmark::DoNotOptimize(res.ray.origin);
            raySurfaces += res.surface;
        }
    }
    state.counters["ray_surfaces_per_s"] =
        benchmark::Counter(static_cast<double>(raySurfaces), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SequentialDoubleGauss)->Unit(benchmark::kMicrosecond);

void BM_SphereKernel(benchmark::State& state) {
    // One sphere of radius 30 mm from glass 1.0 to 1.6, rays spread over 20 mm.
    const SurfaceShape shape = makeShape(1.0 / 30.0, 0.0, {});
    std::vector<Ray> rays;
    for (const Vec2& pp : hexapolarPupil(20))
        rays.push_back(
            {Vec3(10.0 * pp.x, 10.0 * pp.y, -5.0), glm::normalize(Vec3(0.0, 0.05, 1.0))});
    long long raySurfaces = 0;
    for (auto _ : state) {
        for (const Ray& r : rays) {
            const auto t = intersectSequential(shape, r);
            const Vec3 p = r.origin + *t * r.direction;
            const auto d = refract(r.direction, surfaceNormal(shape, p), 1.0, 1.6);
            benchmark::DoNotOptimize(d);
            ++raySurfaces;
        }
    }
    state.counters["ray_surfaces_per_s"] =
        benchmark::Counter(static_cast<double>(raySurfaces), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SphereKernel)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
