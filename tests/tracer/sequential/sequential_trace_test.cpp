// Real-ray sequential trace: paraxial limit, Snell's law, mirrors, failure statuses.

#include "tracer/sequential/sequential_trace.h"

#include <gtest/gtest.h>

#include <cmath>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tests/test_lenses.h"
#include "tracer/sequential/paraxial.h"
#include "tracer/sequential/pupil.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {
namespace {

using test::finishLens;
using test::startLens;
using test::surface;

const GlassCatalog kNoCatalog;

// A strongly curved triplet-like stack with an asphere and a conic: a real system with
// spherical aberration, so agreement at small heights is a real check of the limit.
SequentialModel testStack() {
    Prescription p = startLens(kInfinity, 20.0);
    Surface s1 = surface(40.0, 6.0, Material::model(1.62, 58.0));
    s1.conic = -0.6;
    p.surfaces.push_back(s1);
    p.surfaces.push_back(surface(-150.0, 5.0));
    Surface stop = surface(0.0, 4.0);
    stop.stop = true;
    p.surfaces.push_back(stop);
    Surface s4 = surface(-35.0, 2.0, Material::model(1.72, 29.0));
    s4.asphere[1] = 2e-6;
    s4.asphere[2] = -1e-9;
    p.surfaces.push_back(s4);
    p.surfaces.push_back(surface(35.0, 6.0));
    p.surfaces.push_back(surface(120.0, 5.0, Material::model(1.62, 58.0)));
    p.surfaces.push_back(surface(-45.0, 60.0));
    finishLens(p);
    return SequentialModel::build(p, kNoCatalog);
}

// A Qbfs face changes the vertex curvature (its departure has an r^2 term; Qcon's starts at
// r^4): the paraxial trace takes it, so real rays of tiny height still reproduce it.
TEST(SequentialTrace, QTypeFacesKeepTheParaxialLimit) {
    for (const QAsphere::Kind kind : {QAsphere::Kind::Bfs, QAsphere::Kind::Con}) {
        Prescription p = startLens(kInfinity, 10.0);
        Surface front = surface(50.0, 5.0, Material::model(1.6, 0.0));
        front.qAsphere = QAsphere{kind, 8.0, {0.02, -0.006, 0.003}};
        front.stop = true;
        p.surfaces.push_back(front);
        p.surfaces.push_back(surface(-80.0, 60.0));
        finishLens(p);
        const SequentialModel m = SequentialModel::build(p, kNoCatalog);
        const double extra = paraxialCurvature(p.surfaces[1]) - 1.0 / 50.0;
        if (kind == QAsphere::Kind::Bfs)
            EXPECT_GT(std::abs(extra), 1e-4);  // 2 (0.02 + ...) / 8^2 away from 1/50
        else
            EXPECT_EQ(extra, 0.0);
        const int last = m.imageIndex() - 1;
        const ParaxialRay par = traceParaxial(m, 0, 1, last, 1.0, 0.0);
        const double parSlope = par.nu[last] / m.index(last, 0);
        const double h = 1e-5;
        SequentialTraceOptions o;
        o.lastSurface = last;
        const SequentialRayResult r =
            traceSequential(m, 0, Ray{Vec3(0.0, h, -10.0), Vec3(0.0, 0.0, 1.0)}, o);
        ASSERT_TRUE(r.ok()) << r;
        const double slope = r.ray.direction.y / r.ray.direction.z;
        EXPECT_NEAR(slope / h, parSlope, 1e-7 * std::abs(parSlope));
    }
}

// Real rays of tiny height reproduce the paraxial ray: heights and slopes at the last
// surface agree to 1e-9 relative once scaled by the ray height.
TEST(SequentialTrace, RealRaysConvergeToParaxialInTheLimit) {
    const SequentialModel m = testStack();
    const int last = m.imageIndex() - 1;
    const ParaxialRay par = traceParaxial(m, 0, 1, last, 1.0, 0.0);  // y = 1, parallel
    const double parSlope = par.nu[last] / m.index(last, 0);
    for (double h : {1e-4, -3e-4, 2e-5}) {
        const Ray in{Vec3(0.0, h, -10.0), Vec3(0.0, 0.0, 1.0)};
        SequentialTraceOptions o;
        o.lastSurface = last;
        const SequentialRayResult r = traceSequential(m, 0, in, o);
        ASSERT_TRUE(r.ok()) << r;
        // Compare at the vertex plane of the last surface (the paraxial ray lives there).
        const double zv = m.surface(last).zMm;
        const Vec3 d = r.ray.direction;
        const double yAtVertex = r.ray.origin.y + (zv - r.ray.origin.z) * d.y / d.z;
        EXPECT_NEAR(yAtVertex / h, par.y[last], 1e-9 * std::abs(par.y[last]));
        EXPECT_NEAR((d.y / d.z) / h, parSlope, 1e-9 * std::abs(parSlope));
    }
    // Field direction: a tiny angle through the pupil centre follows the paraxial chief ray.
    const PupilData pupil = computePupil(m, 0);
    const double u = 1e-7;
    const ParaxialRay chief =
        traceParaxial(m, 0, 1, last, -pupil.entrancePupilZMm * u, m.index(0, 0) * u);
    const Vec3 dir = glm::normalize(Vec3(0.0, u, 1.0));
    const Ray in{Vec3(0.0, 0.0, pupil.entrancePupilZMm), dir};
    SequentialTraceOptions o;
    o.lastSurface = last;
    const SequentialRayResult r = traceSequential(m, 0, in, o);
    ASSERT_TRUE(r.ok());
    const double zv = m.surface(last).zMm;
    const Vec3 d = r.ray.direction;
    const double yAtVertex = r.ray.origin.y + (zv - r.ray.origin.z) * d.y / d.z;
    EXPECT_NEAR(yAtVertex, chief.y[last], 1e-9 * std::abs(chief.y[last]));
}

// Snell's law at a flat interface, exactly, including the TIR threshold.
TEST(SequentialTrace, RefractionObeysSnellAndReportsTir) {
    const Vec3 nrm(0.0, 0.0, 1.0);
    for (double deg : {0.0, 10.0, 30.0, 45.0, 60.0, 89.0}) {
        const double a = deg * M_PI / 180.0;
        const Vec3 d(std::sin(a), 0.0, std::cos(a));
        const auto out = refract(d, nrm, 1.0, 1.5);
        ASSERT_TRUE(out);
        EXPECT_NEAR(out->x * 1.5, std::sin(a), 1e-15);
        EXPECT_NEAR(glm::length(*out), 1.0, 1e-15);
        EXPECT_GT(out->z, 0.0);
    }
    const double critical = std::asin(1.0 / 1.5);
    const Vec3 below(std::sin(critical - 1e-9), 0.0, std::cos(critical - 1e-9));
    const Vec3 above(std::sin(critical + 1e-9), 0.0, std::cos(critical + 1e-9));
    EXPECT_TRUE(refract(below, nrm, 1.5, 1.0));
    EXPECT_FALSE(refract(above, nrm, 1.5, 1.0));
}

TEST(SequentialTrace, StatusesForTirClippingAndMisses) {
    // A glass block whose exit face is a strong sphere: steep rays suffer TIR at it.
    Prescription p = startLens(kInfinity, 2.0);
    Surface s1 = surface(0.0, 10.0, Material::model(1.9, 30.0));
    s1.clearSemiDiameterMm = 5.0;
    p.surfaces.push_back(s1);
    Surface s2 = surface(6.0, 10.0);
    s2.stop = true;  // the stop never vignettes: the system aperture sets its size
    s2.clearSemiDiameterMm = 1.0;
    p.surfaces.push_back(s2);
    finishLens(p);
    const SequentialModel m = SequentialModel::build(p, kNoCatalog);
    EXPECT_TRUE(m.surface(1).vignettes);
    EXPECT_FALSE(m.surface(2).vignettes);
    // Clipped: outside surface 1's 5 mm semi-diameter.
    auto r = traceSequential(m, 0, {Vec3(0.0, 5.5, -1.0), Vec3(0.0, 0.0, 1.0)});
    EXPECT_EQ(r.status, RayStatus::Clipped);
    EXPECT_EQ(r.surface, 1);
    // Exactly on the edge counts as inside.
    r = traceSequential(m, 0, {Vec3(0.0, 5.0, -1.0), Vec3(0.0, 0.0, 1.0)});
    EXPECT_NE(r.status, RayStatus::Clipped);
    // TIR at the sphere: at height 4.8 on a 6 mm radius the incidence is asin(0.8) > the
    // critical angle asin(1/1.9).
    r = traceSequential(m, 0, {Vec3(0.0, 4.8, -1.0), Vec3(0.0, 0.0, 1.0)});
    EXPECT_EQ(r.status, RayStatus::TotalInternalReflection);
    EXPECT_EQ(r.surface, 2);
    // Missed: beyond the sphere's 6 mm radius.
    SequentialTraceOptions noClip;
    noClip.clipApertures = false;
    r = traceSequential(m, 0, {Vec3(0.0, 6.5, -1.0), Vec3(0.0, 0.0, 1.0)}, noClip);
    EXPECT_EQ(r.status, RayStatus::Missed);
    EXPECT_EQ(r.surface, 2);
    r = traceSequential(m, 0, {Vec3(0.0), Vec3(0.0)});
    EXPECT_EQ(r.status, RayStatus::Invalid);
}

// A parabolic mirror focuses every ray parallel to its axis at f = r/2 exactly.
TEST(SequentialTrace, ParaboloidFocusesAllParallelRaysExactly) {
    const double r = -400.0;
    Prescription p = startLens(kInfinity, 150.0);
    Surface m1 = surface(r, r / 2.0);
    m1.conic = -1.0;
    m1.mirror = true;
    m1.stop = true;
    p.surfaces.push_back(m1);
    finishLens(p);
    const SequentialModel m = SequentialModel::build(p, kNoCatalog);
    for (double h : {1.0, 20.0, 50.0, 75.0}) {
        const auto res = traceSequential(m, 0, {Vec3(0.0, h, -50.0), Vec3(0.0, 0.0, 1.0)});
        ASSERT_TRUE(res.ok()) << res;
        EXPECT_NEAR(res.ray.origin.y, 0.0, 1e-11) << "h = " << h;
        EXPECT_NEAR(res.ray.origin.z, r / 2.0, 1e-12);
        EXPECT_LT(res.ray.direction.z, 0.0);
    }
}

// A paraboloid primary with a central hole of 10 mm: rays parallel to the axis inside the
// hole are Clipped at the mirror, on the hole's edge and outside they reach the focus. The
// hole clips even where the outer semi-diameter does not (a computed one), and not at all
// without aperture clipping.
TEST(SequentialTrace, CentralHoleClipsLikeTheOuterEdge) {
    const double r = -400.0;
    Prescription p = startLens(kInfinity, 100.0);
    Surface stop = surface(0.0, 50.0);
    stop.stop = true;
    stop.clearSemiDiameterMm = 50.0;
    p.surfaces.push_back(stop);
    Surface m1 = surface(r, r / 2.0);
    m1.conic = -1.0;
    m1.mirror = true;
    m1.clearSemiDiameterMm = 50.0;
    m1.innerSemiDiameterMm = 10.0;
    p.surfaces.push_back(m1);
    finishLens(p);
    SequentialModel m = SequentialModel::build(p, kNoCatalog);
    ASSERT_EQ(m.surface(2).innerSemiDiameterMm, 10.0);
    ASSERT_TRUE(m.surface(2).vignettes);
    auto trace = [&](const SequentialModel& model, double h, bool clip = true) {
        SequentialTraceOptions o;
        o.clipApertures = clip;
        return traceSequential(model, 0, {Vec3(0.0, h, -10.0), Vec3(0.0, 0.0, 1.0)}, o);
    };
    for (double h : {0.0, 5.0, -9.999, 9.999}) {
        const auto res = trace(m, h);
        EXPECT_EQ(res.status, RayStatus::Clipped) << "h = " << h;
        EXPECT_EQ(res.surface, 2) << "h = " << h;
        // Stopped on the mirror, inside the hole (the paraboloid's sag z = -h^2 / 800).
        EXPECT_NEAR(res.ray.origin.z, 50.0 - h * h / 800.0, 1e-12);
    }
    for (double h : {10.0, -10.0, 10.001, 30.0, 50.0}) {
        const auto res = trace(m, h);
        ASSERT_TRUE(res.ok()) << "h = " << h << ": " << res;
        EXPECT_NEAR(res.ray.origin.y, 0.0, 1e-11) << "h = " << h;  // at the focus
    }
    EXPECT_EQ(trace(m, 50.001).status, RayStatus::Clipped);  // the outer edge still clips
    EXPECT_TRUE(trace(m, 5.0, false).ok());                  // no clipping: no hole either

    // A computed outer semi-diameter does not vignette; the hole, always given, still does.
    p.surfaces[2].semiDiameterAutomatic = true;
    m = SequentialModel::build(p, kNoCatalog);
    EXPECT_FALSE(m.surface(2).vignettes);
    EXPECT_EQ(trace(m, 5.0).status, RayStatus::Clipped);
    EXPECT_TRUE(trace(m, 60.0).ok());
}

// Real aiming puts the chief ray through the centre of the real stop.
TEST(SequentialTrace, RealAimingHitsTheStopCentre) {
    const SequentialModel m = testStack();
    const RayAimer aimer(m, AimMode::Real);
    SequentialTraceOptions o;
    o.lastSurface = m.stopIndex();
    o.clipApertures = false;
    for (double fy : {5.0, 12.0, 20.0}) {
        const AimedRay a = aimer.aim(0.0, fy, 0.0, 0.0, 0);
        ASSERT_EQ(a.status, RayStatus::Ok) << fy;
        const auto r = traceSequential(m, 0, a.ray, o);
        ASSERT_TRUE(r.ok());
        EXPECT_NEAR(r.ray.origin.x, 0.0, 1e-10);
        EXPECT_NEAR(r.ray.origin.y, 0.0, 1e-10);
        // Marginal rays land on the stop edge.
        const AimedRay top = aimer.aim(0.0, fy, 0.0, 1.0, 0);
        const auto rt = traceSequential(m, 0, top.ray, o);
        ASSERT_TRUE(rt.ok());
        EXPECT_NEAR(rt.ray.origin.y, aimer.pupil().stopRadiusMm, 1e-9);
    }
}

}  // namespace
}  // namespace veil
