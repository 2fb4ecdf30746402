// Paraxial trace and first-order data against closed-form optics.

#include "analysis/lens/first_order.h"

#include <gtest/gtest.h>

#include <cmath>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "lensdata/zmx_reader.h"
#include "tests/test_lenses.h"
#include "tracer/sequential/paraxial.h"
#include "tracer/sequential/pupil.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {
namespace {

using test::finishLens;
using test::startLens;
using test::surface;

const GlassCatalog kNoCatalog;

// Thick lens in air: lensmaker's equation with the thickness term.
TEST(Paraxial, ThickLensMatchesLensmakersEquation) {
    const double n = 1.5, r1 = 50.0, r2 = -80.0, t = 6.0;
    Prescription p = startLens(kInfinity, 10.0);
    Surface s1 = surface(r1, t, Material::model(n, 50.0));
    s1.stop = true;
    p.surfaces.push_back(s1);
    p.surfaces.push_back(surface(r2, 60.0));
    finishLens(p);
    const SequentialModel m = SequentialModel::build(p, kNoCatalog);
    ASSERT_NEAR(m.index(1, 0), n, 1e-12);

    const double power = (n - 1.0) * (1.0 / r1 - 1.0 / r2 + (n - 1.0) * t / (n * r1 * r2));
    const double f = 1.0 / power;
    const double bfl = f * (1.0 - (n - 1.0) * t / (n * r1));
    const double ffl = -f * (1.0 + (n - 1.0) * t / (n * r2));
    const FirstOrderData fo = computeFirstOrder(m, 0);
    EXPECT_NEAR(fo.eflMm, f, 1e-12 * f);
    EXPECT_NEAR(fo.bflMm, bfl, 1e-12 * f);
    EXPECT_NEAR(fo.fflMm, ffl, 1e-12 * f);
    // Principal planes: H at ffl + f from surface 1, H' at bfl - f from the last surface.
    EXPECT_NEAR(fo.frontPrincipalPlaneMm, ffl + f, 1e-11 * f);
    EXPECT_NEAR(fo.rearPrincipalPlaneMm, (bfl - f) - 60.0, 1e-11 * f);
    EXPECT_NEAR(fo.imageSpaceFNumber, f / 10.0, 1e-12 * f);
    // Stop on surface 1: the entrance pupil is there and has the stop's size.
    EXPECT_NEAR(fo.entrancePupilPositionMm, 0.0, 1e-12);
    EXPECT_NEAR(fo.stopSemiDiameterMm, 5.0, 1e-12);
    // Petzval radius of a thick lens: -1 / sum((n'-n) c / (n n')).
    const double pz = (n - 1.0) / (r1 * n) + (1.0 - n) / (r2 * n);
    EXPECT_NEAR(fo.petzvalRadiusMm, -1.0 / pz, 1e-9);
}

// A plane-parallel plate behind a lens moves the focus by t (1 - 1/n).
TEST(Paraxial, PlateShiftsFocusByTTimesOneMinusInverseN) {
    const double n = 1.6, tPlate = 12.0;
    auto lens = [&](bool withPlate) {
        Prescription p = startLens(kInfinity, 8.0);
        Surface s1 = surface(60.0, 4.0, Material::model(1.5, 60.0));
        s1.stop = true;
        p.surfaces.push_back(s1);
        p.surfaces.push_back(surface(-60.0, 10.0));
        if (withPlate) {
            p.surfaces.push_back(surface(0.0, tPlate, Material::model(n, 40.0)));
            p.surfaces.push_back(surface(0.0, 20.0));
        }
        finishLens(p);
        return SequentialModel::build(p, kNoCatalog);
    };
    const FirstOrderData bare = computeFirstOrder(lens(false), 0);
    const FirstOrderData plate = computeFirstOrder(lens(true), 0);
    // Distance from the lens's back vertex to the focus, with and without the plate.
    const double dBare = bare.bflMm;
    const double dPlate = 10.0 + tPlate + plate.bflMm;
    EXPECT_NEAR(dPlate - dBare, tPlate * (1.0 - 1.0 / n), 1e-12 * dBare);
    EXPECT_NEAR(plate.eflMm, bare.eflMm, 1e-12 * bare.eflMm);
}

// A concave spherical mirror focuses parallel light at r/2 in front of it.
TEST(Paraxial, SphericalMirrorFocalLengthIsHalfTheRadius) {
    for (double r : {-200.0, -37.5, 150.0}) {
        Prescription p = startLens(kInfinity, 10.0);
        Surface m1 = surface(r, -0.5 * std::abs(r));
        m1.mirror = true;
        m1.stop = true;
        p.surfaces.push_back(m1);
        finishLens(p);
        const SequentialModel m = SequentialModel::build(p, kNoCatalog);
        const FirstOrderData fo = computeFirstOrder(m, 0);
        // Concave toward the light (r < 0) converges: EFL = |r| / 2; convex diverges.
        EXPECT_NEAR(fo.eflMm, -r / 2.0, 1e-12 * std::abs(r)) << "r = " << r;
        // The focus lies at z = r/2 (in front of the mirror for the concave one).
        EXPECT_NEAR(fo.bflMm, r / 2.0, 1e-12 * std::abs(r)) << "r = " << r;
        EXPECT_EQ(m.direction(1), -1.0);
        EXPECT_LT(m.index(1, 0), 0.0);
        // Petzval radius of a mirror: r/2 in the folded frame.
        EXPECT_NEAR(fo.petzvalRadiusMm, r / 2.0, 1e-9 * std::abs(r));
    }
}

// A Cassegrain telescope: concave primary f1 = 200, convex secondary f2 = -75, 150 mm
// apart. Two-mirror closed form: 1/f = 1/f1 + 1/f2 - d / (f1 f2) = 1/600, and the focus lies
// f (1 - d / f1) = 150 mm behind the secondary, toward +z again.
TEST(Paraxial, CassegrainFollowsTheTwoMirrorFormula) {
    Prescription p = startLens(kInfinity, 100.0);
    Surface m1 = surface(-400.0, -150.0);
    m1.mirror = true;
    m1.stop = true;
    p.surfaces.push_back(m1);
    Surface m2 = surface(-150.0, 150.0);
    m2.mirror = true;
    p.surfaces.push_back(m2);
    finishLens(p);
    const SequentialModel m = SequentialModel::build(p, kNoCatalog);
    const FirstOrderData fo = computeFirstOrder(m, 0);
    EXPECT_NEAR(fo.eflMm, 600.0, 1e-9);
    EXPECT_NEAR(fo.bflMm, 150.0, 1e-9);
    EXPECT_NEAR(fo.imageSpaceFNumber, 6.0, 1e-12);
    EXPECT_GT(m.index(2, 0), 0.0);
    EXPECT_LT(m.index(1, 0), 0.0);
}

// Two thin lenses in contact: powers add. Separated: the Gullstrand formula.
TEST(Paraxial, SeparatedThinLensesFollowGullstrand) {
    // Nearly thin lenses of f1 = 100, f2 = -150 (thickness 1e-9 mm) separated by d = 30.
    const double n = 1.5, d = 30.0, tiny = 1e-9;
    const double f1 = 100.0, f2 = -150.0;
    const double r1 = 2.0 * (n - 1.0) * f1, r2 = 2.0 * (n - 1.0) * f2;
    Prescription p = startLens(kInfinity, 10.0);
    Surface a = surface(r1, tiny, Material::model(n, 60.0));
    a.stop = true;
    p.surfaces.push_back(a);
    p.surfaces.push_back(surface(-r1, d));
    p.surfaces.push_back(surface(r2, tiny, Material::model(n, 60.0)));
    p.surfaces.push_back(surface(-r2, 100.0));
    finishLens(p);
    const FirstOrderData fo = computeFirstOrder(SequentialModel::build(p, kNoCatalog), 0);
    const double f = 1.0 / (1.0 / f1 + 1.0 / f2 - d / (f1 * f2));
    EXPECT_NEAR(fo.eflMm, f, 1e-7 * f);
    // The exit pupil is the image of lens 1 (the stop) by lens 2: Gaussian lens formula.
    const double s = -d;  // object (lens 1) 30 mm in front of lens 2
    const double sImg = 1.0 / (1.0 / f2 + 1.0 / s);
    EXPECT_NEAR(fo.exitPupilPositionMm, sImg - 100.0, 1e-6);
}

// Finite conjugates: a thin-ish lens at 2f images with magnification -1.
TEST(Paraxial, UnitMagnificationAtTwiceTheFocalLength) {
    const double n = 1.5, f = 50.0;
    const double r = 2.0 * (n - 1.0) * f;
    Prescription p = startLens(2.0 * f, 10.0);
    Surface a = surface(r, 1e-9, Material::model(n, 60.0));
    a.stop = true;
    p.surfaces.push_back(a);
    p.surfaces.push_back(surface(-r, 2.0 * f));
    finishLens(p);
    const FirstOrderData fo = computeFirstOrder(SequentialModel::build(p, kNoCatalog), 0);
    EXPECT_NEAR(fo.paraxialMagnification, -1.0, 1e-8);
    EXPECT_NEAR(fo.paraxialImageDistanceMm, 0.0, 1e-6);
    // NA: marginal ray from the axial object point to the pupil edge.
    EXPECT_NEAR(fo.objectSpaceNA, std::sin(std::atan(5.0 / 100.0)), 1e-9);
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// The two Zemax sample files, imported and traced. The reference EFLs were derived by hand
// (y-nu table in tests/lensdata/zmx_reader_test.cpp): 49.38898 mm for the double Gauss at
// the d line with N-BAK1 and N-BALF4 from the catalog; 24.60872 mm for the catadioptric
// HoO lens at 550 nm, which also follows from the file's own automatic stop semi-diameter
// (FNUM 1.25: EFL = 1.25 * 2 * 9.843488 mm).
TEST(FirstOrderZmx, SampleFilesHaveTheirDerivedFocalLengths) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    {
        const Prescription p =
            readZmx(VEIL_SOURCE_DIR "/tests/data/zmx/US00583336-2-scaled.zmx", catalog);
        const SequentialModel m = SequentialModel::build(p, catalog);
        const FirstOrderData fo = computeFirstOrder(m, m.primaryWavelength());
        EXPECT_NEAR(fo.eflMm, 49.38898, 2e-5);
        EXPECT_NEAR(fo.entrancePupilDiameterMm, 49.38898 / 4.5, 1e-5);
        // Symmetric about the stop: the pupils sit at the principal planes.
        EXPECT_NEAR(fo.entrancePupilPositionMm, fo.frontPrincipalPlaneMm, 1e-9);
        EXPECT_NEAR(fo.exitPupilPositionMm, fo.rearPrincipalPlaneMm, 1e-9);
    }
    {
        const Prescription p =
            readZmx(VEIL_SOURCE_DIR "/tests/data/zmx/HoO-V2C18Ex27.zmx", catalog);
        const SequentialModel m = SequentialModel::build(p, catalog);
        const FirstOrderData fo = computeFirstOrder(m, m.primaryWavelength());
        EXPECT_NEAR(fo.eflMm, 24.60872, 2e-5);
        // The stop is surface 1: its paraxial semi-diameter is EPD / 2, which Zemax wrote
        // (plus the field's offset) as DIAM 9.8475 for the 1.5 degree field.
        EXPECT_NEAR(fo.stopSemiDiameterMm, 24.60872 / 1.25 / 2.0, 1e-5);
        EXPECT_LT(fo.stopSemiDiameterMm, p.surfaces[1].clearSemiDiameterMm);
        // Two mirrors: the image space runs toward +z again, and the image lies near the
        // paraxial focus the file's last thickness was solved for.
        EXPECT_GT(m.index(m.imageIndex() - 1, 0), 0.0);
        EXPECT_NEAR(fo.paraxialImageDistanceMm, 0.0, 1e-3);
    }
}

}  // namespace
}  // namespace veil
