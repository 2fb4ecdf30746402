// Sources: emitted positions and directions against their analytic distributions
// (Pearson's chi-square, fixed seeds, thresholds at mean + 5 sigma), beam coverage of the
// front lens, flux bookkeeping, evaluation (radiance integrated over independently sampled
// positions and directions against the total flux, z-scores; emit() against pdf() by
// chi-square), and the [[source]] reader's keys and errors.

#include "tracer/light/source.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "geometry/numerics.h"
#include "geometry/scene.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "lensdata/toml_document.h"
#include "lensdata/toml_reader.h"
#include "tracer/light/spectrum.h"
#include "tracer/runtime/rng.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {
namespace {

namespace fs = std::filesystem;

constexpr double kDeg = kPi / 180.0;
const GlassCatalog kNoCatalog;

// Statistics Helpers

// Pearson's chi-square over equal-probability bins of a variable that is uniform in [0, 1]
// under the hypothesis. Threshold: the statistic's mean plus five standard deviations,
// dof + 5 sqrt(2 dof): deterministic with fixed seeds, and far below what a real deviation
// of a few per cent in one bin gives at these sample sizes.
class UniformChiSquare {
  public:
    explicit UniformChiSquare(int bins) : counts_(bins, 0) {}
    void add(double x) {
        ++n_;
        if (!(x >= 0.0 && x <= 1.0)) {
            ++outside_;
            return;
        }
        const int b = std::min(static_cast<int>(x * counts_.size()), bins() - 1);
        ++counts_[b];
    }
    int bins() const { return static_cast<int>(counts_.size()); }
    double statistic() const {
        const double e = static_cast<double>(n_) / bins();
        double chi = 0.0;
        for (int64_t k : counts_) chi += (k - e) * (k - e) / e;
        return chi;
    }
    double threshold() const {
        const double dof = bins() - 1;
        return dof + 5.0 * std::sqrt(2.0 * dof);
    }
    bool passes() const { return outside_ == 0 && statistic() < threshold(); }
    int64_t outside() const { return outside_; }
    int64_t n() const { return n_; }

  private:
    std::vector<int64_t> counts_;
    int64_t n_ = 0, outside_ = 0;
};
std::ostream& operator<<(std::ostream& os, const UniformChiSquare& c) {
    return os << "chi2 " << c.statistic() << " over " << c.bins() << " bins (threshold "
              << c.threshold() << "), " << c.outside() << " of " << c.n() << " outside [0, 1]";
}

// Neumaier's compensated sum, so the flux sum is compared to the total at rounding level.
class CompensatedSum {
  public:
    void add(double x) {
        const double t = sum_ + x;
        c_ += std::abs(sum_) >= std::abs(x) ? (sum_ - t) + x : (x - t) + sum_;
        sum_ = t;
    }
    double value() const { return sum_ + c_; }

  private:
    double sum_ = 0.0, c_ = 0.0;
};

// Azimuth of v about an axis with reference directions u, w, as a fraction of a turn.
double turn(const Vec3& v, const Vec3& u, const Vec3& w) {
    const double a = std::atan2(glm::dot(v, w), glm::dot(v, u));
    return (a < 0.0 ? a + 2.0 * kPi : a) / (2.0 * kPi);
}

// Scenes

// A singlet with a mechanical semi-diameter (13 mm) larger than its clear one (12 mm), at
// three wavelengths weighted 1 : 2 : 1.
const std::string kLens = R"([system]
wavelengths_nm = [486.1327, { nm = 587.5618, weight = 2.0 }, 656.2725]
aperture = { epd_mm = 20 }
surfaces = [
  { r = 50, t = 5, glass = { nd = 1.5168, vd = 64.17 }, sd = 12, mech_sd = 13 },
  { r = -80, t = 40, sd = 12 },
]
)";
const int kLensLines = 7;  // sources' lines start at kLensLines + 1

// A Cassegrain: the secondary, 150 mm in front of the primary, is the front of the lens.
const std::string kCassegrain = R"([system]
aperture = { epd_mm = 100 }
surfaces = [
  { r = -400, t = -150, mirror = true, conic = -1, sd = 50 },
  { r = -150, t = 180, mirror = true, conic = -2.5, sd = 15 },
]
)";

double sphereSag(double radius, double r) {
    return radius - std::copysign(std::sqrt(radius * radius - r * r), radius);
}
const double kSag13 = sphereSag(50.0, 13.0);  // of the first surface at its mech_sd

struct Scene {
    explicit Scene(const std::string& sourceText, const std::string& lens = kLens)
        : doc(TomlDocument::fromString(lens + sourceText, "scene.toml")),
          p(readTomlPrescription(doc, kNoCatalog)),
          model(SequentialModel::build(p, kNoCatalog)),
          sources(readSources(doc, p, model)) {
        doc.checkAllUsed();
    }
    const Source& only() const {
        EXPECT_EQ(sources.size(), 1u);
        return sources.at(0);
    }
    TomlDocument doc;
    Prescription p;
    SequentialModel model;
    std::vector<Source> sources;
};

// n rays of a run of n, ray i from stream i as the transport core draws them.
std::vector<EmittedRay> emitRays(const Source& s, int n, uint64_t seed = 2018) {
    std::vector<EmittedRay> rays;
    rays.reserve(n);
    for (int i = 0; i < n; ++i) {
        CounterRng rng(seed, static_cast<uint64_t>(i));
        rays.push_back(s.emit(rng, static_cast<uint64_t>(n)));
    }
    return rays;
}

void expectFluxSumsToTotal(const Source& s, const std::vector<EmittedRay>& rays) {
    CompensatedSum sum;
    for (const EmittedRay& r : rays) sum.add(r.flux);
    EXPECT_NEAR(sum.value(), s.totalFlux(), 1e-12 * s.totalFlux()) << s;
}

// Where a ray crosses the plane z = zMm.
Vec3 atZ(const Ray& r, double zMm) {
    return r.origin + (zMm - r.origin.z) / r.direction.z * r.direction;
}

// Points of the first surface out to radius r (global).
std::vector<Vec3> surfacePoints(const EntranceAperture& a, double r, int azimuths = 72) {
    std::vector<Vec3> pts;
    for (int i = 0; i <= 26; ++i) {
        const double ri = r * i / 26.0;
        const double z = a.vertexZMm + sag(a.shape, ri * ri);
        for (int j = 0; j < azimuths; ++j) {
            const double phi = 2.0 * kPi * j / azimuths;
            pts.emplace_back(ri * std::cos(phi), ri * std::sin(phi), z);
        }
    }
    return pts;
}

// Distance of p from the line through c along unit d.
double offLine(const Vec3& p, const Vec3& c, const Vec3& d) {
    const Vec3 q = p - c;
    return glm::length(q - glm::dot(q, d) * d);
}

constexpr int kRays = 100000;

// Entrance Aperture

TEST(EntranceAperture, UsesTheMechanicalSemiDiameterAndFindsTheFrontOfTheLens) {
    const Scene s("");
    const EntranceAperture a = entranceAperture(s.p, s.model);
    EXPECT_EQ(a.surfaceName, "L1.front");
    EXPECT_EQ(a.radiusMm, 13.0);
    EXPECT_EQ(a.clearRadiusMm, 12.0);
    EXPECT_EQ(a.frontZMm, 0.0);  // the convex vertex
    const auto [lo, hi] = a.zRange(13.0);
    EXPECT_EQ(lo, 0.0);
    EXPECT_NEAR(hi, kSag13, 1e-12);
}

TEST(EntranceAperture, FrontOfAFoldedLensIsTheSecondaryMirror) {
    const Scene s("", kCassegrain);
    const EntranceAperture a = entranceAperture(s.p, s.model);
    // Secondary: vertex at z = -150, hyperboloid c = -1/150, k = -2.5, sd 15.
    const double c = -1.0 / 150.0, k = -2.5, r = 15.0;
    const double sagRim = c * r * r / (1.0 + std::sqrt(1.0 - (1.0 + k) * c * c * r * r));
    EXPECT_NEAR(a.frontZMm, -150.0 + sagRim, 1e-12);
    EXPECT_EQ(a.radiusMm, 50.0);
}

// Collimated Beams

TEST(CollimatedSource, OnAxisBeamFillsTheFrontApertureUniformly) {
    const Scene s(R"(
[[source]]
name = "beam"
kind = "collimated"
margin_mm = 0.5
)");
    const Source& src = s.only();
    EXPECT_EQ(src.name(), "beam");
    EXPECT_STREQ(src.kind(), "collimated");
    EXPECT_EQ(src.unit(), FluxUnit::Watt);
    const Beam& b = std::get<CollimatedSource>(src.shape()).beam;
    EXPECT_NEAR(b.radiusMm, 13.5, 1e-12);  // mech_sd + margin; on axis the sag adds nothing
    // Normalised: 1 W crosses the aperture disk (radius 13) at the first vertex.
    EXPECT_NEAR(src.totalFlux(), 13.5 * 13.5 / (13.0 * 13.0), 1e-12);

    const std::vector<EmittedRay> rays = emitRays(src, kRays);
    UniformChiSquare radial(20), azimuth(24);
    CompensatedSum inAperture;
    int64_t inside = 0;
    for (const EmittedRay& r : rays) {
        EXPECT_EQ(r.ray.direction, Vec3(0.0, 0.0, 1.0));
        EXPECT_NEAR(r.ray.origin.z, -5.0, 1e-12);  // start_gap_mm before the vertex
        const Vec3 p = atZ(r.ray, 0.0);
        const double rho2 = p.x * p.x + p.y * p.y;
        radial.add(rho2 / (13.5 * 13.5));
        azimuth.add(turn(p, Vec3(1, 0, 0), Vec3(0, 1, 0)));
        if (rho2 < 13.0 * 13.0) {
            inAperture.add(r.flux);
            ++inside;
        }
    }
    EXPECT_TRUE(radial.passes()) << radial;
    EXPECT_TRUE(azimuth.passes()) << azimuth;
    // The flux through the aperture is 1 W within the binomial error.
    const double pIn = 13.0 * 13.0 / (13.5 * 13.5);
    const double sigma = src.totalFlux() * std::sqrt(pIn * (1.0 - pIn) / kRays);
    EXPECT_NEAR(inAperture.value(), 1.0, 5.0 * sigma);
    expectFluxSumsToTotal(src, rays);
}

TEST(CollimatedSource, TiltedBeamCoversTheCurvedFrontSurface) {
    const Scene s(R"(
[[source]]
kind = "collimated"
field_deg = [3.0, 7.0]
irradiance_w_mm2 = 0.25
)");
    const Source& src = s.only();
    EXPECT_EQ(src.name(), "collimated");  // the kind names an unnamed source
    const Beam& b = std::get<CollimatedSource>(src.shape()).beam;
    const Vec3 d = glm::normalize(Vec3(std::tan(3 * kDeg), std::tan(7 * kDeg), 1.0));
    EXPECT_NEAR(glm::length(b.direction - d), 0.0, 1e-15);
    const double sinT = std::sqrt(1.0 - d.z * d.z);
    // Radius: the aperture plus half the sag range seen sideways.
    EXPECT_NEAR(b.radiusMm, 13.0 + 0.5 * kSag13 * sinT, 1e-9);
    EXPECT_NEAR(src.totalFlux(), 0.25 * kPi * b.radiusMm * b.radiusMm, 1e-12);

    // Every point of the first surface out to 13 mm lies inside the beam's cylinder.
    const EntranceAperture a = entranceAperture(s.p, s.model);
    for (const Vec3& q : surfacePoints(a, 13.0))
        ASSERT_LE(offLine(q, b.startCenterMm, b.direction), b.radiusMm * (1.0 + 1e-12)) << q;

    const std::vector<EmittedRay> rays = emitRays(src, kRays);
    double maxZ = -1e300;
    int64_t inside = 0;
    UniformChiSquare footprint(20), start(20);
    for (const EmittedRay& r : rays) {
        EXPECT_EQ(r.ray.direction, b.direction);
        maxZ = std::max(maxZ, r.ray.origin.z);
        // On the start disk: perpendicular to the beam, uniform over its area.
        const Vec3 o = r.ray.origin - b.startCenterMm;
        EXPECT_NEAR(glm::dot(o, b.direction), 0.0, 1e-12);
        start.add(glm::dot(o, o) / (b.radiusMm * b.radiusMm));
        // In the plane of the first vertex the beam fills the aperture disk uniformly.
        const Vec3 p = atZ(r.ray, 0.0);
        const double rho2 = p.x * p.x + p.y * p.y;
        if (rho2 < 13.0 * 13.0) {
            ++inside;
            footprint.add(rho2 / (13.0 * 13.0));
        }
    }
    EXPECT_TRUE(start.passes()) << start;
    EXPECT_TRUE(footprint.passes()) << footprint;
    // Origins stay start_gap_mm (5) in front of the lens, and the disk reaches that plane.
    EXPECT_LE(maxZ, -5.0 + 1e-12);
    EXPECT_GT(maxZ, -5.0 - 0.05 * b.radiusMm);
    // Share of the rays through the aperture disk: its area seen along the beam over the beam's.
    const double pIn = 13.0 * 13.0 * d.z / (b.radiusMm * b.radiusMm);
    EXPECT_NEAR(static_cast<double>(inside) / kRays, pIn, 5.0 * std::sqrt(pIn * (1 - pIn) / kRays));
    expectFluxSumsToTotal(src, rays);
}

TEST(CollimatedSource, StartsInFrontOfTheSecondaryOfAFoldedLens) {
    const Scene s(R"(
[[source]]
kind = "collimated"
field_deg = 0.5
start_gap_mm = 2.0
)",
                  kCassegrain);
    const Source& src = s.only();
    const EntranceAperture a = entranceAperture(s.p, s.model);
    for (const EmittedRay& r : emitRays(src, 2000)) {
        EXPECT_LE(r.ray.origin.z, a.frontZMm - 2.0 + 1e-9);
        EXPECT_NEAR(glm::length(r.ray.direction - fieldDirection(0.0, 0.5)), 0.0, 1e-15);
    }
}

// Sun

TEST(SunSource, DirectionsAreUniformOverTheSolarDisk) {
    const Scene s(R"(
[[source]]
name = "sun"
kind = "sun"
field_deg = [0.0, 7.0]
)");
    const Source& src = s.only();
    const SunSource& sun = std::get<SunSource>(src.shape());
    const Beam& b = sun.beam;
    const double alpha = 0.5 * 0.533 * kDeg;
    EXPECT_NEAR(b.halfAngleRad, alpha, 1e-15);
    EXPECT_NEAR(glm::length(b.direction - fieldDirection(0.0, 7.0)), 0.0, 1e-15);
    // Normalised to 1 W through the aperture disk at the first vertex.
    EXPECT_NEAR(src.totalFlux(), b.radiusMm * b.radiusMm / (13.0 * 13.0 * std::cos(7.0 * kDeg)),
                1e-12);

    const double oneMinusCosAlpha = 2.0 * std::pow(std::sin(0.5 * alpha), 2);
    const std::vector<EmittedRay> rays = emitRays(src, kRays);
    UniformChiSquare solidAngle(20), azimuth(24), start(20), wrongHypothesis(20);
    for (const EmittedRay& r : rays) {
        const Vec3 w = r.ray.direction;
        ASSERT_NEAR(glm::length(w), 1.0, 1e-15);
        // Uniform over the disk's solid angle: 1 - cos(gamma) uniform in [0, 1 - cos(alpha)].
        const double oneMinusCos = 0.5 * glm::dot(w - b.direction, w - b.direction);
        solidAngle.add(oneMinusCos / oneMinusCosAlpha);
        wrongHypothesis.add(std::acos(std::min(1.0, glm::dot(w, b.direction))) / alpha);
        azimuth.add(turn(w, b.axisU, b.axisV));
        const Vec3 o = r.ray.origin - b.startCenterMm;
        start.add(glm::dot(o, o) / (b.radiusMm * b.radiusMm));
    }
    EXPECT_TRUE(solidAngle.passes()) << solidAngle;
    EXPECT_TRUE(azimuth.passes()) << azimuth;
    EXPECT_TRUE(start.passes()) << start;
    // The test has power: angles uniform in gamma (not in solid angle) are rejected.
    EXPECT_GT(wrongHypothesis.statistic(), 10.0 * wrongHypothesis.threshold()) << wrongHypothesis;
    expectFluxSumsToTotal(src, rays);

    // Every point of the front surface is lit from every direction of the disk: traced back
    // along the disk's rim directions, it lands on the start disk.
    const EntranceAperture a = entranceAperture(s.p, s.model);
    for (const Vec3& q : surfacePoints(a, 13.0)) {
        for (int j = 0; j < 16; ++j) {
            const double phi = 2.0 * kPi * j / 16;
            const Vec3 w = std::cos(alpha) * b.direction +
                           std::sin(alpha) * (std::cos(phi) * b.axisU + std::sin(phi) * b.axisV);
            const double t = glm::dot(q - b.startCenterMm, b.direction) / glm::dot(w, b.direction);
            const Vec3 back = q - t * w;
            ASSERT_LE(glm::length(back - b.startCenterMm), b.radiusMm * (1.0 + 1e-12));
        }
    }
}

TEST(SunSource, AngularDiameterAndIlluminanceAreKeys) {
    const Scene s(R"(
[[source]]
kind = "sun"
angular_diameter_deg = 1.0
illuminance_lm_mm2 = 0.1
)");
    const Source& src = s.only();
    const Beam& b = std::get<SunSource>(src.shape()).beam;
    EXPECT_NEAR(b.halfAngleRad, 0.5 * kDeg, 1e-15);
    EXPECT_EQ(src.unit(), FluxUnit::Lumen);
    EXPECT_EQ(src.spectrum().sampling(), SpectralSampling::Photometric);
    EXPECT_NEAR(src.totalFlux(), 0.1 * b.areaMm2(), 1e-12);
    for (const EmittedRay& r : emitRays(src, 5000))
        EXPECT_GE(glm::dot(r.ray.direction, b.direction), std::cos(0.5 * kDeg) - 1e-15);
}

// Point Sources

TEST(PointSource, OnAxisConeJustCoversTheApertureAndIsUniformInSolidAngle) {
    const Scene s(R"(
[[source]]
name = "lamp"
kind = "point"
position_mm = [0, 0, -100]
intensity_w_sr = 2.0
)");
    const Source& src = s.only();
    const PointSource& ps = std::get<PointSource>(src.shape());
    EXPECT_NEAR(glm::length(ps.axis - Vec3(0, 0, 1)), 0.0, 1e-9);
    // The rim of the convex front surface (r = 13 at z = sag) bounds the cone.
    const double exact = std::atan(13.0 / (100.0 + kSag13));
    EXPECT_GE(ps.halfAngleRad, exact);
    EXPECT_LT(ps.halfAngleRad, exact + 1e-6);
    EXPECT_NEAR(src.totalFlux(), 2.0 * 2.0 * kPi * (1.0 - std::cos(ps.halfAngleRad)), 1e-12);

    const double oneMinusCosMax = 1.0 - std::cos(ps.halfAngleRad);
    const std::vector<EmittedRay> rays = emitRays(src, kRays);
    UniformChiSquare cosBins(20), azimuth(24);
    for (const EmittedRay& r : rays) {
        EXPECT_EQ(r.ray.origin, Vec3(0, 0, -100));
        cosBins.add((1.0 - glm::dot(r.ray.direction, ps.axis)) / oneMinusCosMax);
        azimuth.add(turn(r.ray.direction, ps.axisU, ps.axisV));
    }
    EXPECT_TRUE(cosBins.passes()) << cosBins;
    EXPECT_TRUE(azimuth.passes()) << azimuth;
    expectFluxSumsToTotal(src, rays);
}

// The largest angle from the cone's axis to any of `points` seen from the source, each
// checked to lie inside the cone.
double largestAngleInCone(const PointSource& ps, const std::vector<Vec3>& points) {
    double largest = 0.0;
    for (const Vec3& q : points) {
        const double angle = std::acos(glm::dot(glm::normalize(q - ps.positionMm), ps.axis));
        EXPECT_LE(angle, ps.halfAngleRad) << q;
        largest = std::max(largest, angle);
    }
    return largest;
}

TEST(PointSource, OffAxisConeCoversTheWholeSurfaceTightly) {
    const Scene s(R"(
[[source]]
kind = "point"
position_mm = [15, -10, -40]
margin_mm = 1
)");
    const Source& src = s.only();
    EXPECT_EQ(src.totalFlux(), 1.0);  // default: 1 W into the cone
    const PointSource& ps = std::get<PointSource>(src.shape());
    // The axis lies in the meridional plane of the point (symmetry).
    const Vec3 meridionalNormal = glm::normalize(glm::cross(Vec3(15, -10, 0), Vec3(0, 0, 1)));
    EXPECT_NEAR(glm::dot(ps.axis, meridionalNormal), 0.0, 1e-9);
    const EntranceAperture a = entranceAperture(s.p, s.model);
    const double largest = largestAngleInCone(ps, surfacePoints(a, 14.0, 7200));
    EXPECT_GT(largest, ps.halfAngleRad - 1e-4);  // no cone with this axis is much smaller
}

// A point inside a deep concave front (a meniscus whose first sphere, r = -15 mm, reaches
// 6 mm toward the object at its 12 mm rim): the point 3 mm in front of the vertex is in
// front of the glass, and the cone that covers the surface opens past 90 degrees (the rim
// lies behind the point: 180 - atan(12 / 3) = 104 degrees). Brute force over the surface.
// A point behind the glass at its own radius is refused.
TEST(PointSource, APointInsideAConcaveFrontGetsAConeWiderThanAHemisphere) {
    const std::string bowl = R"([system]
aperture = { epd_mm = 10 }
surfaces = [
  { r = -15, t = 5, glass = { nd = 1.5168, vd = 64.17 }, sd = 12 },
  { r = -15, t = 40, sd = 12 },
]
)";
    const Scene s("[[source]]\nkind = \"point\"\nposition_mm = [0, 0, -3]\n", bowl);
    const PointSource& ps = std::get<PointSource>(s.only().shape());
    EXPECT_GT(ps.halfAngleRad, 90.0 * kDeg);
    const EntranceAperture a = entranceAperture(s.p, s.model);
    const double largest = largestAngleInCone(ps, surfacePoints(a, 12.0, 7200));
    EXPECT_NEAR(largest, kPi - std::atan(12.0 / 3.0), 1e-3);
    EXPECT_LT(ps.halfAngleRad, largest + 1e-3);
    try {
        Scene behind("[[source]]\nkind = \"point\"\nposition_mm = [0, 0, 1]\n", bowl);
        ADD_FAILURE() << "a point inside the glass was taken";
    } catch (const ParseError& e) {  // at the source's table, naming the surface
        EXPECT_NE(std::string(e.what()).find("is not in front of the surface"), std::string::npos)
            << e.what();
    }
}

TEST(PointSource, GivenHalfAngleEmitsIntoThatCone) {
    const Scene s(R"(
[[source]]
kind = "point"
position_mm = [0, 0, 20]
half_angle_deg = 180
intensity_cd = 0.5
)");
    const Source& src = s.only();
    EXPECT_EQ(src.unit(), FluxUnit::Lumen);
    EXPECT_NEAR(src.totalFlux(), 0.5 * 4.0 * kPi, 1e-12);  // the whole sphere
    UniformChiSquare cosBins(20);
    for (const EmittedRay& r : emitRays(src, kRays))
        cosBins.add(0.5 * (1.0 - r.ray.direction.z));  // the axis aims at the surface: -z
    EXPECT_TRUE(cosBins.passes()) << cosBins;
}

// Window (the seed paper's catadioptric illumination)

TEST(WindowSource, SeedWindowIsCosineWeightedInsideTheCone) {
    const Scene s(R"(
[[source]]
name = "window"
kind = "window"
cone_deg = 3.25
flux = 0.079833
unit = "lm"
)");
    const Source& src = s.only();
    EXPECT_EQ(src.unit(), FluxUnit::Lumen);
    EXPECT_EQ(src.totalFlux(), 0.079833);
    const AreaEmitter& e = std::get<WindowSource>(src.shape()).area;
    EXPECT_EQ(e.shape, AreaEmitter::Shape::Disk);
    EXPECT_EQ(e.radiusMm, 12.0);                      // the clear semi-diameter
    EXPECT_NEAR(e.frame.translation.z, -0.1, 1e-15);  // just in front of the vertex

    const double beta = 3.25 * kDeg, sinBetaSq = std::pow(std::sin(beta), 2);
    const std::vector<EmittedRay> rays = emitRays(src, kRays);
    UniformChiSquare cosineLaw(20), azimuth(24), radial(20);
    std::vector<int64_t> perLine(3, 0);
    for (const EmittedRay& r : rays) {
        const Vec3 w = r.ray.direction;
        ASSERT_GT(w.z, std::cos(beta) - 1e-15);
        // Uniform radiance in the cone: sin^2(theta) uniform in [0, sin^2(beta)].
        cosineLaw.add((w.x * w.x + w.y * w.y) / sinBetaSq);
        azimuth.add(turn(w, Vec3(1, 0, 0), Vec3(0, 1, 0)));
        EXPECT_NEAR(r.ray.origin.z, -0.1, 1e-15);
        radial.add((r.ray.origin.x * r.ray.origin.x + r.ray.origin.y * r.ray.origin.y) / 144.0);
        ++perLine.at(r.wavelength);
        EXPECT_EQ(r.wavelengthNm, s.model.wavelengthNm(r.wavelength));
    }
    EXPECT_TRUE(cosineLaw.passes()) << cosineLaw;
    EXPECT_TRUE(azimuth.passes()) << azimuth;
    EXPECT_TRUE(radial.passes()) << radial;
    expectFluxSumsToTotal(src, rays);
    // Lumens are spent in proportion to weight * V(lambda).
    const double wv[3] = {1.0 * photopicEfficiency(486.1327), 2.0 * photopicEfficiency(587.5618),
                          1.0 * photopicEfficiency(656.2725)};
    const double sum = wv[0] + wv[1] + wv[2];
    double chi = 0.0;
    for (int i = 0; i < 3; ++i) {
        const double expected = kRays * wv[i] / sum;
        chi += (perLine[i] - expected) * (perLine[i] - expected) / expected;
    }
    EXPECT_LT(chi, 2.0 + 5.0 * 2.0);
}

// A window with a black spot (veil glare's test field): no radiance, no flux and no
// crossing along the spot's directions; the rest as without it.
TEST(WindowSource, BlackSpotEmitsNothing) {
    AreaEmitter e;
    e.shape = AreaEmitter::Shape::Disk;
    e.radiusMm = 50.0;
    e.coneHalfAngleRad = 80.0 * kDeg;
    e.frame.translation = Vec3(0.0, 0.0, -5.0);
    const Vec3 spot = glm::normalize(Vec3(std::tan(10.0 * kDeg), 0.0, 1.0));
    e.blackSpotAxis = spot;
    e.blackSpotHalfAngleRad = 0.5 * kDeg;
    const Source src("field", WindowSource{e}, 1.0,
                     SpectralSampler({{550.0, 1.0}}, FluxUnit::Watt));
    const Vec3 on(0.0, 0.0, -5.0);
    const Vec3 inside = glm::normalize(spot + Vec3(0.0, 0.004, 0.0));  // 0.23 deg off its axis
    const Vec3 outside = glm::normalize(spot + Vec3(0.0, 0.012, 0.0));
    EXPECT_EQ(src.emitted(on, spot), 0.0);
    EXPECT_EQ(src.emitted(on, inside), 0.0);
    EXPECT_GT(src.emitted(on, outside), 0.0);
    EXPECT_EQ(src.pdf({on, spot}), 0.0);
    EXPECT_FALSE(src.crossing({on + 10.0 * spot, -spot}, 1e9));
    EXPECT_TRUE(src.crossing({on + 10.0 * outside, -outside}, 1e9));
    // Emitted rays into the spot carry nothing; the others the flux the radiance gives.
    CounterRng rng(3, 3);
    int dark = 0;
    for (int i = 0; i < 200000; ++i) {
        const EmittedRay r = src.emit(rng, 1);
        if (e.inBlackSpot(r.ray.direction)) {
            EXPECT_EQ(r.flux, 0.0);
            ++dark;
        } else {
            EXPECT_EQ(r.flux, 1.0);
        }
    }
    // The spot's share of the cone's projected solid angle.
    const double share = std::pow(std::sin(0.5 * kDeg), 2) * std::cos(10.0 * kDeg) /
                         std::pow(std::sin(80.0 * kDeg), 2);
    EXPECT_NEAR(dark, 200000 * share, 5.0 * std::sqrt(200000 * share));
}

// Lambertian Area Sources

TEST(LambertianSource, TiltedRectangleFollowsTheCosineLaw) {
    const Scene s(R"(
[[source]]
name = "panel"
kind = "lambertian"
position_mm = [1, 2, -30]
normal = [0, 1, 1]
x_axis = [1, 0, 0]
size_mm = [4, 2]
radiance_w_mm2_sr = 0.5
)");
    const Source& src = s.only();
    const AreaEmitter& e = std::get<LambertianSource>(src.shape()).area;
    EXPECT_EQ(e.shape, AreaEmitter::Shape::Rectangle);
    EXPECT_NEAR(src.totalFlux(), 0.5 * 8.0 * kPi, 1e-12);  // L A pi
    const Vec3 n = glm::normalize(Vec3(0, 1, 1)), u(1, 0, 0), v = glm::cross(n, u);

    const std::vector<EmittedRay> rays = emitRays(src, kRays);
    UniformChiSquare cosineLaw(20), isotropic(20), azimuth(24), grid(32);
    for (const EmittedRay& r : rays) {
        const double c = glm::dot(r.ray.direction, n);
        ASSERT_GE(c, 0.0);
        cosineLaw.add(c * c);  // cos^2 uniform <=> density proportional to cos
        isotropic.add(c);      // what a uniform hemisphere would give
        azimuth.add(turn(r.ray.direction, u, v));
        const Vec3 o = r.ray.origin - Vec3(1, 2, -30);
        EXPECT_NEAR(glm::dot(o, n), 0.0, 1e-12);
        const double x = glm::dot(o, u) / 4.0 + 0.5, y = glm::dot(o, v) / 2.0 + 0.5;
        ASSERT_TRUE(x >= 0 && x <= 1 && y >= 0 && y <= 1) << o;
        grid.add((std::min(static_cast<int>(x * 8), 7) * 4 + std::min(static_cast<int>(y * 4), 3) +
                  0.5) /
                 32.0);
    }
    EXPECT_TRUE(cosineLaw.passes()) << cosineLaw;
    EXPECT_TRUE(azimuth.passes()) << azimuth;
    EXPECT_TRUE(grid.passes()) << grid;
    EXPECT_GT(isotropic.statistic(), 10.0 * isotropic.threshold()) << isotropic;
    expectFluxSumsToTotal(src, rays);
}

TEST(LambertianSource, DiskWithinAConeAndPhotometricLuminance) {
    const Scene s(R"(
[[source]]
kind = "lambertian"
position_mm = [0, 0, -20]
radius_mm = 3
cone_deg = 30
luminance_cd_mm2 = 2
)");
    const Source& src = s.only();
    EXPECT_EQ(src.unit(), FluxUnit::Lumen);
    // Flux = L A pi sin^2(cone).
    EXPECT_NEAR(src.totalFlux(), 2.0 * kPi * 9.0 * kPi * 0.25, 1e-12);
    UniformChiSquare cosineLaw(20), radial(20);
    const std::vector<EmittedRay> rays = emitRays(src, kRays);
    for (const EmittedRay& r : rays) {
        const Vec3 w = r.ray.direction;
        cosineLaw.add((w.x * w.x + w.y * w.y) / 0.25);
        radial.add((r.ray.origin.x * r.ray.origin.x + r.ray.origin.y * r.ray.origin.y) / 9.0);
        EXPECT_EQ(r.ray.origin.z, -20.0);
    }
    EXPECT_TRUE(cosineLaw.passes()) << cosineLaw;
    EXPECT_TRUE(radial.passes()) << radial;
    expectFluxSumsToTotal(src, rays);
}

// Emission Bookkeeping

TEST(Source, FluxOfAnyRunSumsToTheTotal) {
    const Scene s(R"(
[[source]]
kind = "sun"
field_deg = 7
[[source]]
kind = "window"
cone_deg = 3.25
flux = 0.079833
unit = "lm"
[[source]]
kind = "point"
position_mm = [0, 3, -50]
)");
    ASSERT_EQ(s.sources.size(), 3u);
    for (const Source& src : s.sources)
        for (int n : {1, 7, 100003}) expectFluxSumsToTotal(src, emitRays(src, n, 5));
}

TEST(Source, EmitDrawsAFixedNumberOfUniformsAndIsReproducible) {
    const Scene s(R"(
[[source]]
kind = "collimated"
[[source]]
kind = "lambertian"
position_mm = [0, 0, -20]
radius_mm = 3
)");
    for (const Source& src : s.sources) {
        CounterRng a(9, 42), b(9, 42), c(9, 42);
        const EmittedRay ra = src.emit(a, 10), rb = src.emit(b, 10);
        EXPECT_EQ(ra.ray.origin, rb.ray.origin);
        EXPECT_EQ(ra.ray.direction, rb.ray.direction);
        EXPECT_EQ(ra.wavelength, rb.wavelength);
        for (int i = 0; i < Source::kEmitUniforms; ++i) c.uniform();
        EXPECT_EQ(a.uniform(), c.uniform()) << src.kind();
    }
}

TEST(Source, PrintsItself) {
    const Scene s(R"(
[[source]]
name = "sun"
kind = "sun"
)");
    std::ostringstream os;
    os << s.only();
    EXPECT_NE(os.str().find("Source{sun: sun Beam{"), std::string::npos) << os.str();
    CounterRng rng(1, 1);
    std::ostringstream ray;
    ray << s.only().emit(rng, 1);
    EXPECT_NE(ray.str().find("EmittedRay{"), std::string::npos);
}

// Source Evaluation
//
// emitted() and pdf() against independent truths: Monte Carlo integrals of the radiance over
// (position, direction) pairs drawn by the test itself (uniform over a box around the
// emitting surface, uniform over the sphere or a cone wider than the emission cone), and
// Pearson's chi-square of emit()'s rays against bin probabilities integrated from pdf().

// Sources of every kind with finite radiance (and the two delta kinds), one per table.
const std::string kEvaluatedSources = R"(
[[source]]
name = "sun"
kind = "sun"
field_deg = [2.0, 7.0]
[[source]]
name = "window"
kind = "window"
cone_deg = 3.25
flux = 0.079833
unit = "lm"
[[source]]
name = "disk"
kind = "lambertian"
position_mm = [1, -2, -20]
normal = [0.2, 0, 1]
radius_mm = 3
radiance_w_mm2_sr = 0.5
[[source]]
name = "disk_cone"
kind = "lambertian"
position_mm = [0, 0, -20]
radius_mm = 3
cone_deg = 30
luminance_cd_mm2 = 2
[[source]]
name = "panel"
kind = "lambertian"
position_mm = [1, 2, -30]
normal = [0, 1, 1]
x_axis = [1, 0, 0]
size_mm = [4, 2]
radiance_w_mm2_sr = 0.5
[[source]]
name = "panel_cone"
kind = "lambertian"
position_mm = [1, 2, -30]
normal = [0, -1, 3]
size_mm = [4, 2]
cone_deg = 12
flux = 3
[[source]]
name = "beam"
kind = "collimated"
field_deg = [0.0, 5.0]
[[source]]
name = "lamp"
kind = "point"
position_mm = [0, 3, -50]
[[source]]
name = "bulb"
kind = "point"
position_mm = [0, 0, -50]
half_angle_deg = 60
axis = [0, 1, 1]
)";

// The emitting surface and the direction cone of a source, in its own axes: positions
// centre + x u + y v, directions about n (azimuth from u toward v).
struct EmissionChart {
    enum class Surface { Point, Disk, Rectangle };
    Surface surface = Surface::Point;
    Vec3 centre{0.0}, u{1, 0, 0}, v{0, 1, 0}, n{0, 0, 1};
    double radiusMm = 0.0;
    Vec2 sizeMm{0.0};
    bool deltaDirection = false;
    double coneRad = 0.0;

    double areaMm2() const {
        return surface == Surface::Disk ? kPi * radiusMm * radiusMm : sizeMm.x * sizeMm.y;
    }
    Vec3 point(double x, double y) const { return centre + x * u + y * v; }
    Vec3 direction(double theta, double psi) const {
        return std::sin(theta) * (std::cos(psi) * u + std::sin(psi) * v) + std::cos(theta) * n;
    }
};

EmissionChart chartOf(const Source& s) {
    EmissionChart c;
    std::visit(
        [&](const auto& k) {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, CollimatedSource> || std::is_same_v<T, SunSource>) {
                c.surface = EmissionChart::Surface::Disk;
                c.centre = k.beam.startCenterMm;
                c.u = k.beam.axisU;
                c.v = k.beam.axisV;
                c.n = k.beam.direction;
                c.radiusMm = k.beam.radiusMm;
                c.deltaDirection = std::is_same_v<T, CollimatedSource>;
                c.coneRad = k.beam.halfAngleRad;
            } else if constexpr (std::is_same_v<T, PointSource>) {
                c.centre = k.positionMm;
                c.u = k.axisU;
                c.v = k.axisV;
                c.n = k.axis;
                c.coneRad = k.halfAngleRad;
            } else {
                const AreaEmitter& e = k.area;
                c.surface = e.shape == AreaEmitter::Shape::Disk ? EmissionChart::Surface::Disk
                                                                : EmissionChart::Surface::Rectangle;
                c.centre = e.frame.translation;
                c.u = e.frame.toGlobalDirection(Vec3(1, 0, 0));
                c.v = e.frame.toGlobalDirection(Vec3(0, 1, 0));
                c.n = e.frame.toGlobalDirection(Vec3(0, 0, 1));
                c.radiusMm = e.radiusMm;
                c.sizeMm = e.sizeMm;
                c.coneRad = e.coneHalfAngleRad;
            }
        },
        s.shape());
    return c;
}

// Mean and standard error of a Monte Carlo estimate.
struct Estimate {
    double mean = 0.0, sigma = 0.0;
    double z(double truth) const { return (mean - truth) / sigma; }
};
std::ostream& operator<<(std::ostream& os, const Estimate& e) {
    return os << e.mean << " +- " << e.sigma << " (" << 100.0 * e.sigma / e.mean << " %)";
}
template <class F>
Estimate monteCarlo(int n, F&& sample) {
    double s1 = 0.0, s2 = 0.0;
    for (int i = 0; i < n; ++i) {
        const double x = sample(i);
        s1 += x;
        s2 += x * x;
    }
    const double mean = s1 / n;
    return {mean, std::sqrt(std::max(0.0, s2 / n - mean * mean) / (n - 1))};
}

// The integral of emitted(x, w) cos(theta) over the surface (area measure) and the
// directions (solid angle), from n pairs drawn uniformly over a box 10 % (rectangle) or
// 2.2 radii (disk) wide around the surface and uniformly over the sphere (hemispherical
// emitters) or over a cone 1.5 times as wide as the emission cone. Independent of emit().
Estimate integratedRadiance(const Source& s, int n, uint64_t seed) {
    const EmissionChart c = chartOf(s);
    const Vec2 box =
        c.surface == EmissionChart::Surface::Disk ? Vec2(2.2 * c.radiusMm) : 1.1 * c.sizeMm;
    const bool sphere = c.coneRad >= 0.5 * kPi;
    const double wide = std::min(kPi, 1.5 * c.coneRad);
    const double solidAngle = sphere ? 4.0 * kPi : 2.0 * kPi * (1.0 - std::cos(wide));
    return monteCarlo(n, [&](int i) {
        CounterRng rng(seed, static_cast<uint64_t>(i));
        const Vec3 x = c.point((rng.uniform() - 0.5) * box.x, (rng.uniform() - 0.5) * box.y);
        const double cosT =
            sphere ? 1.0 - 2.0 * rng.uniform() : 1.0 - rng.uniform() * (1.0 - std::cos(wide));
        const Vec3 w = c.direction(std::acos(cosT), 2.0 * kPi * rng.uniform());
        return s.emitted(x, w) * glm::dot(w, c.n) * box.x * box.y * solidAngle;
    });
}

TEST(SourceEvaluation, RadianceIntegratesToTheTotalFlux) {
    const Scene s(kEvaluatedSources);
    uint64_t seed = 77;  // a stream per source, so that their errors are independent
    for (const Source& src : s.sources) {
        if (src.delta() != Source::Delta::None) continue;
        const Estimate e = integratedRadiance(src, 200000, ++seed);
        EXPECT_LT(std::abs(e.z(src.totalFlux())), 4.0) << src << ": " << e;
        EXPECT_LT(e.sigma, 0.01 * src.totalFlux()) << src << ": " << e;
        // Per line: the shares of the spectral sampler.
        const EmissionChart c = chartOf(src);
        const Vec3 x = c.centre, w = c.n;
        double sum = 0.0;
        for (int i = 0; i < src.spectrum().size(); ++i) sum += src.emitted(x, w, i);
        EXPECT_NEAR(sum, src.emitted(x, w), 1e-14 * src.emitted(x, w)) << src;
    }
}

TEST(SourceEvaluation, DeltaKindsGiveIrradianceAndIntensity) {
    const Scene s(kEvaluatedSources);
    int checked = 0;
    for (const Source& src : s.sources) {
        const EmissionChart c = chartOf(src);
        if (src.delta() == Source::Delta::Direction) {
            // Beam: E A = flux analytically, and the integral of E over a box around the
            // start disk (Monte Carlo, positions only: the direction is a delta).
            EXPECT_NEAR(src.emitted(c.centre, c.n) * src.emittingAreaMm2(), src.totalFlux(),
                        1e-12 * src.totalFlux());
            EXPECT_EQ(src.emittingSolidAngleSr(), 0.0);
            const double side = 2.2 * c.radiusMm;
            const Estimate e = monteCarlo(100000, [&](int i) {
                CounterRng rng(31, static_cast<uint64_t>(i));
                const Vec3 x = c.point((rng.uniform() - 0.5) * side, (rng.uniform() - 0.5) * side);
                return src.emitted(x, c.n) * side * side;
            });
            EXPECT_LT(std::abs(e.z(src.totalFlux())), 4.0) << src << ": " << e;
            EXPECT_LT(e.sigma, 0.01 * src.totalFlux()) << e;
            // Any other direction carries nothing.
            EXPECT_EQ(src.emitted(c.centre, glm::normalize(c.n + 1e-6 * c.u)), 0.0);
            ++checked;
        } else if (src.delta() == Source::Delta::Position) {
            // Point: I Omega = flux analytically, and the integral of I over the sphere.
            EXPECT_NEAR(src.emitted(c.centre, c.n) * src.emittingSolidAngleSr(), src.totalFlux(),
                        1e-12 * src.totalFlux());
            EXPECT_EQ(src.emittingAreaMm2(), 0.0);
            const double wide = std::min(kPi, 1.5 * c.coneRad);
            const double omega = 2.0 * kPi * (1.0 - std::cos(wide));
            const Estimate e = monteCarlo(100000, [&](int i) {
                CounterRng rng(37, static_cast<uint64_t>(i));
                const double cosT = 1.0 - rng.uniform() * (1.0 - std::cos(wide));
                const Vec3 w = c.direction(std::acos(cosT), 2.0 * kPi * rng.uniform());
                return src.emitted(c.centre, w) * omega;
            });
            EXPECT_LT(std::abs(e.z(src.totalFlux())), 4.0) << src << ": " << e;
            EXPECT_LT(e.sigma, 0.01 * src.totalFlux()) << e;
            EXPECT_EQ(src.emitted(c.centre + 1e-3 * c.u, c.n), 0.0);  // only from the point
            ++checked;
        }
    }
    EXPECT_EQ(checked, 3);
}

TEST(SourceEvaluation, EveryEmittedRayIsEvaluatedConsistently) {
    const Scene s(kEvaluatedSources);
    for (const Source& src : s.sources) {
        const EmissionChart c = chartOf(src);
        for (const EmittedRay& r : emitRays(src, 2000, 11)) {
            ASSERT_TRUE(src.emits(r.ray)) << src << " " << r;
            // radiance cos / pdf = flux of a ray of a run of one (before the line's weight).
            const double cosT =
                src.delta() == Source::Delta::None ? glm::dot(r.ray.direction, c.n) : 1.0;
            const double flux = src.emitted(r.ray.origin, r.ray.direction) * cosT / src.pdf(r.ray);
            ASSERT_NEAR(flux, src.totalFlux(), 1e-9 * src.totalFlux()) << src << " " << r;
            // Moved off the surface, or turned out of the cone, it is not emitted.
            const double size = std::max(c.radiusMm, std::max(c.sizeMm.x, c.sizeMm.y)) + 1.0;
            const Ray off{r.ray.origin + 1e-6 * size * c.n, r.ray.direction};
            EXPECT_FALSE(src.emits(off)) << src;
            EXPECT_EQ(src.pdf(off), 0.0);
            if (c.coneRad < kPi) {
                const Vec3 out = c.direction(c.coneRad * 1.001 + 1e-6, 1.0);
                EXPECT_FALSE(src.emits({r.ray.origin, out})) << src;
                EXPECT_EQ(src.emitted(r.ray.origin, out), 0.0);
            }
        }
    }
}

// Bins of emit()'s rays: position (rings x 2 half-disks, or a 3 x 3 grid) times direction
// (6 equal polar angles up to the cone x 2 half-turns); each bin's probability integrated
// from pdf() with a midpoint rule of 6 points per coordinate.
class EmissionBins {
  public:
    explicit EmissionBins(const EmissionChart& c) : c_(c) {
        positionBins_ = c.surface == EmissionChart::Surface::Point ? 1 : 8;
        if (c.surface == EmissionChart::Surface::Rectangle) positionBins_ = 9;
        directionBins_ = c.deltaDirection ? 1 : 12;
    }
    int bins() const { return positionBins_ * directionBins_; }

    int binOf(const Ray& r) const {
        int p = 0, d = 0;
        const Vec3 o = r.origin - c_.centre;
        const double x = glm::dot(o, c_.u), y = glm::dot(o, c_.v);
        if (c_.surface == EmissionChart::Surface::Disk) {
            const int ring = std::min(3, static_cast<int>(std::hypot(x, y) / c_.radiusMm * 4));
            p = ring * 2 + (y < 0.0 ? 1 : 0);
        } else if (c_.surface == EmissionChart::Surface::Rectangle) {
            const int i = std::clamp(static_cast<int>((x / c_.sizeMm.x + 0.5) * 3), 0, 2);
            const int j = std::clamp(static_cast<int>((y / c_.sizeMm.y + 0.5) * 3), 0, 2);
            p = i * 3 + j;
        }
        if (!c_.deltaDirection) {
            const Vec3 w = r.direction;
            const double theta = std::atan2(glm::length(glm::cross(w, c_.n)), glm::dot(w, c_.n));
            const int ring = std::min(5, static_cast<int>(theta / c_.coneRad * 6));
            d = ring * 2 + (glm::dot(w, c_.v) < 0.0 ? 1 : 0);
        }
        return p * directionBins_ + d;
    }

    // Probability of every bin: the integral of pdf() over it (area x solid angle).
    std::vector<double> probabilities(const Source& s) const {
        constexpr int m = 6;
        std::vector<double> prob(bins(), 0.0);
        std::vector<std::pair<Vec3, double>> points;  // position, area weight
        if (c_.surface == EmissionChart::Surface::Point) {
            points.push_back({c_.centre, 1.0});
        } else if (c_.surface == EmissionChart::Surface::Disk) {
            const int nr = 4 * m, na = 2 * m;
            const double dr = c_.radiusMm / nr, da = 2.0 * kPi / na;
            for (int i = 0; i < nr; ++i)
                for (int j = 0; j < na; ++j) {
                    const double r = (i + 0.5) * dr, a = (j + 0.5) * da;
                    points.push_back({c_.point(r * std::cos(a), r * std::sin(a)), r * dr * da});
                }
        } else {
            const int n = 3 * m;
            const double dx = c_.sizeMm.x / n, dy = c_.sizeMm.y / n;
            for (int i = 0; i < n; ++i)
                for (int j = 0; j < n; ++j)
                    points.push_back({c_.point(-0.5 * c_.sizeMm.x + (i + 0.5) * dx,
                                               -0.5 * c_.sizeMm.y + (j + 0.5) * dy),
                                      dx * dy});
        }
        std::vector<std::pair<Vec3, double>> dirs;  // direction, solid angle weight
        if (c_.deltaDirection) {
            dirs.push_back({c_.n, 1.0});
        } else {
            const int nt = 6 * m, np = 2 * m;
            const double dt = c_.coneRad / nt, dp = 2.0 * kPi / np;
            for (int i = 0; i < nt; ++i)
                for (int j = 0; j < np; ++j) {
                    const double t = (i + 0.5) * dt, p = (j + 0.5) * dp;
                    dirs.push_back({c_.direction(t, p), std::sin(t) * dt * dp});
                }
        }
        for (const auto& [x, wa] : points)
            for (const auto& [w, wd] : dirs) {
                const Ray r{x, w};
                prob[binOf(r)] += s.pdf(r) * wa * wd;
            }
        return prob;
    }

  private:
    EmissionChart c_;
    int positionBins_ = 1, directionBins_ = 1;
};

// The two strategies of next-event estimation at a view point (tracer/render/backward.cpp
// directAt) weigh one direction w by the balance heuristic: light sampling by
// p_l / (p_l + p_b), bsdf sampling by p_b / (p_b + p_l), p_b the lobe's density. The weights
// sum to one only if both evaluate the same p_l: sampleIncident()'s pdfSr for its own draw,
// and incidentPdf() where a bsdf-sampled ray crosses the emitter. Checked per draw, and
// incidentPdf over the sphere of directions integrates to the share of draws that carry
// light (the density is per draw), by Monte Carlo over a cone about the emitter.
TEST(SourceEvaluation, MisWeightsOfLightAndBsdfSamplingSumToOne) {
    const Scene s(kEvaluatedSources);
    uint64_t seed = 400;
    int kinds = 0;
    for (const Source& src : s.sources) {
        if (src.delta() != Source::Delta::None) continue;
        ++kinds;
        const EmissionChart c = chartOf(src);
        const double extent = c.surface == EmissionChart::Surface::Disk
                                  ? c.radiusMm
                                  : 0.5 * std::hypot(c.sizeMm.x, c.sizeMm.y);
        const double lateral = 0.3 * extent, d = 40.0;
        const Vec3 p = c.centre + d * c.n + lateral * c.u;
        // Light sampling: each draw's density where its ray crosses the emitter.
        CounterRng rng(++seed, 0);
        int valid = 0;
        const int draws = 20000;
        for (int i = 0; i < draws; ++i) {
            const auto in = src.sampleIncident(p, 0, rng.uniform(), rng.uniform());
            if (!in || !(in->value > 0.0)) continue;
            ++valid;
            ASSERT_GT(in->pdfSr, 0.0) << src;
            const auto t = src.crossing({p, in->toSource}, kInfinity);
            ASSERT_TRUE(t) << src << ": the light's own direction misses the emitter";
            const double pb = src.incidentPdf(p, p + *t * in->toSource, in->toSource);
            ASSERT_NEAR(pb, in->pdfSr, 1e-9 * in->pdfSr) << src;
            for (const double lobe : {0.01, 1.0, 300.0})
                ASSERT_NEAR(in->pdfSr / (in->pdfSr + lobe) + lobe / (lobe + pb), 1.0, 1e-12);
        }
        ASSERT_GT(valid, draws / 100) << src;  // the window: its 3.25 degree cone, 3 %
        // The density over a cone of directions about the emitter as seen from p.
        const Vec3 axis = -c.n;
        const double cone = std::min(std::atan((extent + lateral) / d) + 0.02, c.coneRad + 0.01);
        const double solid = 2.0 * kPi * (1.0 - std::cos(cone));
        const Vec3 u = c.u, v = glm::cross(axis, u);
        double sum = 0.0, sum2 = 0.0;
        const int m = 200000;
        for (int i = 0; i < m; ++i) {
            const double z = 1.0 - rng.uniform() * (1.0 - std::cos(cone));
            const double phi = 2.0 * kPi * rng.uniform(), r = std::sqrt(1.0 - z * z);
            const Vec3 w = z * axis + r * (std::cos(phi) * u + std::sin(phi) * v);
            const auto t = src.crossing({p, w}, kInfinity);
            const double x = t ? src.incidentPdf(p, p + *t * w, w) * solid : 0.0;
            sum += x;
            sum2 += x * x;
        }
        const double mean = sum / m, sigma = std::sqrt((sum2 / m - mean * mean) / (m - 1));
        const double share = static_cast<double>(valid) / draws;
        const double shareSigma = std::sqrt(share * (1.0 - share) / draws);
        EXPECT_LT(std::abs(mean - share), 4.0 * std::hypot(sigma, shareSigma) + 1e-3)
            << src << ": the density integrates to " << mean << " +- " << sigma << ", " << share
            << " of the draws carry light";
    }
    EXPECT_EQ(kinds, 6);  // the sun, the window and four Lambertian emitters
}

TEST(SourceEvaluation, EmitFollowsThePdf) {
    const Scene s(kEvaluatedSources);
    for (const Source& src : s.sources) {
        const EmissionBins bins(chartOf(src));
        const std::vector<double> prob = bins.probabilities(src);
        double total = 0.0;
        for (double p : prob) total += p;
        EXPECT_NEAR(total, 1.0, 2e-3) << src;  // pdf() is normalised (midpoint rule error)
        const int n = 100000;
        std::vector<int64_t> counts(bins.bins(), 0);
        for (const EmittedRay& r : emitRays(src, n, 2026)) ++counts[bins.binOf(r.ray)];
        double chi = 0.0;
        for (int b = 0; b < bins.bins(); ++b) {
            const double e = n * prob[b] / total;
            ASSERT_GT(e, 20.0) << src << " bin " << b;
            chi += (counts[b] - e) * (counts[b] - e) / e;
        }
        const double dof = bins.bins() - 1;
        EXPECT_LT(chi, dof + 5.0 * std::sqrt(2.0 * dof))
            << src << ": chi2 " << chi << " over " << bins.bins() << " bins";
    }
}

TEST(SourceEvaluation, DeltaKindPrints) {
    std::ostringstream os;
    os << Source::Delta::Direction << " " << Source::Delta::Position << " " << Source::Delta::None;
    EXPECT_EQ(os.str(), "direction position none");
}

// Reading [[source]]

// The scene text's error, with the line counted from the first line after the lens.
void expectError(const std::string& sources, const std::string& fragment, int sourceLine,
                 const std::string& lens = kLens) {
    try {
        Scene s(sources, lens);
        ADD_FAILURE() << "no error; expected: " << fragment;
    } catch (const ParseError& e) {
        EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
        if (sourceLine > 0) {
            EXPECT_EQ(e.loc().line, kLensLines + sourceLine) << e.what();
        }
        EXPECT_EQ(e.loc().file, "scene.toml");
    }
}

TEST(ReadSources, NoSourcesIsAnEmptyList) { EXPECT_TRUE(Scene("").sources.empty()); }

TEST(ReadSources, ReportsErrorsAtTheKeyAtFault) {
    expectError("[[source]]\nkind = \"laser\"\n", "unknown source kind 'laser'", 2);
    expectError("[[source]]\nname = \"sun\"\n", "missing key 'kind'", 1);
    expectError("[[source]]\nkind = \"sun\"\nflux = 1\nirradiance_w_mm2 = 2\n",
                "not both 'flux' and 'irradiance_w_mm2'", 4);
    expectError("[[source]]\nkind = \"collimated\"\nintensity_cd = 1\n",
                "'intensity_cd' does not apply to a collimated source", 3);
    expectError("[[source]]\nkind = \"sun\"\nunit = \"W\"\nilluminance_lm_mm2 = 2\n",
                "is \"W\" but 'illuminance_lm_mm2' is in lm", 3);
    expectError("[[source]]\nkind = \"sun\"\nunit = \"lux\"\n", "must be \"W\"", 3);
    expectError("[[source]]\nkind = \"sun\"\nflux = 0\n", "must be > 0", 3);
    expectError("[[source]]\nkind = \"window\"\n", "missing key 'cone_deg'", 1);
    expectError("[[source]]\nkind = \"window\"\ncone_deg = 0\n", "cone_deg", 3);
    expectError("[[source]]\nkind = \"sun\"\nfield_deg = [1, 2, 3]\n", "a pair [x, y]", 3);
    expectError("[[source]]\nkind = \"sun\"\nfield_deg = 90\n", "strictly between -90 and 90", 3);
    expectError("[[source]]\nkind = \"point\"\nposition_mm = [0, 0, 10]\n",
                "not in front of the surface", 1);
    expectError("[[source]]\nkind = \"point\"\nposition_mm = [0, 0]\n", "[x, y, z]", 3);
    expectError(
        "[[source]]\nkind = \"lambertian\"\nposition_mm = [0, 0, -5]\nradius_mm = 1\n"
        "size_mm = [1, 1]\n",
        "not both", 5);
    expectError("[[source]]\nkind = \"lambertian\"\nposition_mm = [0, 0, -5]\n",
                "'radius_mm' (a disk) or 'size_mm'", 1);
    expectError(
        "[[source]]\nkind = \"lambertian\"\nposition_mm = [0, 0, -5]\nradius_mm = 1\n"
        "normal = [0, 0, 1]\nx_axis = [0, 0, 2]\n",
        "must not be parallel to the normal", 6);
    expectError("[[source]]\nkind = \"sun\"\nsampling = \"spectral\"\n", "\"radiometric\"", 3);
    expectError("[[source]]\nname = \"my sun\"\nkind = \"sun\"\n", "letters, digits", 2);
}

// Lengths beyond 1e9 mm are refused at the value (rays starting beyond ~1e18 mm once aborted
// inside Embree): the issue's inputs, and the limit itself accepted.
TEST(ReadSources, LengthsAreBounded) {
    const std::string within = "1e9";
    expectError("[[source]]\nkind = \"point\"\nposition_mm = [0, 0, -1e19]\n",
                "must be between -1e+09 and 1e+09 (got -1e+19)", 3);
    expectError("[[source]]\nkind = \"collimated\"\nstart_gap_mm = 1e19\n",
                "must be between 0 and 1e+09 (got 1e+19)", 3);
    expectError("[[source]]\nkind = \"sun\"\nmargin_mm = 5e299\n", "between 0 and", 3);
    expectError(
        "[[source]]\nkind = \"lambertian\"\nposition_mm = [0, 0, -5]\nsize_mm = [2e301, 10]\n",
        "size_mm", 4);
    expectError(
        "[[source]]\nkind = \"lambertian\"\nposition_mm = [0, 0, -5]\nradius_mm = 1\n"
        "normal = [0, 1e300, 1]\n",
        "normal", 5);
    EXPECT_NO_THROW(Scene("[[source]]\nkind = \"point\"\nposition_mm = [0, 0, -" + within + "]\n"));
}

TEST(ReadSources, NamesAreUnique) {
    expectError("[[source]]\nkind = \"sun\"\n[[source]]\nkind = \"sun\"\n",
                "source name 'sun' is already used at scene.toml:8", 3);
    expectError(
        "[[source]]\nname = \"a\"\nkind = \"sun\"\n[[source]]\nname = \"a\"\nkind = "
        "\"collimated\"\n",
        "already used", 5);
}

TEST(ReadSources, UnknownKeysAreLeftForTheUnusedKeyCheck) {
    expectError("[[source]]\nkind = \"sun\"\nfeild_deg = 7\n", "did you mean 'field_deg'?", 3);
    // A key of another kind is unknown here too.
    expectError("[[source]]\nkind = \"sun\"\ncone_deg = 3\n", "unknown key 'cone_deg'", 3);
}

TEST(ReadSources, SingleTableIsRefused) {
    expectError("[source]\nkind = \"sun\"\n", "write [[source]]", 0);
}

TEST(ReadSources, ModelProblemsNameTheSource) {
    // Without semi-diameters there is no aperture to fill.
    const std::string bare = R"([system]
aperture = { epd_mm = 10 }
surfaces = [ { r = 50, t = 5, glass = { nd = 1.5, vd = 60 } }, { r = -50, t = 40 } ]
)";
    try {
        Scene s("[[source]]\nname = \"beam\"\nkind = \"collimated\"\n", bare);
        FAIL();
    } catch (const ParseError& e) {
        EXPECT_NE(std::string(e.what()).find("source 'beam': L1.front: has no semi-diameter"),
                  std::string::npos)
            << e.what();
    }
    // ... unless the source says how wide its beam is.
    const Scene ok("[[source]]\nkind = \"collimated\"\nradius_mm = 4\n", bare);
    EXPECT_NEAR(std::get<CollimatedSource>(ok.only().shape()).beam.radiusMm, 4.0, 1e-12);
    // Lumens from a lens that only has infrared wavelengths.
    const std::string infrared = R"([system]
wavelengths_nm = [1064]
aperture = { epd_mm = 10 }
surfaces = [ { r = 50, t = 5, glass = { nd = 1.5, vd = 60 }, sd = 6 }, { r = -50, t = 40 } ]
)";
    expectError("[[source]]\nkind = \"sun\"\nunit = \"lm\"\n", "where the eye sees", 0, infrared);
    EXPECT_NO_THROW(Scene("[[source]]\nkind = \"sun\"\n", infrared));
}

// The example of docs/format.md, section [[source]], read from the document itself.
TEST(ReadSources, DocumentedExampleReads) {
    std::ifstream in(fs::path(VEIL_SOURCE_DIR) / "docs" / "format.md");
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string doc = ss.str();
    const size_t section = doc.find("## `[[source]]`");
    ASSERT_NE(section, std::string::npos) << "no [[source]] section in docs/format.md";
    const size_t begin = doc.find("```toml\n", section);
    const size_t end = doc.find("```\n", begin + 8);
    ASSERT_NE(begin, std::string::npos);
    ASSERT_NE(end, std::string::npos);
    const Scene s(doc.substr(begin + 8, end - begin - 8));
    ASSERT_EQ(s.sources.size(), 5u);
    EXPECT_EQ(s.sources[0].name(), "sun");
    EXPECT_STREQ(s.sources[0].kind(), "sun");
    EXPECT_EQ(s.sources[1].name(), "window");
    EXPECT_EQ(s.sources[1].unit(), FluxUnit::Lumen);
    EXPECT_EQ(s.sources[1].totalFlux(), 0.079833);
    EXPECT_STREQ(s.sources[2].kind(), "collimated");
    EXPECT_STREQ(s.sources[3].kind(), "point");
    EXPECT_STREQ(s.sources[4].kind(), "lambertian");
}

}  // namespace
}  // namespace veil
