// The backward pass against independent truth: a Lambertian plate of radiance L seen by a
// detector pixel through a lens gives the camera equation's irradiance, E = pi L T sin^2 theta,
// theta the half-angle of the cone of the lens's clear aperture from the pixel; with ideal
// antireflection T = 1, uncoated T follows the incoherent sum of the glass plate's internal
// reflections (split branches). Thread count does not change a bit. (Source and pixel are
// both in air, so the n^2 factors of the two refractions cancel here; the Importance weights
// themselves are tested for adjointness in optical_property_test.)

#include "tracer/render/backward.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {
namespace {

// A biconvex singlet (model glass, no absorption) of clear radius 12.5 mm, a 1-pixel
// 0.2 mm detector on its image surface, and a Lambertian disk of radius 500 mm 200 mm in
// front, emitting toward the lens: every ray through the lens from the pixel meets it.
std::unique_ptr<PreparedScene> plateScene(const std::string& coating) {
    // One file per test: ctest runs this file's tests in parallel processes.
    const std::string path = ::testing::TempDir() + "veil_backward_" +
                             ::testing::UnitTest::GetInstance()->current_test_info()->name() +
                             ".toml";
    FILE* f = fopen(path.c_str(), "w");
    EXPECT_TRUE(f);
    fprintf(
        f,
        "[system]\nwavelengths_nm = [550.0]\naperture = { epd_mm = 20.0 }\n"
        "fields_deg = [0.0]\nsurfaces = [\n"
        "  { r = 100.0, t = 5.0, glass = { nd = 1.5, vd = 0.0 }, sd = 12.5, stop = true },\n"
        "  { r = -100.0, t = 99.0, sd = 12.5 },\n]\n"
        "[[source]]\nname = \"plate\"\nkind = \"lambertian\"\nposition_mm = [0.0, 0.0, -200.0]\n"
        "radius_mm = 500.0\nflux = 1.0\n"
        "[detector]\nsize_mm = [0.2, 0.2]\npixels = [1, 1]\n"
        "[[assign]]\nobjects = [\"L1.*\", \"L1.edge\"]\nproperty = \"%s\"\n",
        coating.c_str());
    fclose(f);
    return PreparedScene::read(path, GlassCatalog::builtIn());
}

// The last surface's clear aperture: the disk through the rim of L1.back.
ExitAperture rimAperture(const PreparedScene& s) {
    const SequentialModel& m = s.model();
    const int back = m.imageIndex() - 1;
    const double rim = m.surface(back).zMm + sag(m.surface(back).shape, 12.5 * 12.5);
    return ExitAperture{Vec3(0.0, 0.0, rim), Vec3(0.0, 0.0, 1.0), 12.5};
}

double cameraEquation(const PreparedScene& s, const ExitAperture& a) {
    const double radiance =
        s.transport().view.sources[0].emitted(Vec3(0.0, 0.0, -200.0), Vec3(0.0, 0.0, 1.0));
    const double zPixel = s.transport().images[0].geometry().frame.translation.z;
    const double sinTheta = a.radiusMm / std::hypot(a.radiusMm, zPixel - a.centerMm.z);
    const double pixelArea = s.transport().images[0].geometry().pixelAreaMm2();
    return std::numbers::pi * radiance * sinTheta * sinTheta * pixelArea;  // flux on the pixel
}

TEST(Backward, LambertianPlateThroughIdealLensObeysTheCameraEquation) {
    const auto s = plateScene("ideal_ar");
    const ExitAperture a = rimAperture(*s);
    BackwardOptions o;
    o.raysPerPixel = 20000;
    const BackwardResult r = traceBackward(s->transport().view, s->transport().images[0], a, o);
    const double expected = cameraEquation(*s, a);
    const double got = r.visible.flux(0);
    const double sigma = std::sqrt(r.visible.pixelVariance(0, o.raysPerPixel));
    EXPECT_GT(expected, 0.0);
    // Every sampled ray enters the lens and reaches the plate: the estimate is almost exact.
    EXPECT_LE(std::abs(got - expected), 4.0 * sigma + 1e-9 * expected)
        << got << " vs " << expected << " sigma " << sigma;
    EXPECT_LT(sigma, 1e-3 * expected);
    EXPECT_TRUE(r.viewPoints.empty());  // nothing scatters in this scene
}

TEST(Backward, UncoatedLensTransmitsTheIncoherentPlateSum) {
    const auto s = plateScene("uncoated");
    const ExitAperture a = rimAperture(*s);
    BackwardOptions o;
    o.raysPerPixel = 20000;
    o.minRelativeWeight = 1e-9;
    const BackwardResult r = traceBackward(s->transport().view, s->transport().images[0], a, o);
    // Near normal incidence (the cone is 7 degrees) R = ((n - 1) / (n + 1))^2 = 0.04 at each
    // face, and the plate's transmittance summed over its internal reflections is
    // (1 - R) / (1 + R); the angles move R by less than 1e-4 here.
    const double R = 0.04;
    const double expected = cameraEquation(*s, a) * (1.0 - R) / (1.0 + R);
    EXPECT_NEAR(r.visible.flux(0), expected, 5e-4 * expected);
}

TEST(Backward, ThreadCountDoesNotChangeABit) {
    const auto s = plateScene("uncoated");
    const ExitAperture a = rimAperture(*s);
    BackwardOptions o;
    o.raysPerPixel = 3000;
    o.split = false;  // random choice uses the ray's stream too
    BackwardResult one, two;
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        one = traceBackward(s->transport().view, s->transport().images[0], a, o);
    }
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        two = traceBackward(s->transport().view, s->transport().images[0], a, o);
    }
    EXPECT_TRUE(one.visible.sameSums(two.visible));
    EXPECT_EQ(one.segments, two.segments);
    // Random choice is unbiased: within 4 sigma of the split estimate.
    BackwardOptions split = o;
    split.split = true;
    const BackwardResult all =
        traceBackward(s->transport().view, s->transport().images[0], a, split);
    const double sigma = std::sqrt(one.visible.pixelVariance(0, o.raysPerPixel));
    EXPECT_LE(std::abs(one.visible.flux(0) - all.visible.flux(0)), 4.0 * sigma);
}

}  // namespace
}  // namespace veil
