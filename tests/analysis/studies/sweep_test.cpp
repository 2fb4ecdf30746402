// veil sweep as a value (analysis/studies/sweep.h): value lists and ranges, the variants of a grid
// and a zip, common random numbers (a Lambertian mount's stray light scales exactly with its
// reflectance, batch by batch), a variant that cannot be built, and the resume.

#include "analysis/studies/sweep.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "analysis/ghosts/ghost_tracer.h"
#include "analysis/runs/stray_light_run.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "tests/text_checks.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_spec.h"

namespace veil {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

std::string errorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const std::exception& e) {
        return e.what();
    }
    return "no error";
}

TEST(Sweep, ValuesAreListsAndRangesWithoutFloatNoise) {
    EXPECT_THAT(parseSweepValues("0.001,0.01,0.3", "o"), ElementsAre("0.001", "0.01", "0.3"));
    EXPECT_THAT(parseSweepValues("ar,none", "o"), ElementsAre("ar", "none"));
    EXPECT_EQ(parseSweepValues("10:60:5", "o").size(), 11u);
    EXPECT_THAT(parseSweepValues("0.1:0.5:0.1", "o"),
                ElementsAre("0.1", "0.2", "0.3", "0.4", "0.5"));
    EXPECT_THAT(parseSweepValues("5:1:-2", "o"), ElementsAre("5", "3", "1"));
    EXPECT_THAT(parseSweepValues("0.001:1:x10", "o"), ElementsAre("0.001", "0.01", "0.1", "1"));
    EXPECT_THAT(parseSweepValues("1:0.01:x10", "o"), ElementsAre("1", "0.1", "0.01"));
    EXPECT_THAT(errorOf([] { parseSweepValues("1:2:0", "--vary k=1:2:0"); }),
                HasSubstr("--vary k=1:2:0: the step of '1:2:0' is 0"));
    EXPECT_THAT(errorOf([] { parseSweepValues("1:2:-1", "o"); }), HasSubstr("moves away"));
    EXPECT_THAT(errorOf([] { parseSweepValues("0:1:x10", "o"); }), HasSubstr("positive ends"));
    EXPECT_THAT(errorOf([] { parseSweepValues("a:1:1", "o"); }), HasSubstr("must be numbers"));
    EXPECT_THAT(errorOf([] { parseSweepValues("0:1:1e-9", "o"); }),
                HasSubstr("more than 10000 values"));
    EXPECT_THAT(errorOf([] { parseSweepValues("1,,2", "o"); }), HasSubstr("an empty value"));
    EXPECT_THAT(errorOf([] { parseSweepAxis("novalues"); }), HasSubstr("expected KEY=VALUES"));
}

TEST(Sweep, GridAndZipVariants) {
    SweepSpec spec;
    spec.axes = {parseSweepAxis("a=1,2"), parseSweepAxis("b=x,y,z")};
    const auto grid = sweepVariants(spec);
    ASSERT_EQ(grid.size(), 6u);
    EXPECT_THAT(grid[0], ElementsAre("1", "x"));
    EXPECT_THAT(grid[1], ElementsAre("1", "y"));  // the last axis fastest
    EXPECT_THAT(grid[5], ElementsAre("2", "z"));
    spec.zip = true;
    EXPECT_THAT(errorOf([&] { sweepVariants(spec); }),
                HasSubstr("--vary b=x,y,z: --zip pairs the values of every --vary: this one has "
                          "3, the first 2"));
    spec.axes[1] = parseSweepAxis("b=x,y");
    EXPECT_THAT(sweepVariants(spec), ElementsAre(ElementsAre("1", "x"), ElementsAre("2", "y")));
}

// A singlet in its mechanics with a 5 % Lambertian mount finish and ideal antireflection
// faces, lit on axis: for the resume and the variants that cannot be built.
std::filesystem::path writeScene(const std::filesystem::path& dir) {
    std::filesystem::create_directories(dir);
    const std::filesystem::path scene = dir / "scene.toml";
    std::ofstream(scene) << "lens = \"" VEIL_SOURCE_DIR "/examples/lenses/singlet.toml\"\n"
                         << R"(
[mechanics]
property = "mount"

[properties.mount]
scatter = { model = "lambertian", reflectance = 0.05 }

[[assign]]
objects = ["L1.front", "L1.back"]
property = "ideal_ar"

[[source]]
name = "beam"
kind = "collimated"
field_deg = [0.0, 0.0]
)";
    return scene;
}

// The Sun 7 degrees off axis in the 6-lens lens: light that scatters once, at a mount (not
// the stop's edge, whose finish is its own), carries exactly the mounts' reflectance. In
// random mode a ray's path does not depend on that reflectance (a mount has one channel;
// the choices elsewhere do not see it), so with common random numbers every batch's flux
// scales with it exactly, and so does the change against the first variant.
TEST(Sweep, MountStrayLightScalesWithItsReflectanceBatchByBatch) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "veil_sweep_linear";
    std::filesystem::remove_all(dir);
    SweepSpec spec;
    spec.scene = VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml";
    spec.axes = {
        parseSweepAxis("properties.black_anodized.scatter.reflectance=0.01,0.02,0.04,0.08,0.16")};
    spec.raysPerSource = 160000;
    spec.batches = 8;
    spec.transport.mode = TransportOptions::Mode::Random;
    spec.transport.minRelativeFlux = 1e-12;
    spec.where = {"scatter{1} and scatter(barrel|retainer*|spacer*|stop)"};
    spec.folder = dir / "out";
    const SweepResult r = runSweep(spec, GlassCatalog::builtIn());
    ASSERT_EQ(r.variants.size(), 5u);
    ASSERT_EQ(r.quantities.size(), 3u);  // the total, where1, rest
    const double base = r.variants[0].measured[1].value;
    ASSERT_GT(base, 0.0);
    EXPECT_LT(r.variants[0].measured[1].error, 0.3 * base);  // the light is resolved
    for (const SweepVariant& v : r.variants) {
        EXPECT_TRUE(v.error.empty()) << v.error;
        const double ratio = std::stod(v.values[0]) / 0.01;
        for (size_t b = 0; b < v.batchValues[1].size(); ++b)
            EXPECT_NEAR(v.batchValues[1][b], ratio * r.variants[0].batchValues[1][b],
                        1e-9 * ratio * base);
        EXPECT_NEAR(v.measured[1].change, (ratio - 1.0) * base, 1e-9 * ratio * base);
        EXPECT_EQ(v.geometryReused, v.index > 0);  // property-only: one geometry
    }
    std::cout << "[ measured ] one-mount-scatter flux at 1 %: " << base << " +- "
              << r.variants[0].measured[1].error << " W\n";
    std::filesystem::remove_all(dir);
}

TEST(Sweep, AVariantThatCannotBeBuiltIsARowAndTheRerunResumes) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "veil_sweep_resume";
    std::filesystem::remove_all(dir);
    SweepSpec spec;
    spec.scene = writeScene(dir);
    // The lens's front radius: 59.26 mm is the design; 3 mm cannot hold its 11.9 mm rim.
    spec.axes = {parseSweepAxis("system.surfaces[2].r=59.26,3,80")};
    spec.raysPerSource = 400;
    spec.batches = 4;
    spec.folder = dir / "out";
    const SweepResult first = runSweep(spec, GlassCatalog::builtIn());
    ASSERT_EQ(first.variants.size(), 3u);
    EXPECT_TRUE(first.variants[0].error.empty()) << first.variants[0].error;
    EXPECT_FALSE(first.variants[1].error.empty());
    EXPECT_TRUE(first.variants[1].measured.empty());
    EXPECT_TRUE(first.variants[2].error.empty()) << first.variants[2].error;
    EXPECT_FALSE(first.variants[2].geometryReused);  // a lens edit rebuilds the geometry
    for (const SweepVariant& v : first.variants) EXPECT_FALSE(v.resumed);
    const auto files = writeSweep(first, spec.folder);
    EXPECT_EQ(files.size(), 5u);
    for (const auto& f : files) {
        EXPECT_TRUE(std::filesystem::exists(f)) << f;
        // The failed variant's numbers are empty or "-", never inf or nan.
        std::ifstream in(f);
        const std::string text((std::istreambuf_iterator<char>(in)),
                               std::istreambuf_iterator<char>());
        EXPECT_FALSE(veil_test::hasNonFinite(text)) << f;
    }

    // The rerun reads every variant back, failures included, with the same numbers.
    const SweepResult again = runSweep(spec, GlassCatalog::builtIn());
    for (size_t k = 0; k < 3; ++k) {
        EXPECT_TRUE(again.variants[k].resumed);
        EXPECT_EQ(again.variants[k].error, first.variants[k].error);
        EXPECT_EQ(again.variants[k].batchValues, first.variants[k].batchValues);
    }
    // Another ray count is another measurement: nothing is read back.
    spec.raysPerSource = 800;
    const SweepResult other = runSweep(spec, GlassCatalog::builtIn());
    for (const SweepVariant& v : other.variants) EXPECT_FALSE(v.resumed);
    std::filesystem::remove_all(dir);
}

// A baffle in the collimated beam in front of the singlet: the flux through it goes with its
// aperture's area, r^2 (the mesh's inscribed polygon has the same shape at every radius,
// since every part shares one segment count), whatever the beam's own size and the lens's
// transmittance. Every radius rebuilds the mechanics.
TEST(Sweep, ABaffleInTheBeamPassesTheShareItsApertureAreaPredicts) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "veil_sweep_baffle";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::filesystem::path scene = dir / "scene.toml";
    std::ofstream(scene) << "lens = \"" VEIL_SOURCE_DIR "/examples/lenses/singlet.toml\"\n"
                         << R"(
[mechanics]
property = "absorber"

[[mechanics.baffles]]
z_mm = -5.0
inner_radius_mm = 9.0

[[assign]]
objects = ["L1.front", "L1.back"]
property = "ideal_ar"

[[source]]
name = "beam"
kind = "collimated"
field_deg = [0.0, 0.0]
)";
    SweepSpec spec;
    spec.scene = scene;
    spec.axes = {parseSweepAxis("mechanics.baffles[1].inner_radius_mm=9,7,5,3")};
    spec.raysPerSource = 40000;
    spec.batches = 8;
    spec.folder = dir / "out";
    const SweepResult r = runSweep(spec, GlassCatalog::builtIn());
    ASSERT_EQ(r.variants.size(), 4u);
    const SweepValue& open = r.variants[0].measured[0];
    ASSERT_GT(open.value, 0.3);  // most of the beam passes 9 mm
    for (const SweepVariant& v : r.variants) {
        ASSERT_TRUE(v.error.empty()) << v.error;
        EXPECT_FALSE(v.geometryReused);
        const double share = std::pow(std::stod(v.values[0]) / 9.0, 2);
        const SweepValue& m = v.measured[0];
        const double sigma = std::hypot(m.error, share * open.error);
        EXPECT_LT(std::abs(m.value - share * open.value), 4.0 * sigma + 1e-12)
            << "r = " << v.values[0] << ": " << m.value << " +- " << m.error << ", expected "
            << share * open.value;
        EXPECT_LE(m.value, open.value * (1.0 + 1e-12));  // nested apertures, the same rays
    }
    std::filesystem::remove_all(dir);
}

TEST(Sweep, AKeyThatNamesNothingStopsTheSweepBeforeAnyTrace) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "veil_sweep_key";
    std::filesystem::remove_all(dir);
    SweepSpec spec;
    spec.scene = writeScene(dir);
    spec.axes = {parseSweepAxis("properties.mount.scatter.reflectance=0.1"),
                 parseSweepAxis("properties.mont.scatter.reflectance=0.1")};
    spec.raysPerSource = 100;
    spec.folder = dir / "out";
    EXPECT_THAT(errorOf([&] { runSweep(spec, GlassCatalog::builtIn()); }),
                HasSubstr("--vary properties.mont.scatter.reflectance=0.1: no 'mont' in "
                          "[properties]"));
    EXPECT_FALSE(std::filesystem::exists(dir / "out" / "variants"));
    spec.axes = {parseSweepAxis("properties.mount.scatter.reflectance=0.1"),
                 parseSweepAxis("properties.mount.scatter.reflectance=0.2")};
    EXPECT_THAT(errorOf([&] { runSweep(spec, GlassCatalog::builtIn()); }),
                HasSubstr("properties.mount.scatter.reflectance is varied twice"));
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// --measure render: every pass draws the same random numbers in every variant (the aperture
// guide is off), so light that scatters once, on a mount, follows the mounts' reflectance
// pass by pass: the passes' differences value1 - 3 value0 scatter about 0, and less than the
// values themselves.
TEST(SweepRender, OneMountScatterFollowsTheReflectanceWithCommonRandomNumbers) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "veil_sweep_render";
    std::filesystem::remove_all(dir);
    SweepSpec spec;
    spec.scene = VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml";
    spec.axes = {parseSweepAxis("properties.black_anodized.scatter.reflectance=0.01,0.03")};
    spec.measure = SweepMeasure::Render;
    spec.batches = 4;
    spec.render.photonsPerPass = 4000;
    spec.render.ghostPhotonsPerPass = 1000;
    spec.render.raysPerPixel = 1;
    spec.where = {"scatter{1} and scatter(barrel|retainer*|spacer*|stop)"};
    spec.folder = dir / "out";
    const SweepResult r = runSweep(spec, GlassCatalog::builtIn());
    ASSERT_EQ(r.measure, "render");
    ASSERT_EQ(r.variants.size(), 2u);
    ASSERT_TRUE(r.variants[0].error.empty()) << r.variants[0].error;
    ASSERT_TRUE(r.variants[1].error.empty()) << r.variants[1].error;
    // The total, the four components and the criterion.
    ASSERT_EQ(r.quantities.size(), 6u);
    EXPECT_EQ(r.quantities[0], "sensor_image: render");
    EXPECT_EQ(r.quantities[5], "sensor_image: where1");
    const auto& a = r.variants[0].batchValues[5];
    const auto& b = r.variants[1].batchValues[5];
    ASSERT_EQ(a.size(), 4u);
    std::vector<double> d;
    for (size_t k = 0; k < a.size(); ++k) d.push_back(b[k] - 3.0 * a[k]);
    const BatchMean m = batchMean(d);
    const double value = r.variants[0].measured[5].value;
    ASSERT_GT(value, 0.0);
    EXPECT_LT(std::abs(m.value), 4.0 * m.error + 1e-12) << m.value << " +- " << m.error;
    // Common random numbers: the difference is resolved better than the value it is taken
    // from (0.12 of its error here; independent passes would give 1; 0.70 to 0.84 when
    // the small lit parts' points were split by their light, which the variants change).
    EXPECT_LT(m.error, 0.5 * r.variants[0].measured[5].error * 3.0);
    // The sun's visible ghosts do not see the mounts.
    EXPECT_NEAR(r.variants[1].measured[1].value, r.variants[0].measured[1].value,
                4.0 * r.variants[1].measured[1].changeError + 1e-12);
    std::filesystem::remove_all(dir);
}

// --measure ghosts: each variant's sequential estimate, exactly what veil ghosts computes for
// that variant's scene, with no error.
TEST(SweepGhosts, EachVariantIsTheSequentialEstimateOfItsScene) {
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "veil_sweep_ghosts";
    std::filesystem::remove_all(dir);
    SweepSpec spec;
    spec.scene = writeScene(dir);
    spec.axes = {parseSweepAxis("assign[1].property=ideal_ar,uncoated")};
    spec.measure = SweepMeasure::Ghosts;
    spec.folder = dir / "out";
    const SweepResult r = runSweep(spec, GlassCatalog::builtIn());
    ASSERT_EQ(r.quantities.size(), 3u);
    EXPECT_EQ(r.batches, 1);
    for (const SweepVariant& v : r.variants) {
        ASSERT_TRUE(v.error.empty()) << v.error;
        SceneSpec file = readSceneFile(spec.scene, GlassCatalog::builtIn(),
                                       {{"assign[1].property", v.values[0], "test"}});
        const auto prepared = PreparedScene::build(std::move(file), GlassCatalog::builtIn());
        const GhostAnalysis a =
            GhostTracer(prepared->geometry(), prepared->transport(), GlassCatalog::builtIn())
                .analyse();
        double all = 0.0;
        for (const GhostEstimate& g : a.ghosts) all += g.flux();
        EXPECT_EQ(v.measured[0].value, a.nominal.flux());
        EXPECT_EQ(v.measured[1].value, all);
        EXPECT_EQ(v.measured[2].value, a.ghosts.front().flux());
        for (const SweepValue& m : v.measured) EXPECT_EQ(m.error, 0.0);
    }
    // Uncoated faces reflect far more than ideal antireflection ones.
    EXPECT_GT(r.variants[1].measured[1].value, 10.0 * r.variants[0].measured[1].value);
    // Criteria split traced light only.
    spec.where = {"scatter"};
    EXPECT_THROW(runSweep(spec, GlassCatalog::builtIn()), ParseError);
    std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace veil
