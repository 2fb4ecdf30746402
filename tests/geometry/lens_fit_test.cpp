// Lens sizes fitted where the file's do not build. The truths are closed forms: the sag of a
// sphere, z = R - sqrt(R^2 - r^2), gives the radius where an edge reaches a thickness or a
// gap closes, and the fitted sizes must land there.

#include "geometry/lens_fit.h"

#include <gtest/gtest.h>

#include <cmath>

#include "geometry/lens_solid.h"
#include "lensdata/errors.h"
#include "tests/test_lenses.h"

namespace veil {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

double sphereSag(double radius, double r) {
    return radius - std::copysign(std::sqrt(radius * radius - r * r), radius);
}

// A biconvex singlet, R = +-50 mm, 1 mm thick at the centre, clear semi-diameters 10 and
// outer radius 12: its rims meet 0.0204 mm apart at r = 10, so the edge is negative.
Prescription thinSinglet() { return test::equiconvexSinglet(50.0, 1.0, 10.0, 12.0); }

std::function<std::vector<double>()> bundleOf(double sd) {
    return [sd] { return std::vector<double>{0.0, sd, sd, 0.0}; };
}

TEST(LensFit, SizesThatBuildAreKeptAndNothingIsTraced) {
    Prescription p = thinSinglet();
    p.surfaces[1].thicknessMm = 3.0;
    bool traced = false;
    const LensFit fit = fitLensSizes(p, [&] {
        traced = true;
        return std::vector<double>(4, 1.0);
    });
    EXPECT_FALSE(traced);
    EXPECT_TRUE(fit.changes.empty());
    EXPECT_EQ(fit.prescription.surfaces[1].clearSemiDiameterMm, 10.0);
    EXPECT_EQ(fit.prescription.surfaces[1].mechSemiDiameterMm, 12.0);
}

TEST(LensFit, ANegativeEdgeShrinksToAQuarterOfTheCentreThickness) {
    const Prescription p = thinSinglet();
    ASSERT_THROW(lensSolids(p), ModelError);
    const LensFit fit = fitLensSizes(p, bundleOf(6.0));
    // The edge keeps min(0.5, 1 / 4) = 0.25 mm: 1 - 2 sag(r) = 0.25 at r^2 = 2 * 50 * 0.375 -
    // 0.375^2, and the light needs only 6 mm there.
    const double expected = std::sqrt(100.0 * 0.375 - 0.375 * 0.375);
    const Surface& front = fit.prescription.surfaces[1];
    const Surface& back = fit.prescription.surfaces[2];
    EXPECT_NEAR(front.clearSemiDiameterMm, expected, 1e-9);
    EXPECT_NEAR(back.clearSemiDiameterMm, expected, 1e-9);
    EXPECT_EQ(front.mechSemiDiameterMm, 0.0);
    const std::vector<LensSolid> solids = lensSolids(fit.prescription);
    ASSERT_EQ(solids.size(), 1u);
    EXPECT_NEAR(solids[0].edgeRadiusMm, expected, 1e-9);
    EXPECT_NEAR(solids[0].back.rimZMm - solids[0].front.rimZMm, 0.25, 1e-9);
    ASSERT_EQ(fit.changes.size(), 1u);
    const LensSizeChange& c = fit.changes[0];
    EXPECT_EQ(c.element, "L1");
    EXPECT_EQ(c.radiusBeforeMm, 12.0);
    EXPECT_NEAR(c.radiusAfterMm, expected, 1e-9);
    ASSERT_EQ(c.faces.size(), 2u);
    EXPECT_EQ(c.faces[0].name, "L1.front");
    EXPECT_EQ(c.faces[0].clearBeforeMm, 10.0);
    const double rim = sphereSag(50.0, 10.0);
    EXPECT_EQ(c.reason, "edge thickness " + messageNumber(1.0 - 2.0 * rim) + " mm at r = 12 mm");
    const std::string line = describe(c);
    EXPECT_NE(line.find("L1: L1.front clear semi-diameter 10.000 -> 6.112 mm"), std::string::npos)
        << line;
    EXPECT_NE(line.find("outer radius 12.000 -> 6.112 mm"), std::string::npos) << line;
    // The fitted lens is left as the input was otherwise (names are not assigned anew).
    EXPECT_EQ(fit.prescription.surfaces[1].thicknessMm, 1.0);
    EXPECT_EQ(fit.prescription.surfaces.size(), p.surfaces.size());
}

TEST(LensFit, WhenTheLightLeavesNoMarginItKeepsTheBundleSizes) {
    // The light needs 6.5 mm, beyond the 0.25 mm edge at 6.112 but inside r = 7.053 where the
    // edge closes: the bundle's sizes are kept, with the edge they leave.
    const LensFit fit = fitLensSizes(thinSinglet(), bundleOf(6.5));
    EXPECT_EQ(fit.prescription.surfaces[1].clearSemiDiameterMm, 6.5);
    EXPECT_EQ(fit.prescription.surfaces[2].clearSemiDiameterMm, 6.5);
    const std::vector<LensSolid> solids = lensSolids(fit.prescription);
    EXPECT_NEAR(solids[0].back.rimZMm - solids[0].front.rimZMm, 1.0 - 2.0 * sphereSag(50.0, 6.5),
                1e-12);
}

TEST(LensFit, LightThatNeedsMoreGlassThanThereIsIsAnErrorSayingWhatFits) {
    try {
        fitLensSizes(thinSinglet(), bundleOf(7.5));
        FAIL() << "no error";
    } catch (const ModelError& e) {
        const std::string what = e.what();
        EXPECT_EQ(e.object(), "L1.front");
        EXPECT_NE(what.find("its faces L1.front and L1.back cross inside the light: the traced "
                            "rays reach r = 7.500 mm on L1.front and r = 7.500 mm on L1.back"),
                  std::string::npos)
            << what;
        // The edge closes where 2 sag(r) = 1: r^2 = 50 - 0.25.
        const double fits = std::sqrt(49.75);
        char buf[64];
        std::snprintf(buf, sizeof buf, "the largest semi-diameter that fits is %.3f mm", fits);
        EXPECT_NE(what.find(buf), std::string::npos) << what;
    }
}

// L1's back (R -50) bulges toward L2, whose front (R -30) curls back faster: 0.1 mm apart on
// the axis, the gap closes at r = 4.61 mm and is -0.606 mm at r = 10.
Prescription overlappingPair(double l2Sd) {
    Prescription p = test::startLens(kInf, 10.0);
    auto add = [&](double r, double t, Material m, double sd) {
        Surface s = test::surface(r, t, m);
        s.clearSemiDiameterMm = sd;
        p.surfaces.push_back(s);
    };
    add(50.0, 5.0, Material::model(1.5, 60.0), 10.0);
    add(-50.0, 0.1, Material::air(), 10.0);
    add(-30.0, 5.0, Material::model(1.6, 40.0), l2Sd);
    add(0.0, 50.0, Material::air(), l2Sd);
    test::finishLens(p);
    return p;
}

double gapAt(double r) { return 0.1 + sphereSag(-30.0, r) - sphereSag(-50.0, r); }

TEST(LensFit, OverlappingNeighboursShrinkTheOneThatKeepsMostGlass) {
    const Prescription p = overlappingPair(10.0);
    ASSERT_THROW(lensSolids(p), ModelError);
    const LensFit fit =
        fitLensSizes(p, [] { return std::vector<double>{0.0, 2.0, 2.0, 2.0, 2.0, 0.0}; });
    const std::vector<LensSolid> solids = lensSolids(fit.prescription);
    std::vector<LensSolidProblem> ms;
    measuredLensSolids(fit.prescription, ms);
    double gap = kInf;
    for (const LensSolidProblem& m : ms)
        if (m.kind == LensSolidProblem::Kind::AirGap) gap = m.valueMm;
    // The gap kept is min(0.1, 0.1 / 2) = 0.05 mm: either element shrinks to where the
    // spheres are 0.05 mm apart, and the other keeps its 10 mm.
    double lo = 0.0, hi = 10.0;
    for (int i = 0; i < 60; ++i) (gapAt(0.5 * (lo + hi)) >= 0.05 ? lo : hi) = 0.5 * (lo + hi);
    EXPECT_NEAR(gap, 0.05, 1e-9);
    const double r1 = solids[0].edgeRadiusMm, r2 = solids[1].edgeRadiusMm;
    EXPECT_NEAR(std::min(r1, r2), lo, 1e-6);
    EXPECT_EQ(std::max(r1, r2), 10.0);
    ASSERT_EQ(fit.changes.size(), 1u);
    EXPECT_NE(fit.changes[0].reason.find("overlapped"), std::string::npos);
}

TEST(LensFit, NeighboursWhoseLightCrossesAreAnErrorNamingBothFaces) {
    // The light needs 6 mm on both: the spheres cross at 4.61 mm.
    try {
        fitLensSizes(overlappingPair(10.0),
                     [] { return std::vector<double>{0.0, 6.0, 6.0, 6.0, 6.0, 0.0}; });
        FAIL() << "no error";
    } catch (const ModelError& e) {
        const std::string what = e.what();
        EXPECT_EQ(e.object(), "L1.back");
        EXPECT_NE(what.find("L1.back and L2.front (L1 and L2) cross inside the light"),
                  std::string::npos)
            << what;
        double lo = 0.0, hi = 10.0;
        for (int i = 0; i < 60; ++i) (gapAt(0.5 * (lo + hi)) >= 0.0 ? lo : hi) = 0.5 * (lo + hi);
        char buf[64];
        std::snprintf(buf, sizeof buf, "the largest semi-diameter that fits is %.3f mm", lo);
        EXPECT_NE(what.find(buf), std::string::npos) << what;
        EXPECT_NE(what.find("Check the air gap after L1.back"), std::string::npos) << what;
    }
}

}  // namespace
}  // namespace veil
