// The veiling glare index against independent truth: a lens with nothing that reflects or
// scatters has none at all; an uncoated singlet's ghost glare (its one two-reflection ghost)
// against a forward Monte Carlo trace of the same bright field, split by path criterion, on
// a wider detector, and against the sequential ghost analysis walked backward from the
// spot's image; the bench's geometry (the spot's image where the chief ray lands, the
// field reaching the image only through the lens) and its errors.

#include "analysis/studies/glare.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>

#include "analysis/runs/stray_light_run.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_spec.h"

namespace veil {
namespace {

namespace fs = std::filesystem;

// A singlet scene: its faces as given, its butt end and flats absorbing.
SceneSpec singlet(const std::string& name, const std::string& faces) {
    const fs::path path = fs::path(::testing::TempDir()) / ("veil_glare_" + name + ".toml");
    FILE* f = fopen(path.c_str(), "w");
    EXPECT_TRUE(f);
    fprintf(f,
            "lens = \"%s/examples/lenses/singlet.toml\"\n"
            "[[assign]]\nobjects = [\"L1.edge\", \"L1.flat*\"]\nproperty = \"absorber\"\n"
            "[[assign]]\nobjects = [\"L1.front\", \"L1.back\"]\nproperty = \"%s\"\n",
            VEIL_SOURCE_DIR, faces.c_str());
    fclose(f);
    return readSceneFile(path, GlassCatalog::builtIn());
}

// The axis position's spot image radius.
double f0SpotRadius(const GlareResult& r) { return r.fields.at(0).spotImageRadiusMm; }

GlareSpec quick() {
    GlareSpec spec;
    spec.passes = 6;
    spec.render.photonsPerPass = 10000;
    spec.render.raysPerPixel = 64;
    spec.fieldsDeg = {Vec2(0.0), Vec2(0.0, 4.0)};
    return spec;
}

TEST(Glare, PerfectLensHasNone) {
    // Ideal AR faces and black edges: no light reaches the black spot's image but the spot's
    // own, which it does not emit. Exactly zero, on axis and off it.
    const GlareResult r =
        runGlare(singlet("perfect", "ideal_ar"), GlassCatalog::builtIn(), quick());
    ASSERT_EQ(r.fields.size(), 2u);
    for (const GlareField& f : r.fields) {
        EXPECT_EQ(f.black.value, 0.0) << f.fieldDeg;
        EXPECT_EQ(f.vgi.value, 0.0) << f.fieldDeg;
        EXPECT_GT(f.white.value, 0.0) << f.fieldDeg;
        EXPECT_GT(f.white.error, 0.0) << f.fieldDeg;
        EXPECT_EQ(f.ghostPrediction, 0.0) << f.fieldDeg;  // ideal AR: no ghost at all
    }
    // The point source's light all lands in its image, well inside the spot's: the GSF is 0
    // past it, and so are the VGIs recomputed from it and rendered for the disc's field.
    ASSERT_TRUE(r.fields[0].spread.has_value());
    EXPECT_FALSE(r.fields[1].spread.has_value());  // off axis: only with GlareSpreadAt::All
    const GlareSpread& g = *r.fields[0].spread;
    EXPECT_GT(g.discFlux.value, 0.0);
    EXPECT_EQ(g.vgi.value, 0.0);
    EXPECT_NEAR(g.fieldDeg, 5.0, 1e-6);  // the singlet's largest field
    EXPECT_EQ(g.directVgi.value, 0.0);
    for (size_t a = 0; a < g.total.size(); ++a) {
        if (g.edgesMm[a] >= f0SpotRadius(r)) {
            EXPECT_EQ(g.total[a].value, 0.0) << g.edgesMm[a];
        }
    }
}

// Scatter at the stop spreads a point source's light the same way about its image wherever
// the image is (to first order in the field angle): the isoplanatic case, where ISO 9358's
// VGI from the GSF is the VGI. A singlet with ideal AR faces whose front face (1 mm behind
// the stop) scatters by an ABg BTDF (A 5e-4, B 1e-3, g 2; TIS about 1 %):
//   - the GSF's diffuse part follows the BTDF: a ray scattered by delta beta in the glass
//     leaves the flat-ish back face n delta beta off the image ray and lands
//     d = 96.71 + 4 / n mm further on (the image distance plus the glass's reduced
//     thickness), so at distance r from the image, with solid angle n^2 larger in air,
//         GSF(r) = BTDF(r / (n d)) / (n^2 d^2),   BTDF(x) = A / (B + x^2);
//   - the VGI recomputed from the GSF is the VGI rendered for a bright field out to the
//     disc's field angle (5 degrees).
TEST(Glare, SpreadOfScatterAtTheStopIsIsoplanatic) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const fs::path path = fs::path(::testing::TempDir()) / "veil_glare_rough.toml";
    FILE* f = fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    fprintf(f,
            "lens = \"%s/examples/lenses/singlet.toml\"\n"
            "[properties.rough_ar]\nspecular = \"ideal_ar\"\n"
            "scatter = { model = \"abg\", btdf = { a = 5e-4, b = 1e-3, g = 2 } }\n"
            "[[assign]]\nobjects = [\"L1.edge\", \"L1.flat*\"]\nproperty = \"absorber\"\n"
            "[[assign]]\nobjects = [\"L1.back\"]\nproperty = \"ideal_ar\"\n"
            "[[assign]]\nobjects = [\"L1.front\"]\nproperty = \"rough_ar\"\n",
            VEIL_SOURCE_DIR);
    fclose(f);
    GlareSpec spec = quick();
    spec.fieldsDeg = {Vec2(0.0)};
    const GlareResult r = runGlare(readSceneFile(path, catalog), catalog, spec);
    ASSERT_EQ(r.fields.size(), 1u);
    ASSERT_TRUE(r.fields[0].spread.has_value());
    const GlareSpread& g = *r.fields[0].spread;

    const double n = 1.5168, d = 96.71 + 4.0 / n;  // N-BK7 at the d line
    double worst = 0.0;
    for (const double rMm : {0.5, 1.0, 2.0, 4.0, 8.0}) {
        size_t a = 0;
        while (g.edgesMm[a + 1] <= rMm) ++a;
        const double at = spreadRadius(g.edgesMm[a], g.edgesMm[a + 1]);
        const double x = at / (n * d);
        const double expected = 5e-4 / (1e-3 + x * x) / (n * n * d * d);
        const GlareValue& v = g.diffuse[a];
        std::cout << "[ GSF      ] r " << at << " mm: " << v.value << " +- " << v.error << ", ABg "
                  << expected << "\n";
        EXPECT_NEAR(v.value, expected, 4.0 * v.error + 0.05 * expected) << at;
        EXPECT_LT(v.error, 0.05 * v.value);   // the check has teeth
        EXPECT_EQ(g.specular[a].value, 0.0);  // ideal AR: no ghost
        worst = std::max(worst, std::abs(v.value / expected - 1.0));
    }
    std::cout << "[ GSF      ] worst ABg deviation " << worst << "\n";

    ASSERT_NEAR(g.fieldDeg, 5.0, 1e-6);
    std::cout << "[ GSF      ] VGI from the GSF " << g.vgi.value << " +- " << g.vgi.error
              << ", rendered for the disc's field " << g.directVgi.value << " +- "
              << g.directVgi.error << "\n";
    EXPECT_GT(g.vgi.value, 1e-3);
    EXPECT_NEAR(g.vgi.value, g.directVgi.value,
                4.0 * std::hypot(g.vgi.error, g.directVgi.error) + 0.03 * g.directVgi.value);
    EXPECT_LT(g.directVgi.error, 0.05 * g.directVgi.value);
}

TEST(Glare, UncoatedSingletGhostMatchesForwardMonteCarlo) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec file = singlet("uncoated", "uncoated");
    const GlareSpec spec = quick();
    const GlareResult r = runGlare(file, catalog, spec);
    const GlareField& axis = r.fields.at(0);
    // Nothing scatters: all of it is specular.
    EXPECT_EQ(axis.diffuse.value, 0.0);
    EXPECT_GT(axis.specular.value, 0.0);
    EXPECT_DOUBLE_EQ(axis.vgi.value, axis.specular.value);

    // The same bright field (no spot: the spot's own ghost is a fraction of a percent of
    // it) traced forward onto a 2 mm square, its flux split into the one ghost and the image;
    // the ghost's light is smooth over millimetres, so their ratio is the ghost VGI.
    const GlareBench bench(file, catalog, spec);
    const std::unique_ptr<PreparedScene> p =
        PreparedScene::build(bench.scene(bench.locate(Vec2(0.0)), false, 2.0, 4), catalog);
    StrayLightSpec mc;
    mc.raysPerSource = 4000000;
    mc.transport.seed = 7;
    mc.where = {"seq(fresnel(L1.back), fresnel(L1.front)) and fresnel{2} and detector(glare)",
                "not fresnel and detector(glare)"};
    const std::vector<StrayLightRow> rows = runStrayLight(*p, mc).report();
    ASSERT_EQ(rows.size(), 4u);  // total, where1, where2, rest
    const double ghost = rows[1].flux, image = rows[2].flux;
    const double mcRatio = ghost / image;
    const double mcError = mcRatio * std::hypot(rows[1].relativeError, rows[2].relativeError);
    const double z = (axis.specular.value - mcRatio) / std::hypot(axis.specular.error, mcError);
    std::cout << "[ VGI      ] uncoated singlet ghost: glare " << axis.specular.value << " +- "
              << axis.specular.error << ", forward Monte Carlo " << mcRatio << " +- " << mcError
              << " (z " << z << ")\n";
    EXPECT_LT(std::abs(z), 4.0);
    EXPECT_LT(mcError, 0.2 * mcRatio);  // the check has teeth

    // The ghost analysis: the one ghost walked backward sequentially from the spot's image
    // centre predicts the render's specular part (within its error and the backward grid's
    // quadrature, 1 %), and the image through the nominal path the bright field's
    // irradiance less the ghost light in it.
    // Over the 5 degree disc the ghost of a point source is a uniform patch far wider than the
    // disc, and the same for every source in it: isoplanatic, so the VGI recomputed from the
    // GSF is the one rendered for that field.
    ASSERT_TRUE(axis.spread.has_value());
    const GlareSpread& g = *axis.spread;
    std::cout << "[ GSF      ] uncoated singlet: VGI from the GSF " << g.vgi.value << " +- "
              << g.vgi.error << ", rendered for the disc's field " << g.directVgi.value << " +- "
              << g.directVgi.error << "\n";
    EXPECT_EQ(g.vgiDiffuse.value, 0.0);
    EXPECT_GT(g.vgi.value, 0.0);
    EXPECT_NEAR(g.vgi.value, g.directVgi.value,
                4.0 * std::hypot(g.vgi.error, g.directVgi.error) + 0.03 * g.directVgi.value);

    for (const GlareField& f : r.fields) {
        ASSERT_EQ(f.ghosts.size(), 1u);
        EXPECT_EQ(f.ghosts[0].label, "L1.back > L1.front");
        std::cout << "[ VGI      ] field " << f.fieldDeg << ": render " << f.specular.value
                  << " +- " << f.specular.error << ", ghost analysis " << f.ghostPrediction
                  << ", image " << f.imagePrediction << "\n";
        EXPECT_NEAR(f.ghostPrediction, f.specular.value,
                    4.0 * f.specular.error + 0.01 * f.specular.value);
        EXPECT_NEAR(f.imagePrediction, 1.0 - f.specular.value,
                    4.0 * f.white.error / f.white.value + 0.01);
    }
}

TEST(Glare, BenchPlacesTheSpotWhereTheChiefRayLands) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    GlareSpec spec = quick();
    const GlareBench bench(singlet("bench", "uncoated"), catalog, spec);
    const GlareField axis = bench.locate(Vec2(0.0));
    EXPECT_NEAR(axis.imageMm.x, 0.0, 1e-9);
    EXPECT_NEAR(axis.imageMm.y, 0.0, 1e-9);
    // f = 100 mm: the 0.5 deg spot's image is about 100 tan(0.25 deg) in radius.
    EXPECT_NEAR(axis.spotImageRadiusMm, 100.0 * std::tan(0.25 * M_PI / 180.0), 0.02);
    EXPECT_NEAR(axis.measuredSideMm, 0.5 * axis.spotImageRadiusMm, 1e-12);
    const GlareField off = bench.locate(Vec2(0.0, 4.0));
    EXPECT_NEAR(off.imageMm.y, 100.0 * std::tan(4.0 * M_PI / 180.0), 0.2);
    // A spot past the bright field, and a spot the lens does not image.
    EXPECT_THROW(bench.locate(Vec2(0.0, 79.9)), ModelError);
    spec.spotDiameterDeg = 30.0;
    EXPECT_THROW(GlareBench(singlet("bench2", "uncoated"), catalog, spec), ModelError);
}

// Apertures: stopping the double Gauss down from f/2 to f/4 quarters the bright field's
// image irradiance on axis (the stop's area); a scene without a stop plate, or an F-number
// faster than the lens's, is refused before anything is rendered.
TEST(Glare, StoppingDownScalesTheImageIrradiance) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec dg =
        readSceneFile(VEIL_SOURCE_DIR "/examples/scenes/double_gauss_50mm_painted.toml", catalog);
    GlareSpec spec;
    spec.passes = 3;
    spec.render.photonsPerPass = 10000;
    spec.render.raysPerPixel = 32;
    spec.fieldsDeg = {Vec2(0.0)};
    spec.fNumbers = {2.0, 4.0};
    spec.spread = GlareSpreadAt::None;
    const GlareResult r = runGlare(dg, catalog, spec);
    ASSERT_EQ(r.fields.size(), 2u);
    EXPECT_EQ(r.fields[0].fNumber, 2.0);
    EXPECT_EQ(r.fields[1].fNumber, 4.0);
    // The parts add up: ghosts (among them the TIR ghosts), image blur and scatter.
    for (const GlareField& f : r.fields)
        EXPECT_NEAR(f.vgi.value, f.specular.value + f.blur.value + f.diffuse.value,
                    1e-12 * f.vgi.value);
    const GlareValue q = ratio(r.fields[1].white, r.fields[0].white);
    std::cout << "[ VGI      ] white f/4 over f/2: " << q.value << " +- " << q.error << "\n";
    EXPECT_NEAR(q.value, 0.25, 4.0 * q.error + 0.005);
    spec.fNumbers = {1.4};
    EXPECT_THROW(runGlare(dg, catalog, spec), ModelError);
    spec.fNumbers = {8.0};
    EXPECT_THROW(runGlare(singlet("nostop", "uncoated"), catalog, spec), ModelError);
}

// The double Gauss on axis: its ghost light that the sequential ghost analysis does not walk
// is total internal reflection's. Light of the 80 degree field meets a steep face from inside
// the glass beyond the critical angle; with one Fresnel reflection it reaches the image. Take
// those ghosts (path criterion `tir and fresnel`) out of the render's specular part and the
// two-Fresnel-reflection ghosts agree with the ghost analysis.
TEST(Glare, TotalInternalReflectionGhostsAreTheRest) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec dg =
        readSceneFile(VEIL_SOURCE_DIR "/examples/scenes/double_gauss_50mm_painted.toml", catalog);
    GlareSpec spec;  // veil glare's defaults
    spec.render.raysPerPixel = 64;
    spec.fieldsDeg = {Vec2(0.0)};
    spec.spread = GlareSpreadAt::None;
    const GlareResult r = runGlare(dg, catalog, spec);
    const GlareField& f = r.fields.at(0);
    const double fresnel = f.specular.value - f.tir.value;
    std::cout << "[ VGI      ] double Gauss on axis: ghosts " << f.specular.value << " +- "
              << f.specular.error << ", via TIR " << f.tir.value << " +- " << f.tir.error
              << ", two Fresnel reflections " << fresnel << ", ghost analysis " << f.ghostPrediction
              << "\n";
    EXPECT_GT(f.tir.value, 0.1 * f.specular.value);  // a tenth of the ghost light and more
    EXPECT_GT(f.tir.value, 10.0 * f.tir.error);
    EXPECT_NEAR(fresnel, f.ghostPrediction,
                4.0 * std::hypot(f.specular.error, f.tir.error) + 0.03 * f.ghostPrediction);
    // Without the TIR ghosts the two would be 14 % apart.
    EXPECT_GT(f.specular.value, 1.1 * f.ghostPrediction);
    EXPECT_EQ(f.blur.value, 0.0);  // the lens's blur stays inside the spot's image on axis
}

}  // namespace
}  // namespace veil
