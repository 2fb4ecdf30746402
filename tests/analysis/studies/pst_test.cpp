// Point source transmittance (analysis/studies/pst.h) against independent truth: a bare singlet on
// axis transmits what Fresnel's equations leave of the beam, and outside its field no
// refracted light reaches the detector.

#include "analysis/studies/pst.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "lensdata/glass_catalog.h"

namespace veil {
namespace {

// The uncoated singlet with its mechanics (the stop plate makes its entrance pupil real:
// without it, light outside the stop's 10 mm would pass to the 10.5 mm lens).
TEST(Pst, BareLensOnAxisTransmitsWhatFresnelLeaves) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "veil_pst";
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "scene.toml")
        << "lens = \"" VEIL_SOURCE_DIR "/examples/lenses/singlet.toml\"\n[mechanics]\n";
    PstSpec spec;
    spec.scene = dir / "scene.toml";
    spec.anglesDeg = {0.0, 30.0};
    spec.raysPerAngle = 20000;
    spec.batches = 8;
    const PstResult r = runPst(spec, catalog);
    ASSERT_EQ(r.rows.size(), 2u);
    ASSERT_EQ(r.quantities[1].name, "nominal");
    ASSERT_EQ(r.quantities[2].name, "stray");
    EXPECT_DOUBLE_EQ(r.fieldDeg, 5.0);

    // Two uncoated N-BK7 faces at near-normal incidence (the marginal ray meets them at 10
    // degrees at most, where R changes by 1 % of itself), 4 mm of glass, averaged over the
    // three wavelengths: the nominal image's share.
    const Glass* bk7 = catalog.find("N-BK7");
    ASSERT_NE(bk7, nullptr);
    double expected = 0.0;
    for (double nm : {486.1327, 587.5618, 656.2725}) {
        const double n = bk7->index(nm);
        const double rf = std::pow((n - 1.0) / (n + 1.0), 2);
        expected += (1.0 - rf) * (1.0 - rf) * bk7->internalTransmittance(nm, 4.0).value() / 3.0;
    }
    const PstRow& axis = r.rows[0];
    EXPECT_TRUE(axis.inField);
    // Within the Monte Carlo error (which rays of the beam pass the stop's 10 mm) and 0.3 %
    // for the stop's polygon (chord tolerance 0.01 mm) and the angles of incidence.
    EXPECT_NEAR(axis.pst[1], expected, 4.0 * axis.error[1] + 0.003 * expected)
        << "nominal " << axis.pst[1] << " +- " << axis.error[1];
    // The rest of what arrives is ghost light (two reflections), a fraction of a percent.
    EXPECT_GT(axis.pst[2], 0.0);
    EXPECT_LT(axis.pst[2], 0.01);
    EXPECT_NEAR(axis.pst[0], axis.pst[1] + axis.pst[2], 1e-12);
    // The sequential estimate of the two-reflection ghosts is that stray light: the Monte
    // Carlo's also holds the four-reflection ghosts (R^2 ~ 0.2 % of it).
    ASSERT_EQ(r.quantities[3].name, "ghost_estimate");
    EXPECT_EQ(axis.error[3], 0.0);
    EXPECT_NEAR(axis.pst[3], axis.pst[2], 4.0 * axis.error[2] + 0.01 * axis.pst[3])
        << "estimate " << axis.pst[3] << ", Monte Carlo " << axis.pst[2] << " +- " << axis.error[2];

    // 30 degrees, six times the field: the image misses the detector.
    const PstRow& off = r.rows[1];
    EXPECT_FALSE(off.inField);
    EXPECT_EQ(off.pst[1], 0.0);
    EXPECT_LT(off.pst[0], 1e-3 * axis.pst[0]);
    std::filesystem::remove_all(dir);
}

// The same lens rendered (mounts of 1 % Lambertian, so there is scatter to render): on axis
// the specular light is the nominal image and its ghosts, what Fresnel leaves of the beam.
TEST(Pst, RenderedBareLensOnAxisTransmitsWhatFresnelLeaves) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const std::filesystem::path dir = std::filesystem::temp_directory_path() / "veil_pst_render";
    std::filesystem::create_directories(dir);
    std::ofstream(dir / "scene.toml")
        << "lens = \"" VEIL_SOURCE_DIR "/examples/lenses/singlet.toml\"\n"
        << "[mechanics]\nproperty = \"mount\"\n[properties.mount]\n"
        << "scatter = { model = \"lambertian\", reflectance = 0.01 }\n";
    PstSpec spec;
    spec.scene = dir / "scene.toml";
    spec.anglesDeg = {0.0};
    spec.render = true;
    spec.renderOptions.photonsPerPass = 20000;
    spec.renderOptions.ghostPhotonsPerPass = 20000;
    spec.renderOptions.raysPerPixel = 2;
    spec.batches = 4;
    const PstResult r = runPst(spec, catalog);
    ASSERT_EQ(r.measure, "render");
    ASSERT_EQ(r.quantities[1].name, "specular");
    ASSERT_EQ(r.quantities[2].name, "scattered");
    const Glass* bk7 = catalog.find("N-BK7");
    double nominal = 0.0;
    for (double nm : {486.1327, 587.5618, 656.2725}) {
        const double n = bk7->index(nm);
        const double rf = std::pow((n - 1.0) / (n + 1.0), 2);
        nominal += (1.0 - rf) * (1.0 - rf) * bk7->internalTransmittance(nm, 4.0).value() / 3.0;
    }
    const PstRow& axis = r.rows[0];
    const double expected = nominal + axis.pst[3];  // the image and its ghosts
    EXPECT_NEAR(axis.pst[1], expected, 4.0 * axis.error[1] + 0.005 * expected)
        << "specular " << axis.pst[1] << " +- " << axis.error[1];
    EXPECT_GT(axis.pst[2], 0.0);
    EXPECT_LT(axis.pst[2], 1e-2 * axis.pst[1]);  // 1 % mounts barely lit on axis
    EXPECT_NEAR(axis.pst[0], axis.pst[1] + axis.pst[2], 1e-12);
    std::filesystem::remove_all(dir);
}

TEST(Pst, BadAnglesStopBeforeAnyTrace) {
    PstSpec spec;
    spec.scene = VEIL_SOURCE_DIR "/examples/lenses/singlet.toml";
    spec.raysPerAngle = 100;
    spec.anglesDeg = {95.0};
    EXPECT_THROW(runPst(spec, GlassCatalog::builtIn()), ParseError);
    spec.anglesDeg = {};
    EXPECT_THROW(runPst(spec, GlassCatalog::builtIn()), ParseError);
}

}  // namespace
}  // namespace veil
