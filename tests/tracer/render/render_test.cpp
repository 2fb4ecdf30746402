// The renderer against independent truth (tracer/render/render.h):
//  - a Lambertian plate lit by a large Lambertian emitter and seen through an ideal lens: the
//    direct component is the camera equation's irradiance for the plate's radiance R E / pi;
//  - the components add up to the total, pass by pass;
//  - passes are independent: the error falls as the PPM rate says, the radius follows
//    Knaus and Zwicker's recurrence;
//  - a checkpoint resumed gives bitwise the uninterrupted run; one and two threads agree
//    bitwise.

#include "tracer/render/render.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <random>

#include "geometry/scene.h"
#include "lensdata/glass_catalog.h"
#include "tests/tracer/render/box_mesh.h"
#include "tracer/records/detector.h"
#include "tracer/render/photon_pass.h"
#include "tracer/runtime/deadline.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/transport/nonsequential.h"

namespace veil {
namespace {

std::string testName() { return ::testing::UnitTest::GetInstance()->current_test_info()->name(); }

// A biconvex singlet with ideal antireflection (clear radius 12.5 mm), a 1-pixel 0.2 mm
// detector on its image surface, a 1200 mm square plate (Lambertian reflectance R) whose
// front face lies at z = -200, and a Lambertian emitter disk of radius 1000 mm at z = -100
// facing the plate (the emitter is no object: it blocks nothing).
constexpr double kReflectance = 0.3;
constexpr double kEmitterRadius = 1000.0, kEmitterGap = 100.0, kSourceFlux = 1.0;

std::unique_ptr<PreparedScene> litPlateScene(int pixels = 1, double detectorMm = 0.2) {
    const std::string stem = ::testing::TempDir() + "veil_render_" + testName();
    writeBox(stem + ".off", Vec3(-600.0, -600.0, -201.0), Vec3(600.0, 600.0, -200.0));
    const std::string path = stem + ".toml";
    FILE* f = fopen(path.c_str(), "w");
    EXPECT_TRUE(f);
    fprintf(f,
            "%s]\n"
            "[[mesh]]\nname = \"plate\"\nfile = \"%s\"\nproperty = \"white\"\n"
            "[properties.white]\nscatter = { model = \"lambertian\", reflectance = %g }\n"
            "[[source]]\nname = \"lamp\"\nkind = \"lambertian\"\nposition_mm = [0.0, 0.0, %g]\n"
            "normal = [0.0, 0.0, -1.0]\nradius_mm = %g\nflux = %g\n"
            "[detector]\nsize_mm = [%g, %g]\npixels = [%d, %d]\n"
            "[[assign]]\nobjects = [\"L1.*\", \"L1.edge\"]\nproperty = \"ideal_ar\"\n",
            singletSystem(99.0).c_str(), std::filesystem::path(stem + ".off").filename().c_str(),
            kReflectance, -200.0 + kEmitterGap, kEmitterRadius, kSourceFlux, detectorMm, detectorMm,
            pixels, pixels);
    fclose(f);
    return PreparedScene::read(path, GlassCatalog::builtIn());
}

ExitAperture rimAperture(const PreparedScene& s) {
    const SequentialModel& m = s.model();
    const int back = m.imageIndex() - 1;
    const double rim = m.surface(back).zMm + sag(m.surface(back).shape, 12.5 * 12.5);
    return ExitAperture{Vec3(0.0, 0.0, rim), Vec3(0.0, 0.0, 1.0), 12.5};
}

// The flux on the detector's centre pixel: plate radiance R E / pi through the camera
// equation, E the irradiance of the emitter disk on the plate's axis point.
double expectedDirect(const PreparedScene& s, const ExitAperture& a) {
    const double area = std::numbers::pi * kEmitterRadius * kEmitterRadius;
    const double emitterRadiance = kSourceFlux / (area * std::numbers::pi);
    const double E = std::numbers::pi * emitterRadiance * kEmitterRadius * kEmitterRadius /
                     (kEmitterGap * kEmitterGap + kEmitterRadius * kEmitterRadius);
    const double plateRadiance = kReflectance * E / std::numbers::pi;
    const DetectorGeometry& g = s.transport().images[0].geometry();
    const double sinTheta =
        a.radiusMm / std::hypot(a.radiusMm, g.frame.translation.z - a.centerMm.z);
    return std::numbers::pi * plateRadiance * sinTheta * sinTheta * g.pixelAreaMm2();
}

TEST(Render, DirectLightOnALambertianPlateObeysTheCameraEquation) {
    const auto s = litPlateScene();
    const ExitAperture a = rimAperture(*s);
    RenderOptions o;
    o.raysPerPixel = 20000;
    o.photonsPerPass = 2000;
    const Renderer renderer(s->transport().view, s->transport().images[0], a, o);
    const RenderPass pass = renderer.runPass(1, 5.0);
    const double expected = expectedDirect(*s, a);
    const double got = pass.pixels[int(RenderComponent::Direct)][0];
    // The emitter's irradiance varies by < 1e-4 over the patch of plate the pixel sees; the
    // estimate's own spread: one NEE sample per view point, 20000 of them.
    const BackwardResult back = traceBackward(s->transport().view, s->transport().images[0], a,
                                              renderer.backwardOptions(1));
    const double sigma = std::sqrt(back.direct.pixelVariance(0, o.raysPerPixel));
    EXPECT_EQ(back.direct.flux(0), got);  // the pass's direct image is the backward pass's
    EXPECT_GT(expected, 0.0);
    EXPECT_LE(std::abs(got - expected), 4.0 * sigma + 2e-4 * expected)
        << got << " vs " << expected << " sigma " << sigma;
    EXPECT_LT(sigma, 0.01 * expected);
    // Nothing else reaches the pixel: the emitter faces away from the lens, and light the
    // plate scatters meets no second scattering surface.
    EXPECT_EQ(pass.pixels[int(RenderComponent::Visible)][0], 0.0);
    EXPECT_EQ(pass.pixels[int(RenderComponent::Caustic)][0], 0.0);
    EXPECT_EQ(pass.pixels[int(RenderComponent::Secondary)][0], 0.0);
    EXPECT_EQ(pass.viewPoints, o.raysPerPixel);  // every ray through the lens meets the plate
}

// The caustic scene: a Lambertian plate (reflectance R, front face at z = -50) lit only
// through a glass window (ideal antireflection, z = 0..5, radius 1200 mm) by a Lambertian
// emitter disk at z = +60 facing the plate; a free detector at z = -20, facing the plate,
// views it directly. A black cap just behind the detector keeps the emitter's light off its
// back (veil trace records both sides of a detector, the renderer its sensitive side). The window
// blocks every straight line from the plate to the emitter, so all light on the plate has refracted
// first: the direct component is 0 and the plate's light reaches the pixels as the caustic
// component. Forward Monte Carlo converges here (7 % of the emitted flux lands on the detector),
// which makes it the reference.
struct WindowScene {
    double emitterRadius = 30.0;
    double reflectance = 0.3;
    int pixels = 4;
    double detectorMm = 40.0;
    bool cap = true;
    // A white wall (the plate's property) standing on the plate beside the detector's view:
    // light the plate scatters meets it and the reverse, the secondary component.
    bool wall = false;
};

std::unique_ptr<PreparedScene> windowPlateScene(const WindowScene& w) {
    const std::string stem = ::testing::TempDir() + "veil_render_" + testName();
    writeBox(stem + ".off", Vec3(-600.0, -600.0, -51.0), Vec3(600.0, 600.0, -50.0));
    writeBox(stem + ".cap.off", Vec3(-30.0, -30.0, -19.0), Vec3(30.0, 30.0, -18.0));
    std::string wall;
    if (w.wall) {
        writeBox(stem + ".wall.off", Vec3(40.0, -60.0, -49.5), Vec3(42.0, 60.0, -25.0));
        wall = "[[mesh]]\nname = \"wall\"\nfile = \"" +
               std::filesystem::path(stem + ".wall.off").filename().string() +
               "\"\nproperty = \"white\"\n";
    }
    const std::string path = stem + ".toml";
    FILE* f = fopen(path.c_str(), "w");
    EXPECT_TRUE(f);
    fprintf(f,
            "[system]\nwavelengths_nm = [550.0]\naperture = { epd_mm = 20.0 }\n"
            "fields_deg = [0.0]\nsurfaces = [\n"
            "  { r = 0.0, t = 5.0, glass = { nd = 1.5, vd = 0.0 }, sd = 1200.0, stop = true },\n"
            "  { r = 0.0, t = 100.0, sd = 1200.0 },\n]\n"
            "[[mesh]]\nname = \"plate\"\nfile = \"%s\"\nproperty = \"white\"\n"
            "%s%s%s%s"
            "[properties.white]\nscatter = { model = \"lambertian\", reflectance = %g }\n"
            "[[source]]\nname = \"lamp\"\nkind = \"lambertian\"\nposition_mm = [0.0, 0.0, 60.0]\n"
            "normal = [0.0, 0.0, -1.0]\nradius_mm = %g\nflux = 1.0\n"
            "[detector]\nname = \"det\"\nz_mm = -20.0\nsize_mm = [%g, %g]\npixels = [%d, %d]\n"
            "[[assign]]\nobjects = [\"L1.*\", \"L1.edge\"]\nproperty = \"ideal_ar\"\n",
            std::filesystem::path(stem + ".off").filename().c_str(),
            w.cap ? "[[mesh]]\nname = \"cap\"\nfile = \"" : "",
            w.cap ? std::filesystem::path(stem + ".cap.off").filename().c_str() : "",
            w.cap ? "\"\nproperty = \"absorber\"\n" : "", wall.c_str(), w.reflectance,
            w.emitterRadius, w.detectorMm, w.detectorMm, w.pixels, w.pixels);
    fclose(f);
    return PreparedScene::read(path, GlassCatalog::builtIn());
}

// Every direction from the detector down to the plate: a disk just above it, out to its rim.
ExitAperture plateAperture() {
    return ExitAperture{Vec3(0.0, 0.0, -49.99), Vec3(0.0, 0.0, 1.0), 620.0};
}

RenderState render(const PreparedScene& s, const RenderOptions& o, int passes,
                   const ExitAperture& a) {
    const Renderer renderer(s.transport().view, s.transport().images[0], a, o);
    RenderState state(s.transport().images[0].geometry(), o.initialRadiusMm, o.alpha);
    for (int k = 1; k <= passes; ++k)
        state.add(renderer.runPass(k, state.radiusMm(), state.learned(), state.photonsPerPass()));
    return state;
}

// A 1000 mm emitter 110 mm from the plate: irradiance pi L a^2 / (h^2 + a^2) on its axis, the
// window (plane parallel, no reflection) moving the emitter's apparent distance by
// t (1 - 1 / n) = 1.67 mm, a change of 4e-4 in E. The pixel at the centre, 0.2 mm, sees the
// plate from 30 mm over a cone of the aperture disk: pi L' sin^2 theta A of the plate's
// radiance R E / pi.
struct CameraEquation {
    std::unique_ptr<PreparedScene> scene;
    ExitAperture aperture{Vec3(0.0, 0.0, -49.99), Vec3(0.0, 0.0, 1.0), 10.0};
    double expected = 0.0;  // the pixel's caustic flux
};
CameraEquation cameraEquation() {
    WindowScene w;
    w.emitterRadius = 1000.0;
    w.pixels = 1;
    w.detectorMm = 0.2;
    w.cap = false;
    CameraEquation c;
    c.scene = windowPlateScene(w);
    const ExitAperture& a = c.aperture;
    const double L = 1.0 / (std::numbers::pi * 1e6 * std::numbers::pi);
    const double h = 110.0 - 5.0 * (1.0 - 1.0 / 1.5);
    const double E = std::numbers::pi * L * 1e6 / (h * h + 1e6);
    const double dz = -20.0 - a.centerMm.z;
    const double sin2 = a.radiusMm * a.radiusMm / (a.radiusMm * a.radiusMm + dz * dz);
    c.expected = 0.3 * E * sin2 * 0.2 * 0.2;
    return c;
}

// Options with which the photons alone carry the camera equation's light: no connection
// through the window, no parts' points; r1 60 mm (the plate is lit uniformly: no radius bias).
RenderOptions photonsAlone(uint64_t raysPerPixel, uint64_t photons) {
    RenderOptions o;
    o.raysPerPixel = raysPerPixel;
    o.photonsPerPass = photons;
    o.ghostPhotonsPerPass = 1000;
    o.initialRadiusMm = 60.0;
    o.connectThroughLens = false;
    o.partSamples = 0;
    return o;
}

TEST(Render, CausticLightOnAPlateObeysTheCameraEquation) {
    const CameraEquation c = cameraEquation();
    RenderOptions o;
    o.raysPerPixel = 2000;
    o.photonsPerPass = 100000;
    o.initialRadiusMm = 60.0;  // the plate is lit uniformly here: no radius bias
    const RenderState state = render(*c.scene, o, 8, c.aperture);
    const DetectorImage caustic = state.component(RenderComponent::Caustic);
    const double sigma = std::sqrt(caustic.pixelVariance(0, state.passes()));
    EXPECT_LE(std::abs(caustic.flux(0) - c.expected), 4.0 * sigma + 1e-3 * c.expected)
        << caustic.flux(0) << " vs " << c.expected << " sigma " << sigma;
    EXPECT_LT(sigma, 0.04 * c.expected);
    EXPECT_EQ(state.component(RenderComponent::Direct).totalFlux(), 0.0);  // the window blocks
}

TEST(Render, GuidedPhotonsKeepTheCameraEquation) {
    // The camera equation's caustic light carried by the photons alone (no connection through
    // the window): a photon from the 1000 mm emitter's rim brings the centre pixel about
    // (h^2 / (h^2 + a^2))^2 ~ 1e-4 of what one from its centre brings. The emission guide
    // learns that and draws 90 % of its photons from the cells that brought light, each
    // weighted by 1 / its density: the estimate keeps the closed form (without the weight it
    // reads 10x high).
    const CameraEquation c = cameraEquation();
    auto run = [&](double guide) {
        RenderOptions o = photonsAlone(256, 20000);
        o.guideFraction = 0.0;  // RenderState::learned() then holds the emission guide's alone
        o.scatterGuideFraction = 0.0;
        o.photonGuideFraction = guide;
        return render(*c.scene, o, 12, c.aperture);
    };
    const RenderState guided = run(0.9), plain = run(0.0);
    for (const RenderState* state : {&guided, &plain}) {
        const DetectorImage caustic = state->component(RenderComponent::Caustic);
        const double sigma = std::sqrt(caustic.pixelVariance(0, state->passes()));
        EXPECT_LE(std::abs(caustic.flux(0) - c.expected), 4.0 * sigma + 1e-3 * c.expected)
            << caustic.flux(0) << " vs " << c.expected << " sigma " << sigma;
        EXPECT_LT(sigma, 0.05 * c.expected);
    }
    // What the guide learned (the one pixel is its one region): light from the emitter's
    // centre (the first column, u1 < 1 / 16: the disk within a quarter of its radius) far above
    // its rim's (the last column).
    const std::vector<double>& learned = guided.learned();
    ASSERT_EQ(learned.size(), EmissionGuide(1, 1, 1).bins());
    double centre = 0.0, rim = 0.0;
    for (int j = 0; j < ApertureGuide::kCells; ++j) {
        centre += learned[static_cast<size_t>(j * ApertureGuide::kCells)];
        rim += learned[static_cast<size_t>(j * ApertureGuide::kCells + ApertureGuide::kCells - 1)];
    }
    EXPECT_GT(centre, 100.0 * rim) << centre << " " << rim;
    // Hundreds of photons carry this light (478): no few-photons warning.
    EXPECT_GT(guided.effectivePhotons(), RenderState::kFewPhotons);
}

TEST(Render, PhotonSumsAreTheGatheredLight) {
    // The sums behind RenderState::effectivePhotons: with the photons alone carrying the light
    // (no connection, no parts), the sum of every photon's gathered light is the pass's caustic
    // and secondary light, and (sum c)^2 / sum c^2 lies between 1 and the photons that
    // gathered any.
    const CameraEquation c = cameraEquation();
    const RenderOptions o = photonsAlone(64, 5000);
    const Renderer renderer(c.scene->transport().view, c.scene->transport().images[0], c.aperture,
                            o);
    RenderState state(c.scene->transport().images[0].geometry(), o.initialRadiusMm, o.alpha);
    double gathered = 0.0;
    for (int k = 1; k <= 3; ++k) {
        const RenderPass pass = renderer.runPass(k, state.radiusMm(), state.learned());
        double light = 0.0;
        for (const auto rc : {RenderComponent::Caustic, RenderComponent::Secondary})
            for (const double v : pass.pixels[static_cast<int>(rc)]) light += v;
        EXPECT_NEAR(pass.gatheredSum, light, 1e-9 * light);
        EXPECT_GT(light, 0.0);
        EXPECT_LE(pass.gatheredSquares, pass.gatheredSum * pass.gatheredSum);
        gathered += pass.gatheredSum;
        state.add(pass);
    }
    EXPECT_GE(state.effectivePhotons(), 1.0);
    EXPECT_LE(state.effectivePhotons(), 3.0 * 5000.0);
    EXPECT_GT(gathered, 0.0);
}

TEST(Render, AgreesWithForwardMonteCarloInTotalAndPerPixel) {
    const auto s = windowPlateScene({});
    const SceneTransport& t = s->transport();
    // Forward reference.
    TransportOptions fo;
    fo.mode = TransportOptions::Mode::Random;
    fo.seed = 11;
    const uint64_t rays = 1000000;
    const TraceResult forward = traceNonsequential(t.view, t.images, rays, fo);
    const DetectorImage& ref = forward.detectors[0];
    // The renderer, 12 passes.
    RenderOptions o;
    o.raysPerPixel = 2048;  // the aperture spans the hemisphere: many rays per pixel
    o.photonsPerPass = 100000;
    o.initialRadiusMm = 10.0;
    const RenderState state = render(*s, o, 12, plateAperture());
    const DetectorImage total = state.total();
    const uint64_t n = state.passes();
    // The components add up to the total, pixel by pixel and in all.
    double sum = 0.0;
    for (int c = 0; c < kRenderComponents; ++c)
        sum += state.component(static_cast<RenderComponent>(c)).totalFlux();
    EXPECT_NEAR(sum, total.totalFlux(), 1e-12 * total.totalFlux());
    for (int p = 0; p < total.pixelCount(); ++p) {
        double px = 0.0;
        for (int c = 0; c < kRenderComponents; ++c)
            px += state.component(static_cast<RenderComponent>(c)).flux(p);
        EXPECT_NEAR(px, total.flux(p), 1e-12 * total.flux(p));
    }
    // Total flux within the combined error (the radius bias: the irradiance varies on the
    // scale of the emitter's 110 mm distance, (10 / 110)^2 / 8 ~ 1e-3 of it, added).
    const double sr = std::sqrt(total.totalVariance(n));
    const double sf = std::sqrt(ref.totalVariance(rays));
    EXPECT_LE(std::abs(total.totalFlux() - ref.totalFlux()),
              4.0 * std::hypot(sr, sf) + 1e-3 * ref.totalFlux())
        << total.totalFlux() << " vs " << ref.totalFlux() << " (" << sr << ", " << sf << ")";
    EXPECT_LT(sr, 0.03 * ref.totalFlux());
    // Every pixel within 3 sigma plus the bias bound; with 16 pixels a 4-sigma miss would be
    // a defect, not luck.
    for (int p = 0; p < total.pixelCount(); ++p) {
        const double a = total.flux(p), b = ref.flux(p);
        const double sigma =
            std::hypot(std::sqrt(total.pixelVariance(p, n)), std::sqrt(ref.pixelVariance(p, rays)));
        EXPECT_LE(std::abs(a - b), 4.0 * sigma + 1e-3 * b)
            << "pixel " << p << ": " << a << " vs " << b;
    }
    EXPECT_EQ(state.component(RenderComponent::Direct).totalFlux(), 0.0);
    EXPECT_GT(state.component(RenderComponent::Caustic).totalFlux(), 0.9 * total.totalFlux());
}

// A 100 mm square plate in the open ("plate", front face at z = 0, normal +z) and a second
// box `name` from lo to hi, both white (Lambertian, 0.5).
std::unique_ptr<PreparedScene> plateAndBoxScene(const std::string& name, Vec3 lo, Vec3 hi) {
    const std::string stem = ::testing::TempDir() + "veil_render_" + testName();
    writeBox(stem + ".plate.off", Vec3(-50.0, -50.0, -1.0), Vec3(50.0, 50.0, 0.0));
    writeBox(stem + "." + name + ".off", lo, hi);
    const std::string path = stem + ".toml";
    FILE* f = fopen(path.c_str(), "w");
    EXPECT_TRUE(f);
    fprintf(f,
            "[system]\nwavelengths_nm = [550.0]\naperture = { epd_mm = 2.0 }\n"
            "fields_deg = [0.0]\nsurfaces = [\n"
            "  { r = 0.0, t = 1.0, glass = { nd = 1.5, vd = 0.0 }, sd = 1.0, stop = true },\n"
            "  { r = 0.0, t = 10.0, sd = 1.0 },\n]\n"
            "[[mesh]]\nname = \"plate\"\nfile = \"%s\"\nproperty = \"white\"\n"
            "[[mesh]]\nname = \"%s\"\nfile = \"%s\"\nproperty = \"white\"\n"
            "[properties.white]\nscatter = { model = \"lambertian\", reflectance = 0.5 }\n",
            std::filesystem::path(stem + ".plate.off").filename().c_str(), name.c_str(),
            std::filesystem::path(stem + "." + name + ".off").filename().c_str());
    fclose(f);
    return PreparedScene::read(path, GlassCatalog::builtIn());
}

// The plate and a 0.2 mm wide strip beside it ("strip", front face at z = 0, x from 200 to
// 200.2).
std::unique_ptr<PreparedScene> platesScene() {
    return plateAndBoxScene("strip", Vec3(200.0, -50.0, -1.0), Vec3(200.2, 50.0, 0.0));
}

// Forward Monte Carlo's flux on the scene's first detector and its standard error.
std::pair<double, double> forwardTotal(const PreparedScene& s, uint64_t rays, uint64_t seed) {
    const SceneTransport& t = s.transport();
    TransportOptions fo;
    fo.mode = TransportOptions::Mode::Random;
    fo.seed = seed;
    const TraceResult forward = traceNonsequential(t.view, t.images, rays, fo);
    return {forward.detectors[0].totalFlux(), std::sqrt(forward.detectors[0].totalVariance(rays))};
}

// The [system] of a plane window as the lens: glass of index n (no dispersion), thicknessMm
// thick, clear radius sdMm, its back face 100 mm before the image surface.
std::string planeWindowSystem(double thicknessMm, double sdMm, double n = 1.5) {
    char text[512];
    snprintf(text, sizeof text,
             "[system]\nwavelengths_nm = [550.0]\naperture = { epd_mm = 20.0 }\n"
             "fields_deg = [0.0]\nsurfaces = [\n"
             "  { r = 0.0, t = %g, glass = { nd = %g, vd = 0.0 }, sd = %g, stop = true },\n"
             "  { r = 0.0, t = 100.0, sd = %g },\n]\n",
             thicknessMm, n, sdMm, sdMm);
    return text;
}

// A scene of the test's own: a plane window (planeWindowSystem) and one box mesh from lo to
// hi, then `rest` (meshes, properties, sources, detector), in which "{box}" stands for the
// box's file name.
std::unique_ptr<PreparedScene> windowBoxScene(double thicknessMm, double sdMm, Vec3 lo, Vec3 hi,
                                              std::string rest) {
    const std::string stem = ::testing::TempDir() + "veil_render_" + testName();
    writeBox(stem + ".off", lo, hi);
    const std::string box = std::filesystem::path(stem + ".off").filename().string();
    for (size_t at = rest.find("{box}"); at != std::string::npos; at = rest.find("{box}"))
        rest.replace(at, 5, box);
    const std::string path = stem + ".toml";
    FILE* f = fopen(path.c_str(), "w");
    EXPECT_TRUE(f);
    fprintf(f, "%s%s", planeWindowSystem(thicknessMm, sdMm).c_str(), rest.c_str());
    fclose(f);
    return PreparedScene::read(path, GlassCatalog::builtIn());
}

// The id of the scene's object `name` (a test failure and -1 when there is none).
int objectId(const Scene& scene, const std::string& name) {
    for (const SceneObject& o : scene.objects())
        if (o.name == name) return o.id;
    ADD_FAILURE() << "no object " << name;
    return -1;
}

// A view point on `object` looking up along +z (a face at z = 0 seen from above).
ViewPoint upViewPoint(int object) {
    ViewPoint v;
    v.normal = Vec3(0.0, 0.0, 1.0);
    v.toDetector = v.normal;
    v.fromFront = true;
    v.object = object;
    return v;
}

// The rim correction: the share of a gathering disk on its own object, against the areas of
// a disk cut by a straight rim (the circular segment) and by a narrow strip.
TEST(Render, ViewPointAreaShareMatchesTheDiskGeometry) {
    const auto s = platesScene();
    const Scene& scene = s->scene();
    ViewPoint v = upViewPoint(objectId(scene, "plate"));
    const double r = 2.0;
    // Inside the face: every probe lands on it.
    v.positionMm = Vec3(10.0, -20.0, 0.0);
    EXPECT_EQ(viewPointAreaShare(scene, v, r, 16, 0.3).share, 1.0);
    // A distance d from the rim x = 50: 1 - (r^2 acos(d/r) - d sqrt(r^2 - d^2)) / (pi r^2).
    for (double d : {0.0, 0.5, 1.0, 1.5}) {
        v.positionMm = Vec3(50.0 - d - 1e-9, 0.0, 0.0);
        const double segment = r * r * std::acos(d / r) - d * std::sqrt(r * r - d * d);
        const double expected = 1.0 - segment / (std::numbers::pi * r * r);
        EXPECT_NEAR(viewPointAreaShare(scene, v, r, 4096, 0.3).share, expected, 0.005) << "d " << d;
        // 16 probes, as the renderer uses them: within 2.5 probes for any turn, and close on
        // average over the turns (each view point gets its own).
        double mean = 0.0;
        for (int t = 0; t < 1000; ++t) {
            const double share = viewPointAreaShare(scene, v, r, 16, 0.00628 * t).share;
            EXPECT_NEAR(share, expected, 2.5 / 16) << "d " << d << ", turn " << t;
            mean += share / 1000;
        }
        EXPECT_NEAR(mean, expected, 0.01) << "d " << d;
    }
    // A corner: a quarter of the disk.
    v.positionMm = Vec3(50.0 - 1e-9, 50.0 - 1e-9, 0.0);
    EXPECT_NEAR(viewPointAreaShare(scene, v, r, 4096, 0.3).share, 0.25, 0.005);
    // The 0.2 mm strip: 2 w sqrt(r^2 - (w/2)^2) / (pi r^2) to first order, 0.0636.
    v.object = objectId(scene, "strip");
    v.positionMm = Vec3(200.1, 0.0, 0.0);
    EXPECT_NEAR(viewPointAreaShare(scene, v, r, 4096, 0.3).share,
                0.2 * 2.0 * r / (std::numbers::pi * r * r), 0.003);
    // Probes that find only another object (a plate view point placed over the strip) do not
    // count, and the view point's own point keeps the share above zero.
    v.object = objectId(scene, "plate");
    EXPECT_EQ(viewPointAreaShare(scene, v, r, 16, 0.3).share, 1.0 / 16.0);
    EXPECT_EQ(viewPointAreaShare(scene, v, r, 0, 0.3).share, 1.0);  // off
}

// The plate with a cover over its half x < 0, 1 um above it: the contact gap veil's mechanics
// keep between a spacer's end and a lens flat.
std::unique_ptr<PreparedScene> coveredPlateScene() {
    return plateAndBoxScene("cover", Vec3(-50.0, -50.0, 0.001), Vec3(0.0, 50.0, 1.0));
}

// Light in a thin gap is not the light beside it: a view point in the gap and one beside it
// each count the part of their disk in their own kind of place, and the probes reach the
// face under the cover through it (they start inside the cover: 1 um is less than their
// hair off the face).
TEST(Render, ViewPointAreaShareKeepsGapsApart) {
    const auto s = coveredPlateScene();
    const Scene& scene = s->scene();
    int plate = -1;
    for (const SceneObject& o : scene.objects())
        if (o.name == "plate") plate = o.id;
    ASSERT_GE(plate, 0);
    ViewPoint v;
    v.normal = Vec3(0.0, 0.0, 1.0);
    v.toDetector = v.normal;
    v.fromFront = true;
    v.object = plate;
    const double r = 2.0;
    ASSERT_LT(1e-3, kGapFraction * r);  // the cover is in a gap at this radius
    // d = 1 from the cover's border: the disk's part on the view point's side of it.
    const double segment = r * r * std::acos(1.0 / r) - std::sqrt(r * r - 1.0);
    const double beside = 1.0 - segment / (std::numbers::pi * r * r);
    for (const double x : {1.0, -1.0}) {
        v.positionMm = Vec3(x, 3.0, 0.0);
        v.primitive = s->scene().closestHit({v.positionMm + v.normal * 1e-4, -v.normal})->primitive;
        const DiskShare d = viewPointAreaShare(scene, v, r, 4096, 0.3);
        EXPECT_EQ(d.inGap, x < 0.0) << "x " << x;
        EXPECT_NEAR(d.share, beside, 0.005) << "x " << x;
        // The light the plate transmits to the view point comes from below, where nothing
        // lies, and leaves on the cover's side: the same part of the disk counts, the open
        // part for a view point beside the cover and the covered part for one under it.
        const DiskShare t = viewPointAreaShare(scene, v, r, 4096, 0.3, true);
        EXPECT_FALSE(t.inGap) << "x " << x;
        EXPECT_EQ(t.viewInGap, x < 0.0) << "x " << x;
        EXPECT_NEAR(t.share, beside, 0.005) << "x " << x;
    }
    // Far inside either part, the whole disk; far from the plate, nothing in front of it.
    v.positionMm = Vec3(-20.0, 0.0, 0.0);
    EXPECT_TRUE(viewPointAreaShare(scene, v, r, 256, 0.3).inGap);
    EXPECT_EQ(viewPointAreaShare(scene, v, r, 256, 0.3).share, 1.0);
    v.positionMm = Vec3(20.0, 0.0, 0.0);
    EXPECT_FALSE(viewPointAreaShare(scene, v, r, 256, 0.3).inGap);
    EXPECT_EQ(viewPointAreaShare(scene, v, r, 256, 0.3).share, 1.0);
    // A gap wider than kGapFraction r is open space: at r = 0.005 mm the 1 um gap is 0.2 r.
    v.positionMm = Vec3(-20.0, 0.0, 0.0);
    EXPECT_FALSE(viewPointAreaShare(scene, v, 0.005, 16, 0.3).inGap);
}

// The gathering disk fits the piece it lies on: inside the 100 mm plate, near its rim and on
// it the pass radius (half or more of the disk on the plate); on the 0.2 mm strip
// r_v = kPieceRadiusFraction w (a disk as wide as the strip), w the strip's measured width
// within the bisection's resolution, and a later pass's smaller radius leaves it as it is.
TEST(Render, GatheringDiskFitsThePieceItLiesOn) {
    const auto s = platesScene();
    const Scene& scene = s->scene();
    ViewPoint v = upViewPoint(objectId(scene, "plate"));
    const double r = 2.0;
    for (const double turn : {0.0, 0.4, 1.3}) {
        for (const double x : {10.0, 49.5, 50.0 - 1e-9}) {  // inside, 0.5 mm and 0 from the rim
            v.positionMm = Vec3(x, -20.0, 0.0);
            EXPECT_EQ(viewPointDisk(scene, v, r, 16, turn).radiusMm, r) << x;
            EXPECT_EQ(viewPointDisk(scene, v, 0.5 * r, 16, turn).radiusMm, 0.5 * r) << x;
        }
        v.object = objectId(scene, "strip");
        v.positionMm = Vec3(200.1, 0.0, 0.0);
        const double width = pieceWidth(scene, v, 2.5 * r, kGapFraction * r, turn);
        EXPECT_LE(width, 0.2 * std::sqrt(2.0) + 1e-9) << turn;
        EXPECT_GE(width, 0.2 - 2.0 * 2.5 * r / 256.0) << turn;
        const GatherDisk d = viewPointDisk(scene, v, r, 16, turn);
        EXPECT_NEAR(d.radiusMm, kPieceRadiusFraction * width, 1e-12);
        // The disk (radius about 0.1 mm) lies almost whole on the strip; its half too.
        EXPECT_GT(d.share, 0.6);
        EXPECT_GT(d.halfShare, 0.9);
        EXPECT_NEAR(viewPointDisk(scene, v, 0.5 * r, 16, turn).radiusMm,
                    std::min(0.5 * r,
                             kPieceRadiusFraction * pieceWidth(scene, v, 1.25 * r, 0.05 * r, turn)),
                    1e-12);
        v.object = objectId(scene, "plate");
    }
    // Without the rim correction (--area-samples 0) every disk is the pass's.
    v.object = objectId(scene, "strip");
    EXPECT_EQ(viewPointDisk(scene, v, r, 0, 0.0).radiusMm, r);
}

// A 10 mm square plate lit by a point source 3 mm above it through a window: the irradiance
// falls tenfold from its centre to its rim, and a 4 mm gathering disk averages it over
// whatever of the disk lies on the plate. The flux comes out biased by several sigma; the
// half-radius estimate detects it, and the error with the bias covers the difference from
// forward Monte Carlo.
std::unique_ptr<PreparedScene> smallLitPlateScene() {
    return windowBoxScene(
        2.0, 30.0, Vec3(-5.0, -5.0, -1.5), Vec3(5.0, 5.0, -0.5),
        "[[mesh]]\nname = \"plate\"\nfile = \"{box}\"\nproperty = \"white\"\n"
        "[properties.white]\nscatter = { model = \"lambertian\", reflectance = 0.5 }\n"
        "[[source]]\nname = \"lamp\"\nkind = \"point\"\nposition_mm = [0.0, 0.0, 2.5]\n"
        "half_angle_deg = 80\naxis = [0, 0, -1]\nflux = 1.0\n"
        "[detector]\nname = \"det\"\nz_mm = 30.0\nsize_mm = [20.0, 20.0]\npixels = [4, 4]\n"
        "[[assign]]\nobjects = [\"L1.*\", \"L1.edge\"]\nproperty = \"ideal_ar\"\n");
}

TEST(Render, RadiusBiasOnASmallLitPartIsDetectedAndBounded) {
    const auto s = smallLitPlateScene();
    const SceneTransport& t = s->transport();
    const auto [ref, refSigma] = forwardTotal(*s, 2000000, 5);
    const ExitAperture a = exitApertureFor(s->scene(), t.images[0].geometry());
    auto run = [&](double radius) {
        RenderOptions o;
        o.raysPerPixel = 512;
        o.initialRadiusMm = radius;
        return render(*s, o, 10, a);
    };
    // A 4 mm disk on a 10 mm plate: biased beyond its noise, detected.
    const RenderState wide = run(4.0);
    const DetectorImage total = wide.total();
    const double sigma = std::sqrt(total.totalVariance(wide.passes()));
    const RadiusBias bias = wide.radiusBias();
    EXPECT_TRUE(bias.detected()) << bias.difference << " +- " << bias.sigma;
    EXPECT_GT(std::abs(total.totalFlux() - ref), 3.0 * std::hypot(sigma, refSigma))
        << "the scene no longer shows a radius bias: " << total.totalFlux() << " vs " << ref;
    EXPECT_LE(std::abs(total.totalFlux() - ref), 3.0 * std::hypot(bias.errorWith(sigma), refSigma))
        << total.totalFlux() << " vs " << ref << ", bias " << bias.estimate();
    EXPECT_LE(std::abs(total.totalFlux() - ref), bias.bound() + 3.0 * std::hypot(sigma, refSigma));
    // A 0.5 mm disk: within its errors, and what bias is left is bounded by a small figure.
    const RenderState narrow = run(0.5);
    const DetectorImage n = narrow.total();
    const RadiusBias nb = narrow.radiusBias();
    const double ns = nb.errorWith(std::sqrt(n.totalVariance(narrow.passes())));
    EXPECT_LE(std::abs(n.totalFlux() - ref), 3.0 * std::hypot(ns, refSigma))
        << n.totalFlux() << " vs " << ref;
    EXPECT_LT(nb.bound(), 0.02 * ref);
}

// The radius bias's arithmetic.
TEST(Render, RadiusBiasDetectsOnlyADifferenceBeyondItsNoise) {
    RadiusBias b{0.3, 0.1};
    EXPECT_FALSE(b.detected());
    // Not detected: the error holds the estimate beyond one sigma of its noise.
    EXPECT_DOUBLE_EQ(b.errorWith(0.5), std::hypot(0.5, 2.0 * (0.3 - 0.1)));
    EXPECT_EQ((RadiusBias{0.05, 0.1}).errorWith(0.5), 0.5);
    EXPECT_EQ((RadiusBias{0.0, 0.0}).errorWith(0.5), 0.5);
    EXPECT_DOUBLE_EQ(b.bound(), 2.0 * (0.3 + 0.2));
    b.difference = -0.31;
    EXPECT_TRUE(b.detected());
    EXPECT_DOUBLE_EQ(b.estimate(), -0.62);
    EXPECT_DOUBLE_EQ(b.errorWith(0.5), std::hypot(0.5, 0.62));
    EXPECT_FALSE((RadiusBias{0.0, 0.0}).detected());
    // A change of more than half the light: the estimate is no bound any more.
    EXPECT_TRUE(b.bounded(1.3));
    EXPECT_FALSE(b.bounded(1.1));
    EXPECT_TRUE((RadiusBias{0.3, 0.1}).bounded(0.01));  // not detected: bounded by its noise
}

// An isotropic point source 30 mm above a large Lambertian plate lights it directly; a free
// detector looks at the plate through a plane window (ideal antireflection) from the far side.
// The closed form: the plate's radiance R I h / (pi |p - s|^3) seen from each detector point
// through the slab (a ray at angle theta in air crosses the glass at theta_g, sin theta =
// n sin theta_g, and lands tan theta (air height) + tan theta_g (glass height) away),
// integrated over the detector and the hemisphere by quadrature.
// A Lambertian plate (reflectance R, 800 mm square, its face at z = -50) under an isotropic
// point lamp 30 mm above it, seen through a wide plane window (ideal antireflection) by a
// 20 mm detector of 2 x 2 pixels at z = 60. The plate's radiance falls as 1 / r^3 away from
// the lamp: the few pixel rays that land beneath it carry most of the direct light.
struct PointLampScene {
    double R = 0.3, flux = 1.0, n = 1.5, glass = 5.0, detZ = 60.0, side = 20.0;
    Vec3 lamp{0.0, 0.0, -20.0};
    std::unique_ptr<PreparedScene> read() const {
        const std::string stem = ::testing::TempDir() + "veil_render_" + testName();
        writeBox(stem + ".off", Vec3(-400.0, -400.0, -51.0), Vec3(400.0, 400.0, -50.0));
        const std::string path = stem + ".toml";
        FILE* f = fopen(path.c_str(), "w");
        EXPECT_TRUE(f);
        fprintf(f,
                "%s"
                "[[mesh]]\nname = \"plate\"\nfile = \"%s\"\nproperty = \"white\"\n"
                "[properties.white]\nscatter = { model = \"lambertian\", reflectance = %g }\n"
                "[[source]]\nname = \"lamp\"\nkind = \"point\"\nposition_mm = [%g, %g, %g]\n"
                "half_angle_deg = 180\nflux = %g\n"
                "[detector]\nname = \"det\"\nz_mm = %g\nsize_mm = [%g, %g]\npixels = [2, 2]\n"
                "[[assign]]\nobjects = [\"L1.*\", \"L1.edge\"]\nproperty = \"ideal_ar\"\n",
                planeWindowSystem(glass, 600.0, n).c_str(),
                std::filesystem::path(stem + ".off").filename().c_str(), R, lamp.x, lamp.y, lamp.z,
                flux, detZ, side, side);
        fclose(f);
        return PreparedScene::read(path, GlassCatalog::builtIn());
    }
};

TEST(Render, PointSourceLightingAPlateThroughAWindowObeysTheClosedForm) {
    const PointLampScene scene;
    const auto s = scene.read();
    const double R = scene.R, flux = scene.flux, n = scene.n, glass = scene.glass,
                 detZ = scene.detZ, side = scene.side;
    const Vec3 lamp = scene.lamp;
    // Quadrature: detector points on a 16 x 16 midpoint grid (the radiance varies slowly
    // over it), directions by theta (Gauss-Legendre-like midpoints in cos) and phi.
    const double I = flux / (4.0 * std::numbers::pi);
    const double h = lamp.z - (-50.0);
    const double air = detZ - (-50.0) - glass;
    double expected = 0.0;
    const int nx = 16, nt = 2000, np = 64;
    for (int ix = 0; ix < nx; ++ix)
        for (int iy = 0; iy < nx; ++iy) {
            const double x = side * ((ix + 0.5) / nx - 0.5), y = side * ((iy + 0.5) / nx - 0.5);
            double radiance = 0.0;  // integral of L cos over the hemisphere
            for (int it = 0; it < nt; ++it) {
                // mu = cos theta, uniform midpoints: d omega cos = mu d mu d phi.
                const double mu = (it + 0.5) / nt;
                const double st = std::sqrt(1.0 - mu * mu), sg = st / n;
                const double reach = air * st / mu + glass * sg / std::sqrt(1.0 - sg * sg);
                if (reach > 350.0) continue;  // off the plate (400 mm half side)
                for (int ip = 0; ip < np; ++ip) {
                    const double phi = 2.0 * std::numbers::pi * (ip + 0.5) / np;
                    const Vec3 p(x + reach * std::cos(phi), y + reach * std::sin(phi), -50.0);
                    const Vec3 d = p - lamp;
                    const double r = glm::length(d);
                    radiance += R * I * h / (std::numbers::pi * r * r * r) * mu * (1.0 / nt) *
                                (2.0 * std::numbers::pi / np);
                }
            }
            expected += radiance * (side / nx) * (side / nx);
        }
    const SceneTransport& t = s->transport();
    const ExitAperture a = exitApertureFor(s->scene(), t.images[0].geometry());
    RenderOptions o;
    o.raysPerPixel = 4096;
    o.photonsPerPass = 20000;
    o.initialRadiusMm = 5.0;
    const RenderState state = render(*s, o, 8, a);
    const DetectorImage direct = state.component(RenderComponent::Direct);
    const double sigma = std::sqrt(direct.totalVariance(state.passes()));
    EXPECT_GT(expected, 0.0);
    EXPECT_LE(std::abs(direct.totalFlux() - expected), 3.0 * sigma + 2e-3 * expected)
        << direct.totalFlux() << " vs " << expected << " sigma " << sigma;
    std::cout << "direct " << direct.totalFlux() << " +- " << sigma << ", closed form " << expected
              << "\n";
    EXPECT_LT(sigma, 0.05 * expected);
    // Light the plate scatters meets nothing else: no gathered light.
    EXPECT_EQ(state.component(RenderComponent::Caustic).totalFlux(), 0.0);
    EXPECT_EQ(state.component(RenderComponent::Secondary).totalFlux(), 0.0);
}

TEST(Render, RaySumsCountTheRaysThatCarryTheDirectLight) {
    // The pixel rays' side of the few-contributions check (RenderState::effectiveRays): per
    // pass the rays' sum is the backward stage's stray light (here the direct light alone),
    // and (sum c)^2 / sum c^2 lies between 1 and the rays. Under the point lamp a few rays
    // carry the light: at 16 rays per pixel the effective rays stay few (the error bar of
    // such a run was seen 11 sigma off), at 4096 many.
    const auto s = PointLampScene{}.read();
    const SceneTransport& t = s->transport();
    const ExitAperture a = exitApertureFor(s->scene(), t.images[0].geometry());
    auto run = [&](uint64_t raysPerPixel, int passes) {
        RenderOptions o;
        o.raysPerPixel = raysPerPixel;
        o.photonsPerPass = 5000;
        o.initialRadiusMm = 5.0;
        const Renderer renderer(t.view, t.images[0], a, o);
        RenderState state(t.images[0].geometry(), o.initialRadiusMm, o.alpha);
        for (int k = 1; k <= passes; ++k) {
            const RenderPass pass = renderer.runPass(k, state.radiusMm(), state.learned());
            double light = 0.0;
            for (const double v : pass.pixels[static_cast<int>(RenderComponent::Direct)])
                light += v;
            EXPECT_NEAR(pass.raySum, light, 1e-9 * light);
            EXPECT_GT(light, 0.0);
            EXPECT_LE(pass.raySquares, pass.raySum * pass.raySum);
            state.add(pass);
        }
        EXPECT_GE(state.effectiveRays(), 1.0);
        EXPECT_LE(state.effectiveRays(), double(passes) * 4.0 * raysPerPixel);
        EXPECT_NEAR(state.rayLight(), state.component(RenderComponent::Direct).totalFlux(),
                    1e-9 * state.rayLight());
        std::cout << raysPerPixel << " rays per pixel, " << passes
                  << " passes: " << state.effectiveRays() << " effective rays\n";
        return state.effectiveRays();
    };
    EXPECT_LT(run(16, 8), RenderState::kFewPhotons);
    EXPECT_GT(run(4096, 8), RenderState::kFewPhotons);
}

// The sun on the axis of an uncoated plane window (n = 1.5, R = 0.04 at normal incidence), a
// 10 mm detector behind it inside the beam: the light through the window as designed is
// (1 - R)^2 of what enters, the ghosts' (1 - R)^2 (R^2 + R^4 + ...), so of the light on the
// detector (1 - R) / (1 + R) the image-forming share is (1 - R)^2 / ((1 - R) / (1 + R)) and
// the stray share the rest, R^2 (1 + ...) = 1 - (1 - R)(1 + R).
std::unique_ptr<PreparedScene> sunThroughWindowScene() {
    return windowBoxScene(
        5.0, 10.0, Vec3(100.0, 100.0, -20.0), Vec3(110.0, 110.0, -19.0),
        "[[mesh]]\nname = \"block\"\nfile = \"{box}\"\nproperty = \"white\"\n"
        "[properties.white]\nscatter = { model = \"lambertian\", reflectance = 0.5 }\n"
        "[[source]]\nname = \"sun\"\nkind = \"sun\"\nfield_deg = [0.0, 0.0]\n"
        "[detector]\nname = \"det\"\nz_mm = 50.0\nsize_mm = [10.0, 10.0]\npixels = [1, 1]\n");
}

TEST(Render, ImageFormingLightIsTheDesignedPathAndTheGhostsAreStray) {
    const auto s = sunThroughWindowScene();
    const ExitAperture a = exitApertureFor(s->scene(), s->transport().images[0].geometry());
    RenderOptions o;
    o.raysPerPixel = 16;
    o.photonsPerPass = 100000;
    o.initialRadiusMm = 1.0;
    const RenderState state = render(*s, o, 4, a);
    const double total = state.total().totalFlux();
    const double image = state.imageForming().totalFlux();
    const double stray = state.strayLight().totalFlux();
    const double R = 0.04;
    ASSERT_GT(total, 0.0);
    EXPECT_NEAR(image / total, (1.0 - R) * (1.0 + R), 1e-5) << image << " of " << total;
    EXPECT_NEAR(stray / total, 1.0 - (1.0 - R) * (1.0 + R), 1e-5) << stray << " of " << total;
    EXPECT_NEAR(image + stray, total, 1e-12 * total);
}

// The visible photons deposit the sun's light as the ghost photons do, each 1 / (their
// number) of it: through the window the image-forming and the ghost light keep their closed
// forms, and the visible light is the ghost photons' alone within its noise.
TEST(Render, VisiblePhotonsCarryTheVisibleLightAsTheGhostPhotonsDo) {
    const auto s = sunThroughWindowScene();
    const ExitAperture a = exitApertureFor(s->scene(), s->transport().images[0].geometry());
    const double R = 0.04;
    double visible[2], sigma[2];
    for (const uint64_t v : {uint64_t{0}, uint64_t{50000}}) {
        RenderOptions o;
        o.raysPerPixel = 16;
        o.photonsPerPass = 20000;
        o.ghostPhotonsPerPass = 1000;
        o.visiblePhotonsPerPass = v;
        o.initialRadiusMm = 1.0;
        const RenderState state = render(*s, o, 4, a);
        const double total = state.total().totalFlux();
        ASSERT_GT(total, 0.0);
        EXPECT_NEAR(state.imageForming().totalFlux() / total, (1.0 - R) * (1.0 + R), 1e-5);
        EXPECT_NEAR(state.strayLight().totalFlux() / total, 1.0 - (1.0 - R) * (1.0 + R), 1e-5);
        const DetectorImage vis = state.component(RenderComponent::Visible);
        visible[v > 0] = vis.totalFlux();
        sigma[v > 0] = std::sqrt(vis.totalVariance(state.passes()));
        std::cout << v << " visible photons: visible " << visible[v > 0] << " +- " << sigma[v > 0]
                  << "\n";
    }
    EXPECT_NEAR(visible[1], visible[0], 4.0 * std::hypot(sigma[0], sigma[1]) + 1e-9 * visible[0]);
    EXPECT_LT(3.0 * sigma[1], sigma[0]);  // 51 times the photons: about 7x less noise
}

// A Gaussian 5 degree plate lit through a window by a large Lambertian emitter and seen
// through it: the pixel rays follow its lobe (followLobesBelowDeg) to the emitter, and the
// light they find agrees with forward Monte Carlo, as the gathered light does.
TEST(Render, FollowedNarrowLobesAgreeWithForwardMonteCarlo) {
    const auto s = windowBoxScene(
        5.0, 400.0, Vec3(-300.0, -300.0, -51.0), Vec3(300.0, 300.0, -50.0),
        "[[mesh]]\nname = \"plate\"\nfile = \"{box}\"\nproperty = \"gloss\"\n"
        "[properties.gloss]\n"
        "scatter = { model = \"gaussian\", reflectance = 0.3, half_width_deg = 5.0 }\n"
        "[[source]]\nname = \"lamp\"\nkind = \"lambertian\"\nposition_mm = [0.0, 0.0, 20.0]\n"
        "normal = [0.0, 0.0, -1.0]\nradius_mm = 100.0\nflux = 1.0\n"
        "[detector]\nname = \"det\"\nz_mm = 40.0\nsize_mm = [40.0, 40.0]\npixels = [2, 2]\n"
        "[[assign]]\nobjects = [\"L1.*\", \"L1.edge\"]\nproperty = \"ideal_ar\"\n");
    const SceneTransport& t = s->transport();
    const auto [ref, refSigma] = forwardTotal(*s, 2000000, 3);
    const ExitAperture a = exitApertureFor(s->scene(), t.images[0].geometry());
    // Followed by the pixel rays, gathered from photons, and splatted by the photons
    // (RenderOptions::splatLobesBelowDeg, the default).
    for (const auto& [follow, splat] :
         {std::pair{15.0, 0.0}, std::pair{0.0, 0.0}, std::pair{0.0, 15.0}}) {
        RenderOptions o;
        o.raysPerPixel = 2048;  // the aperture spans most of the hemisphere
        o.photonsPerPass = 50000;
        o.initialRadiusMm = 6.0;
        o.followLobesBelowDeg = follow;
        o.splatLobesBelowDeg = splat;
        const RenderState state = render(*s, o, 8, a);
        const DetectorImage caustic = state.component(RenderComponent::Caustic);
        const double sigma =
            state.radiusBias().errorWith(std::sqrt(caustic.totalVariance(state.passes())));
        EXPECT_LE(std::abs(caustic.totalFlux() - ref), 3.0 * std::hypot(sigma, refSigma))
            << "follow " << follow << ", splat " << splat << ": " << caustic.totalFlux() << " +- "
            << sigma << " vs " << ref << " +- " << refSigma;
        std::cout << "follow " << follow << ", splat " << splat << ": " << caustic.totalFlux()
                  << " +- " << sigma << " vs " << ref << " +- " << refSigma << "\n";
        EXPECT_LT(sigma, 0.12 * ref) << "follow " << follow << ", splat " << splat;
        // Followed or splatted, no photon is gathered: no radius bias to find.
        if (follow > 0.0 || splat > 0.0) {
            EXPECT_EQ(state.radiusBias().difference, 0.0);
        }
    }
}

// A 5 degree Gaussian diffuser (the front face of a 1 mm glass plate passes 30 % in a lobe
// about the refracted direction) behind a plane window, lit through the window by a large
// Lambertian emitter, seen by a detector behind it. The pixel rays follow the lobe; at the
// diffuser the emitter's light is connected through the window (the pilot's chain of its two
// faces) and weighed by multiple importance sampling against the lobe's own direction, which
// meets the emitter through the window too. With and without the connection, against forward
// Monte Carlo: the two strategies' weights must sum to one for the total to hold.
TEST(Render, FollowedLobeConnectedThroughTheLensAgreesWithForwardMonteCarlo) {
    const std::string path = ::testing::TempDir() + "veil_render_" + testName() + ".toml";
    FILE* f = fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    fprintf(f,
            "[system]\nwavelengths_nm = [550.0]\naperture = { epd_mm = 20.0 }\n"
            "fields_deg = [0.0]\nsurfaces = [\n"
            "  { r = 0.0, t = 5.0, glass = { nd = 1.5, vd = 0.0 }, sd = 60.0, stop = true },\n"
            "  { r = 0.0, t = 45.0, sd = 60.0 },\n"
            "  { r = 0.0, t = 1.0, glass = { nd = 1.5, vd = 0.0 }, sd = 60.0 },\n"
            "  { r = 0.0, t = 250.0, sd = 60.0 },\n]\n"
            "[properties.diffuser]\n"
            "scatter = { model = \"gaussian\", transmittance = 0.3, half_width_deg = 5.0 }\n"
            "[[source]]\nname = \"lamp\"\nkind = \"lambertian\"\nposition_mm = [0.0, 0.0, -20.0]\n"
            "normal = [0.0, 0.0, 1.0]\nradius_mm = 10.0\nflux = 1.0\n"
            "[detector]\nname = \"det\"\nz_mm = 290.0\nsize_mm = [40.0, 40.0]\npixels = [2, 2]\n"
            "[[assign]]\nobjects = [\"L1.*\", \"L1.edge\", \"L2.back\"]\nproperty = \"ideal_ar\"\n"
            "[[assign]]\nobjects = \"L2.front\"\nproperty = \"diffuser\"\n");
    fclose(f);
    const auto s = PreparedScene::read(path, GlassCatalog::builtIn());
    const SceneTransport& t = s->transport();
    const auto [ref, refSigma] = forwardTotal(*s, 2000000, 7);
    ASSERT_GT(ref, 0.0);
    const ExitAperture a = exitApertureFor(s->scene(), t.images[0].geometry());
    double sigmaOn = 0.0, sigmaOff = 0.0;
    for (const bool connect : {true, false}) {
        RenderOptions o;
        o.raysPerPixel = 1024;
        o.photonsPerPass = 20000;
        o.initialRadiusMm = 6.0;
        o.followLobesBelowDeg = 15.0;
        o.connectThroughLens = connect;
        const RenderState state = render(*s, o, 6, a);
        const DetectorImage all = state.total();
        const double sigma = std::sqrt(all.totalVariance(state.passes()));
        std::cout << "connect " << connect << ": " << all.totalFlux() << " +- " << sigma
                  << ", forward " << ref << " +- " << refSigma << "\n";
        EXPECT_LE(std::abs(all.totalFlux() - ref), 3.0 * std::hypot(sigma, refSigma))
            << "connect " << connect << ": " << all.totalFlux() << " +- " << sigma << " vs " << ref
            << " +- " << refSigma;
        EXPECT_LT(sigma, 0.05 * ref) << "connect " << connect;
        (connect ? sigmaOn : sigmaOff) = sigma;
    }
    // The emitter's image through the window is about as wide as the lobe: each strategy is
    // the better one over part of the directions, and together they beat the lobe alone
    // (measured: 0.5 % against 3.2 %).
    EXPECT_LT(3.0 * sigmaOn, sigmaOff);
}

// The bias of a standard error from n passes: closed forms at 2 and 3 passes, and the mean
// of the sample standard deviation of 4 normal draws over 200 000 trials.
TEST(Render, StandardErrorBiasIsTheMeanSampleDeviation) {
    EXPECT_EQ(standardErrorBias(1), 1.0);
    EXPECT_NEAR(standardErrorBias(2), std::sqrt(2.0 / std::numbers::pi), 1e-12);
    EXPECT_NEAR(standardErrorBias(3), std::sqrt(std::numbers::pi) / 2.0, 1e-12);
    EXPECT_GT(standardErrorBias(1000), 0.9997);
    std::mt19937_64 rng(7);
    std::normal_distribution<double> normal;
    const int trials = 200000;
    double sum = 0.0, squares = 0.0;
    for (int t = 0; t < trials; ++t) {
        double x[4], mean = 0.0, var = 0.0;
        for (double& v : x) mean += (v = normal(rng)) / 4.0;
        for (double v : x) var += (v - mean) * (v - mean) / 3.0;
        sum += std::sqrt(var);
        squares += var;
    }
    const double m = sum / trials, sd = std::sqrt((squares / trials - m * m) / trials);
    EXPECT_NEAR(m, standardErrorBias(4), 4.0 * sd) << m << " +- " << sd;
}

TEST(Render, RadiusShrinksByTheProgressiveRule) {
    const DetectorGeometry g{"d", Frame{}, 1.0, 1.0, 1, 1, -1, std::nullopt, Vec2(0.0)};
    RenderState state(g, 3.0, 2.0 / 3.0);
    RenderPass pass;
    for (auto& v : pass.pixels) v.assign(1, 1.0);
    double r2 = 9.0;
    for (int k = 1; k <= 50; ++k) {
        EXPECT_NEAR(state.radiusMm() * state.radiusMm(), r2, 1e-12 * r2);
        state.add(pass);
        r2 *= (k + 2.0 / 3.0) / (k + 1.0);
    }
    // r_k^2 ~ k^(alpha - 1): the product tends to Gamma(2) / Gamma(1 + alpha) k^(alpha - 1).
    const double k = 51.0;
    EXPECT_NEAR(state.radiusMm() * state.radiusMm() / 9.0,
                std::tgamma(2.0) / std::tgamma(1.0 + 2.0 / 3.0) * std::pow(k, -1.0 / 3.0),
                0.01 * state.radiusMm() * state.radiusMm() / 9.0);
}

TEST(Render, ErrorFallsAtTheProgressivePhotonMappingRate) {
    // With a gathering disk larger than the pixel's footprint on the uniformly lit plate, a
    // pass's caustic estimate counts the photons in the disk: its variance goes as 1 / r_k^2,
    // and the mean of n passes has variance P(n) = sum_k r_1^2 / r_k^2 / n^2 times the first
    // pass's, ~ n^-alpha (a fixed kernel would give n^-1). The variance of the mean is
    // measured over independent runs (seeds) at n = 4 ... 64 and its log-log slope fitted.
    WindowScene w;
    w.emitterRadius = 1000.0;
    w.pixels = 1;
    w.detectorMm = 0.2;
    w.cap = false;
    const auto s = windowPlateScene(w);
    const ExitAperture a{Vec3(0.0, 0.0, -49.99), Vec3(0.0, 0.0, 1.0), 10.0};
    RenderOptions o;
    o.raysPerPixel = 512;  // the backward part's own noise well below the photons'
    o.photonsPerPass = 400;
    o.initialRadiusMm = 300.0;
    o.alpha = 0.5;
    // The rate assumes independent photons: quasi-random ones count the photons in a disk
    // with far less spread while it holds many of their strata, and so fall differently.
    o.quasiRandomPhotons = false;
    const int runs = 100, passes = 64;
    const std::vector<int> at = {4, 8, 16, 32, 64};
    std::vector<std::vector<double>> means(at.size());
    for (int run = 0; run < runs; ++run) {
        RenderOptions ro = o;
        ro.seed = 1000 + run;
        const Renderer renderer(s->transport().view, s->transport().images[0], a, ro);
        RenderState state(s->transport().images[0].geometry(), ro.initialRadiusMm, ro.alpha);
        for (int k = 1; k <= passes; ++k) {
            state.add(renderer.runPass(k, state.radiusMm(), state.learned()));
            for (size_t j = 0; j < at.size(); ++j)
                if (k == at[j])
                    means[j].push_back(state.component(RenderComponent::Caustic).flux(0));
        }
    }
    auto variance = [](const std::vector<double>& x) {
        double m = 0.0, v = 0.0;
        for (double xi : x) m += xi;
        m /= x.size();
        for (double xi : x) v += (xi - m) * (xi - m);
        return v / (x.size() - 1);
    };
    // The expected variances from the radius sequence.
    std::vector<double> predicted;
    double r2 = 1.0, sum = 0.0;
    for (int k = 1; k <= passes; ++k) {
        sum += 1.0 / r2;
        for (int n : at)
            if (k == n) predicted.push_back(sum / (double(n) * n));
        r2 *= (k + o.alpha) / (k + 1.0);
    }
    auto slope = [&](auto&& y) {
        double sx = 0, sy = 0, sxx = 0, sxy = 0;
        const double m = at.size();
        for (size_t j = 0; j < at.size(); ++j) {
            const double x = std::log(double(at[j])), v = std::log(y(j));
            sx += x;
            sy += v;
            sxx += x * x;
            sxy += x * v;
        }
        return (m * sxy - sx * sy) / (m * sxx - sx * sx);
    };
    const double measured = slope([&](size_t j) { return variance(means[j]); });
    const double expected = slope([&](size_t j) { return predicted[j]; });
    // expected is -0.55 here (-alpha asymptotically); each variance of 100 runs carries 14 %.
    EXPECT_NEAR(measured, expected, 0.15) << "fixed-kernel Monte Carlo would give -1";
    EXPECT_GT(measured, -0.8);
}

// One component's total flux and relative error, for the window scene at reflectances 0.1 %
// and 30 % (the plate's, and the wall's when `wall`), 64 rays per pixel, 20000 photons.
struct ByReflectance {
    std::array<double, 2> flux{}, error{};
};
ByReflectance componentByReflectance(RenderComponent component, bool wall, double radiusMm,
                                     double guide, int passes) {
    ByReflectance out;
    const std::array<double, 2> reflectance = {0.001, 0.3};
    for (int i = 0; i < 2; ++i) {
        WindowScene w;
        w.reflectance = reflectance[i];
        w.wall = wall;
        const auto s = windowPlateScene(w);
        RenderOptions o;
        o.raysPerPixel = 64;
        o.photonsPerPass = 20000;
        o.initialRadiusMm = radiusMm;
        o.guideFraction = guide;
        const RenderState state = render(*s, o, passes, plateAperture());
        const DetectorImage c = state.component(component);
        out.flux[i] = c.totalFlux();
        out.error[i] = std::sqrt(c.totalVariance(state.passes())) / c.totalFlux();
    }
    return out;
}

TEST(Render, SingleScatterErrorDoesNotDependOnTheReflectance) {
    // The seed's claim: a 0.1 % plate costs what a 30 % one does. The photons reach the plate
    // the same way whatever it reflects; the reflectance only scales what they leave there.
    const auto [flux, error] = componentByReflectance(RenderComponent::Caustic, false, 2.0,
                                                      RenderOptions{}.guideFraction, 6);
    EXPECT_NEAR(error[0], error[1], 0.2 * error[1]);
    EXPECT_NEAR(flux[0] / flux[1], 0.001 / 0.3, 0.05 * 0.001 / 0.3);
}

TEST(Render, TwiceScatteredErrorDoesNotDependOnTheReflectance) {
    // The same claim for light scattered twice (plate to wall or wall to plate, both of
    // reflectance R): a photon that scattered once off a dark surface must be followed as far
    // as one that scattered off a bright one, or the secondary light of dark mounts starves
    // (a roulette relative to the emitted flux kept 1 in 100 at R = 0.1 %).
    const auto [flux, error] =
        componentByReflectance(RenderComponent::Secondary, true, 4.0, 0.0, 16);
    ASSERT_GT(flux[0], 0.0);
    EXPECT_NEAR(error[0], error[1], 0.3 * error[1]) << error[0] << " vs " << error[1];
    // Twice scattered: the flux scales as R^2, within the two runs' errors.
    const double ratio = 0.001 * 0.001 / (0.3 * 0.3);
    EXPECT_NEAR(flux[0] / flux[1], ratio, 4.0 * std::hypot(error[0], error[1]) * ratio)
        << "errors " << error[0] << ", " << error[1];
}

TEST(Render, GuidedAndWindowedScattersKeepTheTwiceScatteredLight) {
    // The scatter guide (tracer/render/scatter_guide.h) draws the photons' scattered directions
    // toward the plate and the wall where the passes before gathered light, each weighted by
    // the surface's density over the mixture's; the weight windows split and roulette the
    // photons where they scatter by the yield learned there. The twice scattered light guided
    // (90 % of the directions), and with windows of 1.5, agrees with it unguided, and each
    // total with forward Monte Carlo. Here the windows play roulette only (about 80 % of the
    // windowed scatters end): the light scattered once, gathered at the plate, credits no
    // scatter, so no cube's yield reaches the mean's. ScatterGuide.WeightWindowsKeepTheExpectedFlux
    // covers the splits.
    WindowScene w;
    w.wall = true;
    const auto s = windowPlateScene(w);
    auto run = [&](double g, double window) {
        RenderOptions o;
        o.raysPerPixel = 64;
        o.photonsPerPass = 20000;
        o.initialRadiusMm = 4.0;
        o.scatterGuideFraction = g;
        o.weightWindow = window;
        return render(*s, o, 16, plateAperture());
    };
    const RenderState plain = run(0.0, 0.0);
    const uint64_t n = plain.passes();
    const DetectorImage b = plain.component(RenderComponent::Secondary);
    const double sb = std::sqrt(b.totalVariance(n));
    ASSERT_GT(b.totalFlux(), 0.0);
    const auto [reference, sf] = forwardTotal(*s, 1000000, 13);
    for (const auto& [g, window] : {std::pair{0.9, 0.0}, std::pair{0.0, 1.5}}) {
        const RenderState state = run(g, window);
        const DetectorImage a = state.component(RenderComponent::Secondary);
        const double sa = std::sqrt(a.totalVariance(n));
        EXPECT_LE(std::abs(a.totalFlux() - b.totalFlux()), 4.0 * std::hypot(sa, sb))
            << "guide " << g << ", window " << window << ": " << a.totalFlux() << " +- " << sa
            << " vs " << b.totalFlux() << " +- " << sb;
        // 16 passes of 20000 photons: 9.4 % unguided, 10.7 % guided (the plate's light reaches
        // the wall from everywhere: little for a guide to learn here).
        EXPECT_LT(sa, 0.15 * b.totalFlux()) << "guide " << g << ", window " << window;
        const DetectorImage total = state.total();
        const double st = std::sqrt(total.totalVariance(n));
        // With the radius bias bound of AgreesWithForwardMonteCarloInTotalAndPerPixel (1e-3 of
        // the flux; the radius here is smaller).
        EXPECT_LE(std::abs(total.totalFlux() - reference),
                  4.0 * std::hypot(st, sf) + 1e-3 * reference)
            << "guide " << g << ", window " << window << ": " << total.totalFlux() << " +- " << st
            << " vs " << reference << " +- " << sf;
    }
}

TEST(Render, BalancedPhotonsEvenOutTheWorkOfTheTwoSides) {
    RenderOptions o;
    o.ghostPhotonsPerPass = 16384;
    o.maxPhotonsPerPass = 4000000;
    RenderPass pass;
    pass.photonsPerSource = 116384;  // 100000 beyond the ghost photons
    // The other photons did 1e6 units, the ghost photons 5e5, the view points 3e6: the others
    // grow to fill what the ghost photons leave, 2.5e6, at the same cost per photon.
    pass.photonWork = 1500000;
    pass.ghostWork = 500000;
    pass.viewPointWork = 3000000;
    EXPECT_EQ(balancedPhotons(o, pass), 16384u + 250000u);
    // At most 4x either way per pass.
    pass.viewPointWork = 100000000;
    EXPECT_EQ(balancedPhotons(o, pass), 16384u + 400000u);
    pass.viewPointWork = 600000;  // the ghost photons alone take most of it
    EXPECT_EQ(balancedPhotons(o, pass), 16384u + 25000u);
    // Ghost photons beyond the view points' work: the others at their fewest.
    pass.photonsPerSource = 16384 + 8192;
    pass.viewPointWork = 400000;
    EXPECT_EQ(balancedPhotons(o, pass), 16384u + kMinBalancedPhotons);
    // Never beyond the most photons per pass.
    o.maxPhotonsPerPass = 200000;
    pass.photonsPerSource = 116384;
    pass.viewPointWork = 100000000;
    EXPECT_EQ(balancedPhotons(o, pass), 200000u);
    // A first pass with no photons beyond the ghost photons starts the others at the fewest.
    pass.photonsPerSource = 5000;
    pass.ghostWork = pass.photonWork;
    EXPECT_EQ(balancedPhotons(o, pass), 5000u + kMinBalancedPhotons);
}

// A mean image of `passes` passes whose pixels have the given means and variances (of the
// mean), as RenderState::total() gives it.
DetectorImage meanImage(const std::vector<double>& mean, const std::vector<double>& variance,
                        int passes) {
    const DetectorGeometry g{"d", Frame{}, 1.0,          1.0,      static_cast<int>(mean.size()),
                             1,   -1,      std::nullopt, Vec2(0.0)};
    std::vector<double> squares(mean.size());
    const double k = passes;
    for (size_t p = 0; p < mean.size(); ++p)
        squares[p] = variance[p] * (k - 1.0) / k + mean[p] * mean[p] / k;
    double total = 0.0;
    for (double m : mean) total += m;
    return DetectorImage::fromSums(g, mean, squares,
                                   std::vector<uint64_t>(mean.size(), uint64_t(passes)), total,
                                   total * total / k, uint64_t(passes));
}

TEST(Render, BalancedVisiblePhotonsFollowTheTargetsError) {
    RenderOptions o;
    o.maxPhotonsPerPass = 4000000;
    RenderPass pass;
    pass.ghostPerSource = 16384;
    pass.visiblePerSource = 65536;
    pass.viewPointWork = 3000000;
    pass.photonWork = 2000000;  // of which the visible photons' 1e6: T_v / T_r = 1 / 4
    pass.visibleWork = 1000000;
    const int k = 4;
    const double inverse = k / 81920.0;  // every pass at this pass's photons
    // Two pixels of equal light and variance; the visible light's share of it a / (a + b).
    auto next = [&](double share) {
        const DetectorImage target = meanImage({1.0, 1.0}, {0.01, 0.01}, k);
        const DetectorImage visible = meanImage({0.5, 0.5}, {0.01 * share, 0.01 * share}, k);
        return balancedVisiblePhotons(o, pass, target, &visible, k, inverse);
    };
    // At the best split the variance shares are the time shares: a / b = T_v / T_r.
    EXPECT_EQ(next(0.2), 65536u);
    // a / b = 1 against 1 / 4: the best ratio is sqrt(1 x 1/4) = 1 / 2, 2x the time; the step
    // goes halfway in the logarithm, sqrt(2).
    EXPECT_EQ(next(0.5), uint64_t(std::round(65536 * std::sqrt(2.0))));
    // a / b = 1 / 16: half the time; halfway, 1 / sqrt(2).
    EXPECT_EQ(next(1.0 / 17.0), uint64_t(std::round(65536 / std::sqrt(2.0))));
    // No visible light in the target's error: a quarter, down to the fewest.
    EXPECT_EQ(next(0.0), 16384u);
    EXPECT_EQ(balancedVisiblePhotons(o, pass, meanImage({1.0, 1.0}, {0.01, 0.01}, k), nullptr, k,
                                     inverse),
              16384u);
    pass.visiblePerSource = 2048;
    EXPECT_EQ(next(0.0), kMinVisiblePhotons);
    pass.visiblePerSource = 65536;
    // All of it: 4x at most, and then the visible photons' work at most 8x the rest's.
    EXPECT_EQ(next(1.0), 4u * 65536u);
    pass.photonWork = 9500000;  // T_v / T_r = 8.5 / 4: 4x would be 8.5x the rest's work
    pass.visibleWork = 8500000;
    EXPECT_EQ(next(1.0), uint64_t(std::round(65536 * kMostVisibleWork * 4.0 / 8.5)));
    pass.photonWork = 2000000;
    pass.visibleWork = 1000000;
    // The passes before had fewer photons (the inverse sum twice this pass's): the visible
    // variance per pass at this pass's photons is half what the mean's says. A third of the
    // variance is then a / b = (1/6) / (2/3) = T_v / T_r: the best split.
    {
        const DetectorImage target = meanImage({1.0, 1.0}, {0.01, 0.01}, k);
        const DetectorImage visible = meanImage({0.5, 0.5}, {0.01 / 3.0, 0.01 / 3.0}, k);
        EXPECT_EQ(balancedVisiblePhotons(o, pass, target, &visible, k, 2.0 * inverse), 65536u);
    }
    // No visible photons traced (none asked for, or no source the photons see): as it was.
    pass.visiblePerSource = 0;
    EXPECT_EQ(next(1.0), 0u);
    pass.visiblePerSource = 65536;
    pass.visibleWork = 0;
    EXPECT_EQ(next(1.0), 65536u);
    // After one pass (no variance yet): as it was where the target holds visible light, a
    // quarter where it holds none.
    pass.visibleWork = 1000000;
    const DetectorImage one = meanImage({1.0}, {0.0}, 1);
    EXPECT_EQ(balancedVisiblePhotons(o, pass, one, &one, 1, inverse), 65536u);
    EXPECT_EQ(balancedVisiblePhotons(o, pass, one, nullptr, 1, inverse), 16384u);
    const DetectorImage dark = meanImage({0.0}, {0.0}, 1);
    EXPECT_EQ(balancedVisiblePhotons(o, pass, one, &dark, 1, inverse), 16384u);
}

TEST(Render, BalancedPhotonsFollowTheTargetsError) {
    RenderOptions o;
    o.maxPhotonsPerPass = 4000000;
    o.ghostPhotonsPerPass = 16384;
    RenderPass pass;
    pass.photonsPerSource = 16384 + 100000;  // 100k beyond the ghost photons
    pass.viewPointWork = 3000000;
    pass.photonWork = 2000000;  // of which the ghost and visible photons' 1e6: T_p / T_r = 1 / 4
    pass.ghostWork = 500000;
    pass.visibleWork = 500000;
    const int k = 4;
    // Two pixels of equal light whose variance per pass is 4 x 0.01; the photons' share of it
    // s, as their halves' difference d, d^2 = 0.04 s.
    auto next = [&](double share) {
        const DetectorImage target = meanImage({1.0, 1.0}, {0.01, 0.01}, k);
        const double d = std::sqrt(0.04 * share);
        return balancedPhotonsByError(o, pass, target, {d, -d}, k) - 16384;
    };
    // At the best split the variance shares are the time shares: a / b = T_p / T_r.
    EXPECT_EQ(next(0.2), 100000u);
    // a / b = 1 against 1 / 4: the best is 2x the time; halfway in the logarithm, sqrt(2).
    EXPECT_EQ(next(0.5), uint64_t(std::round(100000 * std::sqrt(2.0))));
    // a / b = 1 / 16: half the time; halfway, 1 / sqrt(2).
    EXPECT_EQ(next(1.0 / 17.0), uint64_t(std::round(100000 / std::sqrt(2.0))));
    // All of it: the rest is taken as at least a tenth (one pass's halves are noisy), a / b =
    // 10, (10 x 4)^(1/4).
    EXPECT_EQ(next(1.0), uint64_t(std::round(100000 * std::pow(40.0, 0.25))));
    // No gathered light in the target's error, one pass, no spread, or no photons beyond the
    // ghost photons: the balance by work (its room 3e6 - 1e6 against their 1e6: 2x).
    EXPECT_EQ(next(0.0), 200000u);
    EXPECT_EQ(balancedPhotons(o, pass) - 16384, 200000u);
    const DetectorImage one = meanImage({1.0, 1.0}, {0.0, 0.0}, 1);
    EXPECT_EQ(balancedPhotonsByError(o, pass, one, {0.1, 0.1}, 1), balancedPhotons(o, pass));
    const DetectorImage flat = meanImage({1.0, 1.0}, {0.0, 0.0}, k);
    EXPECT_EQ(balancedPhotonsByError(o, pass, flat, {0.1, 0.1}, k), balancedPhotons(o, pass));
    EXPECT_EQ(balancedPhotonsByError(o, pass, meanImage({1.0, 1.0}, {0.01, 0.01}, k), {0.1}, k),
              balancedPhotons(o, pass));
    // 4x at most a pass, and within the bounds.
    pass.viewPointWork = 300000000;
    EXPECT_EQ(next(0.5), 400000u);
    o.maxPhotonsPerPass = 16384 + 250000;
    EXPECT_EQ(next(0.5), 250000u);
    o.maxPhotonsPerPass = 4000000;
    pass.viewPointWork = 30000;
    pass.photonWork = 200000000;
    pass.ghostWork = 500000;
    pass.visibleWork = 500000;
    EXPECT_EQ(next(1.0 / 17.0), 25000u);
    pass.photonsPerSource = 16384 + 5000;
    EXPECT_EQ(next(1.0 / 17.0), kMinBalancedPhotons);
}

// The photon halves (RenderPass::photonParity): the square of their difference estimates the
// variance the photons give the gathered light, which the photon balance weighs against the
// rest. With 1000 photons and 1024 rays per pixel the view points add about a sixth of the
// passes' spread of the gathered flux (measured at 32000 photons: 1.2e-8 of spread, 1.5e-9 of
// it the photons'), so the mean squared difference is most of the spread (0.94 of it as run);
// and it falls as 1 / N with the photons (44x for 32x as run, each a mean of 80 squares).
TEST(Render, PhotonHalvesMeasureThePhotonsShareOfTheVariance) {
    WindowScene w;
    w.wall = true;  // twice-scattered light too
    const auto s = windowPlateScene(w);
    auto run = [&](uint64_t photons, int passes) {
        RenderOptions o;
        o.raysPerPixel = 1024;
        o.photonsPerPass = photons;
        o.ghostPhotonsPerPass = 1;  // all but one photon are ones the balance scales
        o.quasiRandomPhotons = false;
        o.initialRadiusMm = 4.0;
        o.alpha = 0.99;  // the radius all but fixed: the passes alike
        o.balancePhotons = o.balancePhotonsByError = true;  // the halves are booked for it
        const Renderer renderer(s->transport().view, s->transport().images[0], plateAperture(), o);
        std::vector<double> gathered, halves;
        for (int k = 1; k <= passes; ++k) {
            const RenderPass pass = renderer.runPass(k, o.initialRadiusMm, {}, 0);
            double g = 0.0, d = 0.0;
            for (size_t p = 0; p < pass.photonParity.size(); ++p) {
                g += pass.pixels[static_cast<int>(RenderComponent::Caustic)][p] +
                     pass.pixels[static_cast<int>(RenderComponent::Secondary)][p];
                d += pass.photonParity[p];
            }
            gathered.push_back(g);
            halves.push_back(d * d);
        }
        double mean = 0.0, squares = 0.0, halvesMean = 0.0;
        for (double g : gathered) mean += g / passes;
        for (double g : gathered) squares += (g - mean) * (g - mean) / (passes - 1);
        for (double h : halves) halvesMean += h / passes;
        return std::pair{squares, halvesMean};
    };
    const auto [spread, halves] = run(1000, 80);
    // Each of the two is a mean of 80 squares: about 16 % off at one sigma.
    EXPECT_GT(halves, 0.55 * spread);
    EXPECT_LT(halves, 1.6 * spread);
    const auto [spreadMany, halvesMany] = run(32000, 80);
    EXPECT_GT(halves / halvesMany, 32.0 / 1.8);
    EXPECT_LT(halves / halvesMany, 32.0 * 1.8);
    // There the view points' share shows: the photons' is a small part of the spread.
    EXPECT_LT(halvesMany, 0.5 * spreadMany);
}

TEST(Render, BalancedPhotonsKeepTheEstimateUnbiased) {
    // Every pass's estimate is unbiased whatever its photon count, so the mean over passes of
    // different counts is too: the balanced render against forward Monte Carlo, as
    // AgreesWithForwardMonteCarloInTotalAndPerPixel does for a fixed count.
    const auto s = windowPlateScene({});
    const auto [reference, referenceSigma] = forwardTotal(*s, 1000000, 17);
    RenderOptions o;
    o.raysPerPixel = 1024;
    o.photonsPerPass = 100000;
    o.ghostPhotonsPerPass = 1000;
    o.balancePhotons = true;
    o.initialRadiusMm = 10.0;
    const Renderer renderer(s->transport().view, s->transport().images[0], plateAperture(), o);
    RenderState state(s->transport().images[0].geometry(), o.initialRadiusMm, o.alpha);
    std::vector<uint64_t> photons;
    for (int k = 1; k <= 10; ++k) {
        const RenderPass pass =
            renderer.runPass(k, state.radiusMm(), state.learned(), state.photonsPerPass());
        photons.push_back(pass.photonsPerSource);
        // The next count follows this pass's work.
        EXPECT_EQ(pass.nextPhotonsPerSource, balancedPhotons(o, pass));
        state.add(pass);
    }
    // 100000 photons outweigh the view points of 1024 rays per pixel many times here: the
    // count falls, by at most 4x a pass, to where the two sides' work meet or to the fewest.
    EXPECT_LT(photons.back(), photons.front() / 16);
    for (size_t k = 1; k < photons.size(); ++k) EXPECT_GE(4 * photons[k], photons[k - 1]);
    const DetectorImage total = state.total();
    const double sigma = std::sqrt(total.totalVariance(state.passes()));
    // The radius bias bound of the fixed-count test (1e-3 of the flux) added.
    EXPECT_LE(std::abs(total.totalFlux() - reference),
              4.0 * std::hypot(sigma, referenceSigma) + 1e-3 * reference)
        << total.totalFlux() << " +- " << sigma << " vs " << reference << " +- " << referenceSigma;
    EXPECT_LT(sigma, 0.03 * reference);
}

TEST(Render, ResumedAndThreadedRunsAreBitwiseTheSame) {
    WindowScene w;
    w.wall = true;  // light scattered twice: the scatter guide learns and guides too
    const auto s = windowPlateScene(w);
    RenderOptions o;
    o.raysPerPixel = 16;
    o.photonsPerPass = 5000;
    o.ghostPhotonsPerPass = 1000;
    o.balancePhotons = true;  // each pass's photons from the work counts of the one before
    o.initialRadiusMm = 2.0;
    const uint64_t print = 12345;
    const Renderer renderer(s->transport().view, s->transport().images[0], plateAperture(), o);
    const DetectorGeometry& g = s->transport().images[0].geometry();
    std::vector<uint64_t> photons;
    auto run = [&](RenderState& state, int passes) {
        while (state.passes() < passes) {
            const RenderPass pass = renderer.runPass(state.passes() + 1, state.radiusMm(),
                                                     state.learned(), state.photonsPerPass());
            photons.push_back(pass.photonsPerSource);
            state.add(pass);
        }
    };
    RenderState straight(g, o.initialRadiusMm, o.alpha);
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
        run(straight, 5);
    }
    // The balance moved the photon count away from the first pass's.
    ASSERT_EQ(photons.size(), 5u);
    EXPECT_EQ(photons[0], 5000u);
    EXPECT_NE(photons[4], photons[0]);
    const std::vector<uint64_t> straightPhotons = photons;
    photons.clear();
    // Three passes, a checkpoint, read back, two more, on two threads.
    const std::filesystem::path cp = ::testing::TempDir() + "veil_render_" + testName() + ".cp";
    {
        RenderState first(g, o.initialRadiusMm, o.alpha);
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        run(first, 3);
        first.write(cp, print);
    }
    RenderState resumed = RenderState::read(cp, print, g);
    EXPECT_EQ(resumed.passes(), 3);
    // A pass whose deadline passes (here before it starts: it stops at its first block) has no
    // result, and the run goes on as if it had not been tried.
    EXPECT_THROW(renderer.runPass(4, resumed.radiusMm(), resumed.learned(),
                                  resumed.photonsPerPass(), -1, Deadline(Deadline::Clock::now())),
                 DeadlinePassed);
    EXPECT_EQ(resumed.passes(), 3);
    {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 2);
        run(resumed, 5);
    }
    EXPECT_TRUE(resumed.sameSums(straight));
    EXPECT_EQ(photons, straightPhotons);  // on two threads, across the checkpoint
    EXPECT_GT(straight.total().totalFlux(), 0.0);
    // The passes after the first were guided by what the ones before them learned, and the
    // checkpoint carried it.
    ASSERT_FALSE(straight.learned().empty());
    EXPECT_EQ(resumed.learned(), straight.learned());
    // The learned light of all three guides: the aperture's, the emission's, the scatters'.
    const size_t aperture = ApertureGuide(g.pixelsX, g.pixelsY).bins(),
                 emission = EmissionGuide(1, g.pixelsX, g.pixelsY).bins();
    ASSERT_GT(straight.learned().size(), aperture + emission);
    double scattered = 0.0;
    for (size_t b = aperture + emission; b < straight.learned().size(); ++b)
        scattered += straight.learned()[b];
    EXPECT_GT(scattered, 0.0);
    // A checkpoint of another fingerprint or grid is refused, naming the file.
    EXPECT_THROW(RenderState::read(cp, print + 1, g), std::runtime_error);
    DetectorGeometry other = g;
    other.pixelsX = 8;
    EXPECT_THROW(RenderState::read(cp, print, other), std::runtime_error);
    std::filesystem::remove(cp);
}

}  // namespace
}  // namespace veil
