// The example lenses: each loads, traces, and has the first-order data its source gives.
// Published lenses are checked against the published numbers; lenses designed here against
// their design targets and an independent closed form where one exists.

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "analysis/lens/first_order.h"
#include "analysis/lens/spot.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/lens_file.h"
#include "lensdata/prescription.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

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

// Newtonian: the paraboloid's focus, R / 2 = 500 mm, folded 70 mm out of the tube by the
// 45 degree mirror 430 mm in front of the primary: the image at (0, 70, 70) mm, where every
// on-axis ray lands (the paraboloid is perfect on its axis).
TEST(Examples, NewtonianFoldsThePerfectFocusOutOfTheTube) {
    const Loaded l = load("newtonian_500mm.toml");
    EXPECT_NEAR(l.firstOrder.primaryData().eflMm, 500.0, 1e-9);
    const int img = l.model.imageIndex();
    const Vec3 v = l.model.surface(img).frame.translation;
    EXPECT_NEAR(v.x, 0.0, 1e-12);
    EXPECT_NEAR(v.y, 70.0, 1e-12);
    EXPECT_NEAR(v.z, 70.0, 1e-12);
    EXPECT_FALSE(l.model.coaxial());
    const RayAimer aimer(l.model, AimMode::Real);
    for (int w = 0; w < 3; ++w) {
        const SpotResult s = computeSpot(l.model, aimer, 0, w);
        EXPECT_EQ(s.raysLanded, s.raysTraced);
        EXPECT_LT(s.rmsRadiusMm, 1e-9);
        EXPECT_LT(glm::length(s.centroidMm), 1e-9);
    }
}

// The Numbers examples/README.md Quotes
// Each lens's paragraph quotes what `veil info` reports: EFL, F/#, BFL and total track at the
// primary wavelength, and the RMS spot radius about the centroid at F, d and C (8 hexapolar
// rings, real aiming, apertures clipping) on axis and at one field. These are design results
// (no outside truth exists for a lens designed here), so the check is that the README says
// what the files and the tracer give: every number to half a unit in the last digit it
// prints. A change that moves one fails here, and the README is corrected with it.

// |actual - printed| within half a unit of the printed number's last digit.
void expectPrinted(double actual, double printed, int decimals, const std::string& what) {
    const double halfUnit = 0.5 * std::pow(10.0, -decimals);
    EXPECT_LE(std::abs(actual - printed), halfUnit * (1.0 + 1e-9))
        << what << ": veil gives " << actual << ", the README prints " << printed;
}

struct QuotedLens {
    std::string file;
    double efl;  // mm
    int eflDecimals;
    double fNumber;
    double bfl;  // mm
    int bflDecimals;
    double track;  // mm
    int trackDecimals;
    double axisSpotUm[3];  // F, d, C; one decimal
    int field;             // the other quoted field (index into the file's fields)
    double fieldSpotUm[3];
};

TEST(Examples, ReadmeQuotesWhatVeilInfoReports) {
    // One lens per row, as the README's paragraphs quote them.
    // clang-format off
    const std::vector<QuotedLens> lenses = {
        {"singlet.toml", 99.994, 3, 5.0, 97.69, 2, 101.71, 2, {66.7, 26.1, 56.2}, 2,
         {143.8, 67.9, 41.2}},
        {"achromat.toml", 99.997, 3, 5.0, 96.46, 2, 105.02, 2, {6.3, 2.7, 5.0}, 2,
         {33.4, 30.1, 24.1}},
        {"cooke_triplet.toml", 50.005, 3, 3.465, 38.256, 3, 57.562, 3, {12.8, 12.8, 9.9}, 2,
         {23.7, 20.7, 16.5}},
        {"double_gauss_50mm.toml", 50.007, 3, 2.0, 35.722, 3, 67.76, 2, {17.0, 14.8, 18.3}, 3,
         {57.6, 58.2, 61.9}},
        {"longfocus_360mm.toml", 359.97, 2, 7.0, 196.08, 2, 305.97, 2, {2.3, 4.8, 11.7}, 2,
         {2.1, 12.4, 3.6}},
        {"catadioptric_2000mm.toml", 2000.23, 2, 10.0, 236.09, 2, 710.30, 2, {13.7, 8.9, 6.9}, 2,
         {8.2, 12.2, 14.5}},
        {"newtonian_500mm.toml", 500.0, 0, 5.0, 70.0, 0, 140.00, 2, {0.0, 0.0, 0.0}, 2,
         {10.2, 10.2, 10.2}},
        {"anamorphic_cylinders.toml", 100.00, 2, 10.0, 46.704, 3, 103.41, 2, {57.4, 19.9, 11.2}, 2,
         {63.3, 25.1, 12.2}},
    };
    // clang-format on
    for (const QuotedLens& q : lenses) {
        SCOPED_TRACE(q.file);
        const Loaded l = load(q.file);
        const FirstOrderData& d = l.firstOrder.primaryData();
        expectPrinted(d.eflMm, q.efl, q.eflDecimals, "EFL");
        EXPECT_NEAR(d.imageSpaceFNumber, q.fNumber, 1e-9);
        expectPrinted(d.bflMm, q.bfl, q.bflDecimals, "BFL");
        expectPrinted(d.totalTrackMm, q.track, q.trackDecimals, "total track");
        const RayAimer aimer(l.model, AimMode::Real);
        ASSERT_EQ(l.model.wavelengthCount(), 3);
        for (int w = 0; w < 3; ++w) {
            const std::string line = " at " + std::to_string(l.model.wavelengthNm(w)) + " nm";
            expectPrinted(1000.0 * computeSpot(l.model, aimer, 0, w).rmsRadiusMm, q.axisSpotUm[w],
                          1, "RMS spot on axis" + line);
            expectPrinted(1000.0 * computeSpot(l.model, aimer, q.field, w).rmsRadiusMm,
                          q.fieldSpotUm[w], 1,
                          "RMS spot at field " + std::to_string(q.field) + line);
        }
    }
}

// Share of the entrance pupil's area that does not reach the image at field f, wavelength w:
// a hexapolar grid of 100 rings (30301 rays) samples the disk with nearly uniform density,
// to 0.3 % of the area (the same share from 200 rings).
double pupilShareLost(const Loaded& l, int f, int w, int rings = 100) {
    SpotOptions o;
    o.rings = rings;
    const SpotResult s = computeSpot(l.model, RayAimer(l.model, AimMode::Real), f, w, o);
    return 1.0 - static_cast<double>(s.raysLanded) / s.raysTraced;
}

// The vignetting the README quotes: the Cooke triplet's and the double Gauss's published
// apertures cut the off-axis beams (the share of the pupil's area, and of the 217 spot rays,
// whose outer ring weighs more); the long-focus lens vignettes nothing at any field,
// wavelength or corner.
TEST(Examples, ReadmeVignettingIsThePupilAreaLost) {
    const Loaded cooke = load("cooke_triplet.toml");
    const int d = cooke.model.primaryWavelength();
    expectPrinted(100.0 * pupilShareLost(cooke, 2, d), 43.0, 0, "Cooke, area at 11.86 deg");
    const SpotResult cs = computeSpot(cooke.model, RayAimer(cooke.model), 2, d);
    expectPrinted(100.0 * (cs.raysTraced - cs.raysLanded) / cs.raysTraced, 49.0, 0,
                  "Cooke, spot rays at 11.86 deg");
    const Loaded dg = load("double_gauss_50mm.toml");
    expectPrinted(100.0 * pupilShareLost(dg, 3, d), 71.0, 0, "double Gauss, area at 22 deg");
    const SpotResult ds = computeSpot(dg.model, RayAimer(dg.model), 3, d);
    expectPrinted(100.0 * (ds.raysTraced - ds.raysLanded) / ds.raysTraced, 73.0, 0,
                  "double Gauss, spot rays at 22 deg");
    const Loaded lf = load("longfocus_360mm.toml");
    for (int f = 0; f < static_cast<int>(lf.prescription.system.fields.size()); ++f)
        for (int w = 0; w < 3; ++w) EXPECT_EQ(pupilShareLost(lf, f, w, 24), 0.0) << f << " " << w;
}

// The singlet started from the thin-lens best form for an object at infinity,
// q = 2 (n^2 - 1) / (n + 2) (Kingslake, Lens Design Fundamentals, 4.3) = 0.740 for N-BK7;
// real-ray refinement moved its radii, not far: q = (r2 + r1) / (r2 - r1) of the file.
TEST(Examples, SingletHasTheBestFormShapeFactor) {
    const double n = 1.51680;
    expectPrinted(2.0 * (n * n - 1.0) / (n + 2.0), 0.740, 3, "best-form shape factor");
    const Loaded l = load("singlet.toml");
    const double r1 = l.prescription.surfaces[2].radiusMm(),
                 r2 = l.prescription.surfaces[3].radiusMm();
    EXPECT_NEAR((r2 + r1) / (r2 - r1), 0.740, 0.002);
}

// The catadioptric's obscuration numbers: the secondary's sd is 38.6 % of the aperture's
// (15 % of its area); on axis the primary's hole vignettes 8 % of the pupil's area in the
// sequential model; the light returning from M2 crosses the primary's sphere within
// 28.21 mm (real rays over the full pupil at F, d and C, fields 0 to 0.625 deg, no
// apertures), and the hole is that plus 1 mm.
TEST(Examples, CatadioptricHoleAndObscurationAreTheQuotedSizes) {
    const Loaded l = load("catadioptric_2000mm.toml");
    const Prescription& p = l.prescription;
    const double eps = p.surfaces[5].clearSemiDiameterMm / p.surfaces[1].clearSemiDiameterMm;
    expectPrinted(100.0 * eps, 38.6, 1, "obscuration, diameter");
    expectPrinted(100.0 * eps * eps, 15.0, 0, "obscuration, area");
    expectPrinted(100.0 * pupilShareLost(l, 0, l.model.primaryWavelength()), 8.0, 0,
                  "hole, on axis");
    // Where the ray after M2 meets M1's sphere (vertex z0, radius R; the crossing nearer the
    // vertex), by hand.
    const SequentialSurface& m1 = l.model.surface(4);
    const double radius = p.surfaces[4].radiusMm();
    const Vec3 centre(0.0, 0.0, m1.zMm + radius);
    const RayAimer aimer(l.model, AimMode::Real);
    SequentialTraceOptions o;
    o.clipApertures = false;
    o.recordPath = true;
    double widest = 0.0;
    for (const Field& f : p.system.fields)
        for (int w = 0; w < 3; ++w)
            for (const Vec2& pupil : hexapolarPupil(24)) {
                const AimedRay a = aimer.aim(f, pupil.x, pupil.y, w);
                ASSERT_EQ(a.status, RayStatus::Ok);
                const SequentialRayResult r = traceSequential(l.model, w, a.ray, o);
                ASSERT_TRUE(r.ok()) << r;
                const Ray& afterM2 = r.path[5 - o.firstSurface];
                const Vec3 oc = afterM2.origin - centre;
                const double b = glm::dot(oc, afterM2.direction);
                const double c = glm::dot(oc, oc) - radius * radius;
                const double t = -b + std::sqrt(b * b - c);  // M2 lies inside M1's sphere
                const Vec3 x = afterM2.origin + t * afterM2.direction;
                widest = std::max(widest, std::hypot(x.x, x.y));
            }
    expectPrinted(widest, 28.21, 2, "returning beam on M1");
    EXPECT_NEAR(p.surfaces[4].innerSemiDiameterMm - widest, 1.0, 0.01);
}

}  // namespace
}  // namespace veil
