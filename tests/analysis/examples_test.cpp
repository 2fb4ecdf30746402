// The example lenses: each loads, traces, and has the first-order data its source gives.
// Published lenses are checked against the published numbers; lenses designed here against
// their design targets and an independent closed form where one exists.

#include <gtest/gtest.h>

#include <cmath>

#include "analysis/first_order.h"
#include "analysis/spot.h"
#include "lensdata/lens_file.h"

namespace veil {
namespace {

struct Loaded {
    Prescription prescription;
    SequentialModel model;
    FirstOrderReport firstOrder;
};

Loaded load(const std::string& name) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    Prescription p = readLensFile(VEIL_SOURCE_DIR "/examples/lenses/" + name, catalog);
    SequentialModel m = SequentialModel::build(p, catalog);
    FirstOrderReport fo = computeFirstOrder(m);
    return {std::move(p), std::move(m), std::move(fo)};
}

// RMS spot radius on axis at the primary wavelength (8 hexapolar rings, 217 rays), of which
// `vignetted` must be lost (a central hole) and no more.
double onAxisRmsUm(const Loaded& l, int vignetted = 0) {
    const RayAimer aimer(l.model, AimMode::Real);
    const SpotResult s = computeSpot(l.model, aimer, 0, l.model.primaryWavelength());
    EXPECT_EQ(s.raysLanded, s.raysTraced - vignetted) << "on-axis rays vignetted";
    return 1000.0 * s.rmsRadiusMm;
}

// Singlet: thick-lens lensmaker's equation with N-BK7's catalog nd = 1.51680.
TEST(Examples, SingletMatchesTheLensmakersEquation) {
    const Loaded l = load("singlet.toml");
    const double n = 1.51680, r1 = 59.26, r2 = -394.56, t = 4.0;
    const double f = 1.0 / ((n - 1.0) * (1.0 / r1 - 1.0 / r2 + (n - 1.0) * t / (n * r1 * r2)));
    const FirstOrderData& d = l.firstOrder.primaryData();
    EXPECT_NEAR(d.eflMm, f, 1e-5 * f);  // catalog nd is rounded to 1e-5
    EXPECT_NEAR(d.eflMm, 100.0, 0.05);
    EXPECT_NEAR(d.imageSpaceFNumber, 5.0, 1e-9);
}

// Cemented achromat: 100 mm, f/5. An N-BK7 singlet of the same power separates the F and C
// focal lengths by f / Vd = 100 / 64.17 = 1.56 mm; the doublet, optimized on real rays
// (which balances spherochromatism against paraxial colour), keeps them within 0.25 mm.
TEST(Examples, AchromatBringsFAndCTogether) {
    const Loaded l = load("achromat.toml");
    const auto& w = l.firstOrder.wavelengths;
    ASSERT_EQ(w.size(), 3u);
    EXPECT_NEAR(l.firstOrder.primaryData().eflMm, 100.0, 0.05);
    EXPECT_LT(std::abs(w[0].eflMm - w[2].eflMm), 0.25);
    EXPECT_EQ(l.prescription.elements().size(), 2u);
    EXPECT_LT(onAxisRmsUm(l), 10.0);
}

// Cooke triplet: W. J. Smith's worked example, EFL 101.181 and BFL 77.405, scaled by
// 0.494157 to EFL 50.00 mm and BFL 38.251 mm.
TEST(Examples, CookeTripletHasTheBooksFirstOrderData) {
    const Loaded l = load("cooke_triplet.toml");
    const FirstOrderData& d = l.firstOrder.primaryData();
    EXPECT_NEAR(d.eflMm, 101.181 * 0.494157, 0.01);
    EXPECT_NEAR(d.bflMm, 77.405 * 0.494157, 0.01);
    EXPECT_EQ(l.prescription.elements().size(), 3u);
    EXPECT_LT(onAxisRmsUm(l), 20.0);
}

// Double Gauss: US 2,673,491 at f = 1 with back focus 0.71436, scaled x50.
TEST(Examples, DoubleGaussHasThePatentsFirstOrderData) {
    const Loaded l = load("double_gauss_50mm.toml");
    const FirstOrderData& d = l.firstOrder.primaryData();
    EXPECT_NEAR(d.eflMm, 50.0, 0.02);  // radii published to 4 decimals of f = 1
    EXPECT_NEAR(d.bflMm, 0.71436 * 50.0, 0.01);
    EXPECT_NEAR(d.imageSpaceFNumber, 2.0, 1e-9);
    EXPECT_EQ(l.prescription.elements().size(), 6u);
    EXPECT_LT(onAxisRmsUm(l), 20.0);
}

// The seed paper's first system: 6 lenses, 360 mm, f/7, +-5 degree rectangular field; the
// fourth lens is a singlet in air (its front/back ghost is the paper's example).
TEST(Examples, LongFocusLensIsTheSeedsFirstSystem) {
    const Loaded l = load("longfocus_360mm.toml");
    const FirstOrderData& d = l.firstOrder.primaryData();
    EXPECT_NEAR(d.eflMm, 360.0, 0.1);
    EXPECT_NEAR(d.imageSpaceFNumber, 7.0, 1e-9);
    EXPECT_NEAR(d.entrancePupilDiameterMm, d.eflMm / 7.0, 1e-9);
    const auto elements = l.prescription.elements();
    ASSERT_EQ(elements.size(), 6u);
    const Element& l4 = elements[3];
    EXPECT_TRUE(l.prescription.surfaces[l4.frontSurface - 1].material.isAir());
    EXPECT_TRUE(l.prescription.surfaces[l4.backSurface].material.isAir());
    EXPECT_EQ(l.prescription.surfaces[l4.frontSurface].name, "L4.front");
    EXPECT_EQ(l.prescription.surfaces[l4.backSurface].name, "L4.back");
    EXPECT_TRUE(l.prescription.system.rectangularField);
    double maxX = 0.0, maxY = 0.0;
    for (const Field& f : l.prescription.system.fields) {
        maxX = std::max(maxX, f.x);
        maxY = std::max(maxY, f.y);
    }
    EXPECT_EQ(maxX, 5.0);
    EXPECT_EQ(maxY, 5.0);
    // Image height at 5 degrees: f tan(5 deg) within distortion of a few tenths of a percent.
    EXPECT_NEAR(d.paraxialImageHeightsMm[2], d.eflMm * std::tan(5.0 * M_PI / 180.0), 1e-6);
    EXPECT_LT(onAxisRmsUm(l), 10.0);
}

// The seed paper's second system: 2 lenses, 2 mirrors, 2000 mm, f/10, 1 deg 15' field.
TEST(Examples, CatadioptricIsTheSeedsSecondSystem) {
    const Loaded l = load("catadioptric_2000mm.toml");
    const FirstOrderData& d = l.firstOrder.primaryData();
    EXPECT_NEAR(d.eflMm, 2000.0, 1.0);
    EXPECT_NEAR(d.imageSpaceFNumber, 10.0, 1e-9);
    int mirrors = 0;
    for (const Surface& s : l.prescription.surfaces) mirrors += s.mirror ? 1 : 0;
    EXPECT_EQ(mirrors, 2);
    EXPECT_EQ(l.prescription.elements().size(), 2u);
    EXPECT_EQ(l.prescription.system.fields.back().y, 0.625);
    // After two reflections the light travels toward +z again.
    EXPECT_GT(l.model.index(l.model.imageIndex() - 1, 0), 0.0);
    // The primary's central hole passes the light from M2 to the field lens; on the way in it
    // vignettes the centre of the beam, as the secondary's shadow does in the real lens. On
    // axis a pupil ray at height h meets M1 at about 1.03 h (the meniscus diverges the beam a
    // little), so hexapolar rings 0 to 2 of 8 (h = 0, 12.5 and 25 mm on the 100 mm pupil
    // radius) fall inside the 29.2 mm hole and ring 3 (h = 37.5 mm) outside: the centre, 6
    // and 12 rays are lost.
    const Surface& m1 = l.prescription.surfaces[4];
    ASSERT_EQ(m1.name, "M1");
    EXPECT_EQ(m1.innerSemiDiameterMm, 29.2);
    EXPECT_LT(onAxisRmsUm(l, 1 + 6 + 12), 15.0);
}

}  // namespace
}  // namespace veil
