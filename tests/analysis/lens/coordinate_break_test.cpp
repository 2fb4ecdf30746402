// Coordinate breaks in the sequential model and trace, against hand-computed geometry:
// the break's axes and its inverse, a tilted plate's lateral shift, a fold mirror's image
// position, a decentered lens's boresight error.

#include <gtest/gtest.h>

#include <cmath>

#include "analysis/lens/first_order.h"
#include "geometry/surface_frames.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tests/test_lenses.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {
namespace {

using test::finishLens;
using test::startLens;
using test::surface;

const GlassCatalog kNoCatalog;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

Surface coordinateBreak(CoordinateBreak b, double thicknessMm, Material m = Material::air()) {
    Surface s;
    s.coordinateBreak = b;
    s.thicknessMm = thicknessMm;
    s.material = m;
    return s;
}

CoordinateBreak tilt(double xDeg, double yDeg, double zDeg, bool tiltFirst = false) {
    CoordinateBreak b;
    b.tiltXDeg = xDeg;
    b.tiltYDeg = yDeg;
    b.tiltZDeg = zDeg;
    b.tiltFirst = tiltFirst;
    return b;
}

CoordinateBreak decenter(double xMm, double yMm, bool tiltFirst = false) {
    CoordinateBreak b;
    b.decenterXMm = xMm;
    b.decenterYMm = yMm;
    b.tiltFirst = tiltFirst;
    return b;
}

void expectNear(const Vec3& a, const Vec3& b, double tol) {
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

// The sign conventions of lens design programs: +x tilt turns z toward +y, +y tilt turns z
// toward -x, +z tilt turns x toward +y.
TEST(CoordinateBreak, AxesFollowTheLensDesignConvention) {
    const double a = 30.0, s = std::sin(a * kDeg), c = std::cos(a * kDeg);
    const Frame fx = breakFrame(Frame{}, tilt(a, 0, 0));
    expectNear(fx.rotation[2], Vec3(0.0, s, c), 1e-15);
    const Frame fy = breakFrame(Frame{}, tilt(0, a, 0));
    expectNear(fy.rotation[2], Vec3(-s, 0.0, c), 1e-15);
    const Frame fz = breakFrame(Frame{}, tilt(0, 0, a));
    expectNear(fz.rotation[0], Vec3(c, s, 0.0), 1e-15);
    // Order 0 decenters along the incoming axes, order 1 along the tilted ones.
    CoordinateBreak both = tilt(90.0, 0, 0);
    both.decenterYMm = 2.0;
    expectNear(breakFrame(Frame{}, both).translation, Vec3(0.0, 2.0, 0.0), 1e-15);
    both.tiltFirst = true;
    expectNear(breakFrame(Frame{}, both).translation, Vec3(0.0, 0.0, -2.0), 1e-15);
}

// A break with every value negated and the order flipped undoes it (both orders), and the
// frames stay orthonormal.
TEST(CoordinateBreak, NegatedBreakWithFlippedOrderIsTheInverse) {
    for (bool first : {false, true}) {
        CoordinateBreak b = tilt(12.5, -40.0, 77.0, first);
        b.decenterXMm = 3.25;
        b.decenterYMm = -1.5;
        CoordinateBreak inv = tilt(-12.5, 40.0, -77.0, !first);
        inv.decenterXMm = -3.25;
        inv.decenterYMm = 1.5;
        Frame start;
        start.rotation = breakFrame(Frame{}, tilt(5.0, 6.0, 7.0)).rotation;
        start.translation = Vec3(1.0, 2.0, 3.0);
        const Frame f = breakFrame(start, b);
        const glm::dmat3 rtr = glm::transpose(f.rotation) * f.rotation;
        for (int i = 0; i < 3; ++i)
            for (int j = 0; j < 3; ++j) EXPECT_NEAR(rtr[i][j], i == j ? 1.0 : 0.0, 1e-15);
        const Frame back = breakFrame(f, inv);
        for (int i = 0; i < 3; ++i) expectNear(back.rotation[i], start.rotation[i], 1e-15);
        expectNear(back.translation, start.translation, 1e-14);
    }
}

// A plane-parallel plate of thickness T and index n tilted by theta shifts a ray along the
// old axis sideways by T sin(theta) (1 - cos(theta) / sqrt(n^2 - sin^2(theta))), toward
// the side the plate's normal turned to, and leaves its direction unchanged.
TEST(CoordinateBreak, TiltedPlateShiftsTheRayByTheTextbookAmount) {
    const double T = 10.0, n = 1.5;
    for (double theta : {5.0, 30.0, 60.0}) {
        for (int axis : {0, 1}) {
            Prescription p = startLens(kInfinity, 4.0);
            p.surfaces.push_back(surface(0.0, 20.0));  // dummy: the plate sits 20 mm behind it
            p.surfaces.push_back(
                coordinateBreak(axis == 0 ? tilt(theta, 0, 0) : tilt(0, theta, 0), 0.0));
            p.surfaces.push_back(surface(0.0, T, Material::model(n, 0.0)));
            p.surfaces.push_back(surface(0.0, 0.0));
            p.surfaces.push_back(coordinateBreak(
                axis == 0 ? tilt(-theta, 0, 0, true) : tilt(0, -theta, 0, true), 30.0));
            finishLens(p);
            const SequentialModel m = SequentialModel::build(p, kNoCatalog);
            EXPECT_FALSE(m.coaxial());
            for (double h : {0.0, 0.7}) {
                const Ray in{Vec3(h, h, -5.0), Vec3(0.0, 0.0, 1.0)};
                const SequentialRayResult r = traceSequential(m, 0, in);
                ASSERT_TRUE(r.ok()) << r;
                const double t = theta * kDeg;
                const double shift =
                    T * std::sin(t) *
                    (1.0 - std::cos(t) / std::sqrt(n * n - std::sin(t) * std::sin(t)));
                // Globally: the old axis is the global z axis.
                const Vec3 q = r.ray.origin;
                EXPECT_NEAR(q.x, axis == 0 ? h : h - shift, 1e-12);
                EXPECT_NEAR(q.y, axis == 0 ? h + shift : h, 1e-12);
                expectNear(r.ray.direction, Vec3(0.0, 0.0, 1.0), 1e-14);
                // The plate's thickness runs along its own axis: the image vertex is at
                // z = 20 + T cos(theta) + 30, displaced by T sin(theta) sideways.
                const Vec3 v = m.surface(m.imageIndex()).frame.translation;
                const Vec3 vExpected = axis == 0
                                           ? Vec3(0.0, T * std::sin(t), 50.0 + T * std::cos(t))
                                           : Vec3(-T * std::sin(t), 0.0, 50.0 + T * std::cos(t));
                expectNear(v, vExpected, 1e-12);
            }
        }
    }
}

// A concave paraboloid (R = -200 mm) images an axial collimated beam perfectly at its focus,
// 100 mm in front of it. A flat mirror 40 mm in front of the paraboloid, tilted 45 degrees
// about x, folds the beam: the focus is the mirror image of (0, 0, -100) in the fold plane,
// (0, 60, -40), and the image surface, 60 mm along the folded axis, is there.
TEST(CoordinateBreak, FoldMirrorPutsTheImageWhereTheFoldedFocusIs) {
    Prescription p = startLens(kInfinity, 40.0);
    Surface primary = surface(-200.0, -40.0);
    primary.conic = -1.0;
    primary.mirror = true;
    primary.stop = true;
    p.surfaces.push_back(primary);
    p.surfaces.push_back(coordinateBreak(tilt(45.0, 0, 0), 0.0));
    Surface fold = surface(0.0, 0.0);
    fold.mirror = true;
    p.surfaces.push_back(fold);
    p.surfaces.push_back(coordinateBreak(tilt(45.0, 0, 0), 60.0));
    finishLens(p);
    const SequentialModel m = SequentialModel::build(p, kNoCatalog);
    const int img = m.imageIndex();
    expectNear(m.surface(img).frame.translation, Vec3(0.0, 60.0, -40.0), 1e-12);
    expectNear(m.surface(img).frame.rotation[2], Vec3(0.0, 1.0, 0.0), 1e-15);
    // Light travels +y after the second mirror: along the image's +z, as the +60 mm says.
    EXPECT_EQ(m.direction(img - 1), 1.0);
    for (double y : {-18.0, -5.0, 0.0, 3.0, 19.5})
        for (double x : {-7.0, 0.0, 11.0}) {
            const SequentialRayResult r =
                traceSequential(m, 0, Ray{Vec3(x, y, -10.0), Vec3(0.0, 0.0, 1.0)});
            ASSERT_TRUE(r.ok()) << r;
            expectNear(r.ray.origin, Vec3(0.0, 60.0, -40.0), 1e-11);
            // It left the paraboloid toward -z and the fold toward +y.
            EXPECT_GT(r.ray.direction.y, 0.0);
        }
    // First-order data ignore the fold: the paraboloid's EFL (100 mm, negative by the sign
    // convention of a single mirror) and the image 60 mm beyond the fold at its focus.
    const FirstOrderData fo = computeFirstOrder(m, 0);
    EXPECT_NEAR(std::abs(fo.eflMm), 100.0, 1e-9);
    EXPECT_NEAR(fo.paraxialImageDistanceMm, 0.0, 1e-9);
    // The aimed chief ray finds the stop on the paraboloid and lands at the image centre.
    const RayAimer aimer(m, AimMode::Real);
    const AimedRay chief = aimer.aim(0.0, 0.0, 0.0, 0.0, 0);
    ASSERT_EQ(chief.status, RayStatus::Ok);
    const SequentialRayResult rc = traceSequential(m, 0, chief.ray);
    ASSERT_TRUE(rc.ok());
    expectNear(m.localPoint(img, rc.ray.origin), Vec3(0.0), 1e-11);
}

// Decentering a lens together with its stop by delta moves its whole image by delta: the
// image of every field lands delta further along the decenter than in the centred lens, so
// the boresight (the object direction imaged on the old axis) is off by delta / EFL. The
// ray aimer finds the stop in its decentered frame.
TEST(CoordinateBreak, DecenteredLensMovesTheImageByTheDecenter) {
    const double delta = 0.35;
    double imageDistance = 85.0;
    auto build = [&](bool decentered) {
        Prescription p = startLens(kInfinity, 10.0);
        p.system.fields = {{0.0, 0.0, 1.0}, {0.0, 5.0, 1.0}, {3.0, -4.0, 1.0}};
        p.surfaces.push_back(surface(0.0, 15.0));  // a dummy in object space
        p.surfaces.push_back(
            coordinateBreak(decentered ? decenter(0.0, delta) : CoordinateBreak{}, 0.0));
        Surface front = surface(60.0, 5.0, Material::model(1.6, 0.0));
        front.stop = true;
        p.surfaces.push_back(front);
        p.surfaces.push_back(surface(-250.0, 0.0));
        p.surfaces.push_back(coordinateBreak(
            decentered ? decenter(0.0, -delta, true) : CoordinateBreak{}, imageDistance));
        finishLens(p);
        return SequentialModel::build(p, kNoCatalog);
    };
    // The image surface at the paraxial focus.
    imageDistance += computeFirstOrder(build(false), 0).paraxialImageDistanceMm;
    const SequentialModel nominal = build(false), moved = build(true);
    EXPECT_TRUE(nominal.coaxial());
    EXPECT_FALSE(moved.coaxial());
    const RayAimer an(nominal, AimMode::Real), am(moved, AimMode::Real);
    const int img = nominal.imageIndex();
    for (const Field& f : nominal.prescription().system.fields) {
        for (const Vec2 pupil : {Vec2(0.0), Vec2(0.0, 0.8), Vec2(-0.6, 0.3)}) {
            const AimedRay a = an.aim(f, pupil.x, pupil.y, 0), b = am.aim(f, pupil.x, pupil.y, 0);
            ASSERT_EQ(a.status, RayStatus::Ok);
            ASSERT_EQ(b.status, RayStatus::Ok);
            const SequentialRayResult ra = traceSequential(nominal, 0, a.ray);
            const SequentialRayResult rb = traceSequential(moved, 0, b.ray);
            ASSERT_TRUE(ra.ok() && rb.ok());
            const Vec3 qa = nominal.localPoint(img, ra.ray.origin);
            const Vec3 qb = moved.localPoint(img, rb.ray.origin);
            EXPECT_NEAR(qb.x, qa.x, 1e-10);
            EXPECT_NEAR(qb.y, qa.y + delta, 1e-10);
        }
    }
    // Boresight: the on-axis object lands at delta; the field that lands on the old axis
    // is off by atan(delta / EFL) to first order.
    const double efl = computeFirstOrder(nominal, 0).eflMm;
    const AimedRay chief = am.aim(0.0, 0.0, 0.0, 0.0, 0);
    const Vec3 q = moved.localPoint(img, traceSequential(moved, 0, chief.ray).ray.origin);
    EXPECT_NEAR(q.y, delta, 1e-10);
    double lo = -2.0, hi = 2.0;  // field angle (deg) whose chief ray lands at y = 0
    for (int it = 0; it < 80; ++it) {
        const double mid = 0.5 * (lo + hi);
        const AimedRay c = am.aim(0.0, mid, 0.0, 0.0, 0);
        const double y = moved.localPoint(img, traceSequential(moved, 0, c.ray).ray.origin).y;
        (y > 0.0 ? hi : lo) = mid;
    }
    EXPECT_NEAR(std::tan(0.5 * (lo + hi) * kDeg), -delta / efl, 1e-4 * delta / efl);
}

// A break of 90 degrees turns the next plane along the beam: an axial ray meets it, if at
// all, ~1e17 mm away (cos 90 deg rounds to 6e-17). That is a miss, not a hit at infinity.
TEST(CoordinateBreak, APlaneTurnedAlongTheBeamIsMissed) {
    Prescription p = startLens(kInfinity, 4.0);
    p.surfaces.push_back(surface(0.0, 10.0));
    p.surfaces.push_back(coordinateBreak(tilt(90.0, 0, 0), 5.0));
    finishLens(p);
    const SequentialModel m = SequentialModel::build(p, kNoCatalog);
    const SequentialRayResult r =
        traceSequential(m, 0, Ray{Vec3(0.0, 0.0, -5.0), Vec3(0.0, 0.0, 1.0)});
    EXPECT_EQ(r.status, RayStatus::Missed);
    EXPECT_EQ(r.surface, m.imageIndex());
    // A ray climbing toward the turned plane meets it where geometry says: 5 mm up.
    const SequentialRayResult up =
        traceSequential(m, 0, Ray{Vec3(0.0, 0.0, 0.0), glm::normalize(Vec3(0.0, 1.0, 1.0))});
    ASSERT_TRUE(up.ok()) << up;
    EXPECT_NEAR(up.ray.origin.y, 5.0, 1e-12);
    EXPECT_NEAR(up.ray.origin.z, 5.0, 1e-12);
}

// Breaks that cancel leave a coaxial model, bit for bit on the axis.
TEST(CoordinateBreak, CancellingBreaksLeaveACoaxialModel) {
    Prescription p = startLens(kInfinity, 10.0);
    p.surfaces.push_back(coordinateBreak(tilt(33.0, -12.0, 4.0), 0.0));
    p.surfaces.push_back(coordinateBreak(tilt(-33.0, 12.0, -4.0, true), 10.0));
    p.surfaces.push_back(surface(50.0, 4.0, Material::model(1.5, 0.0)));
    p.surfaces.push_back(surface(0.0, 40.0));
    finishLens(p);
    const SequentialModel m = SequentialModel::build(p, kNoCatalog);
    EXPECT_TRUE(m.coaxial());
    EXPECT_EQ(m.surface(3).frame.translation, Vec3(0.0, 0.0, 10.0));
    EXPECT_EQ(m.surface(3).zMm, 10.0);
}

// A break is a flat dummy that keeps the medium; validate() names it otherwise.
TEST(CoordinateBreak, ValidationNamesTheBreak) {
    auto withBreak = [](auto edit) {
        Prescription p = startLens(kInfinity, 10.0);
        p.surfaces.push_back(surface(50.0, 4.0, Material::model(1.5, 0.0)));
        Surface b = coordinateBreak(tilt(1.0, 0, 0), 0.0, Material::model(1.5, 0.0));
        edit(b);
        p.surfaces.push_back(b);
        p.surfaces.push_back(surface(0.0, 40.0));
        p.surfaces.push_back(Surface{});
        p.assignNames();
        return p;
    };
    EXPECT_NO_THROW(withBreak([](Surface&) {}).validate());
    // In glass, the element runs on through the break to the next real surface.
    const std::vector<Element> e = withBreak([](Surface&) {}).elements();
    ASSERT_EQ(e.size(), 1u);
    EXPECT_EQ(e[0].frontSurface, 1);
    EXPECT_EQ(e[0].backSurface, 3);
    auto message = [](const Prescription& p) {
        try {
            p.validate();
        } catch (const ModelError& err) {
            return std::string(err.what());
        }
        return std::string();
    };
    EXPECT_NE(message(withBreak([](Surface& s) {
                  s.material = Material::air();
              })).find("keeps the medium"),
              std::string::npos);
    EXPECT_NE(message(withBreak([](Surface& s) { s.curvature = 0.01; })).find("flat dummy"),
              std::string::npos);
    EXPECT_NE(message(withBreak([](Surface& s) { s.conic = -1.0; })).find("S2"), std::string::npos);
    EXPECT_NE(message(withBreak([](Surface& s) { s.mirror = true; })).find("flat dummy"),
              std::string::npos);
    EXPECT_NE(message(withBreak([](Surface& s) {
                  s.coordinateBreak->tiltXDeg = NAN;
              })).find("not finite"),
              std::string::npos);
}

}  // namespace
}  // namespace veil
