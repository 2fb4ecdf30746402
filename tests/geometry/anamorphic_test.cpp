// Biconic and toroidal surfaces against independent truth: their defining geometry written
// another way (a toroid as the sweep of its profile about the axis of rotation, a biconic by
// its implicit quartic), the shapes they reduce to (a biconic with equal sections is a conic,
// a toroid whose radius of rotation equals its profile's radius is a sphere), the normal
// against finite differences of the sag, and every crossing against a brute-force scan of
// the ray for sign changes, so no nearer crossing is skipped.

#include "geometry/anamorphic.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "geometry/surface_shape.h"

namespace veil {
namespace {

using LD = long double;

// The toroid by its construction, in long double: the profile point at height y lies at
// distance rho = R - zy from the axis of rotation (z = R); swept by the angle that reaches
// x, it sits at z = R - rho cos(theta) with rho sin(theta) = x.
LD toroidBySweep(const ToroidalShape& s, LD x, LD y) {
    const LD c = s.yCurvature, k = s.yConic;
    LD zy = c * y * y / (1 + std::sqrt(1 - (1 + k) * c * c * y * y));
    LD yp = y * y;
    for (double a : s.yCoefficients) {
        zy += a * yp;
        yp *= y * y;
    }
    if (s.xCurvature == 0.0) return zy;
    const LD R = 1 / LD(s.xCurvature);
    const LD rho = R - zy;
    const LD theta = std::asin(x / rho);
    return R - rho * std::cos(theta);
}

// The biconic's implicit form: with A = cx x^2 + cy y^2 and B = ax x^2 + ay y^2,
// z (1 + sqrt(1 - B)) = A squares to A^2 - 2 A z + B z^2 = 0.
LD biconicImplicit(const BiconicShape& s, LD x, LD y, LD z) {
    const LD A = LD(s.xCurvature) * x * x + LD(s.yCurvature) * y * y;
    const LD B = (1 + LD(s.xConic)) * s.xCurvature * s.xCurvature * x * x +
                 (1 + LD(s.yConic)) * s.yCurvature * s.yCurvature * y * y;
    return A * A - 2 * A * z + B * z * z;
}

Vec3 randomDirection(std::mt19937_64& rng, double spread) {
    std::normal_distribution<double> n;
    return glm::normalize(Vec3(spread * n(rng), spread * n(rng), 1.0));
}

// Brute force: the first sign change of f(t) = z(t) - sag(x(t), y(t)) in (tMin, tEnd],
// sampled every `step` mm within the rim. Returns the bracketing t, or NaN.
double firstSignChange(const SurfaceShape& shape, const Ray& ray, double tMin, double tEnd,
                       double rMax, double step) {
    auto f = [&](double t) {
        const Vec3 p = ray.origin + t * ray.direction;
        if (std::hypot(p.x, p.y) > rMax) return std::numeric_limits<double>::quiet_NaN();
        return p.z - sagAt(shape, p.x, p.y);
    };
    double prev = f(tMin);
    for (double t = tMin + step; t <= tEnd; t += step) {
        const double v = f(t);
        if (std::isfinite(prev) && std::isfinite(v) && (prev <= 0.0) != (v <= 0.0)) return t;
        prev = v;
    }
    return std::numeric_limits<double>::quiet_NaN();
}

const BiconicShape kBiconic{1.0 / 40.0, -0.6, -1.0 / 75.0, 1.5};
const ToroidalShape kToroid{1.0 / 30.0, -0.4, {2e-4, -3e-7, 1e-10}, 1.0 / 55.0};
const ToroidalShape kCylinder{1.0 / 25.0, 0.0, {}, 0.0};

TEST(Anamorphic, ToroidSagMatchesItsSweep) {
    for (const ToroidalShape& s :
         {kToroid, kCylinder, ToroidalShape{-1.0 / 30.0, 0.5, {}, 1.0 / 80.0}}) {
        for (double x = -12.0; x <= 12.0; x += 1.5) {
            for (double y = -12.0; y <= 12.0; y += 1.5) {
                const double z = sagAt(SurfaceShape{s}, x, y);
                EXPECT_NEAR(z, static_cast<double>(toroidBySweep(s, x, y)), 1e-13)
                    << s << " at " << x << ", " << y;
            }
        }
    }
}

TEST(Anamorphic, BiconicSagSolvesItsImplicitForm) {
    for (double x = -15.0; x <= 15.0; x += 1.25) {
        for (double y = -15.0; y <= 15.0; y += 1.25) {
            const double z = sagAt(SurfaceShape{kBiconic}, x, y);
            const LD A =
                std::abs(kBiconic.xCurvature) * x * x + std::abs(kBiconic.yCurvature) * y * y;
            EXPECT_LE(std::abs(biconicImplicit(kBiconic, x, y, z)), 1e-14L * (1 + A * A))
                << x << ", " << y;
        }
    }
    // The sections are the conics they name.
    for (double r = 0.0; r <= 15.0; r += 0.5) {
        EXPECT_NEAR(sagAt(SurfaceShape{kBiconic}, r, 0.0),
                    sag(ConicShape{kBiconic.xCurvature, kBiconic.xConic}, r * r), 1e-15);
        EXPECT_NEAR(sagAt(SurfaceShape{kBiconic}, 0.0, r),
                    sag(ConicShape{kBiconic.yCurvature, kBiconic.yConic}, r * r), 1e-15);
    }
}

TEST(Anamorphic, RotationalSagIsRefused) {
    EXPECT_THROW(sag(SurfaceShape{kBiconic}, 1.0), std::logic_error);
    EXPECT_FALSE(isRotational(SurfaceShape{kToroid}));
    EXPECT_TRUE(isRotational(SurfaceShape{SphereShape{0.01}}));
}

// A biconic with equal sections is the conic; a toroid swept about its profile's own centre
// of curvature is the sphere. Both must meet every ray where the closed forms do.
TEST(Anamorphic, ReducesToTheRotationalShapes) {
    const double c = 1.0 / 35.0;
    const SurfaceShape biconic = BiconicShape{c, -0.7, c, -0.7};
    const SurfaceShape conic = ConicShape{c, -0.7};
    const SurfaceShape toroid = ToroidalShape{c, 0.0, {}, c};
    const SurfaceShape sphere = SphereShape{c};
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> u(-14.0, 14.0);
    int hits = 0;
    for (int i = 0; i < 2000; ++i) {
        const Ray ray{Vec3(u(rng), u(rng), -20.0), randomDirection(rng, 0.3)};
        for (const auto& [a, b] : {std::pair{biconic, conic}, std::pair{toroid, sphere}}) {
            const auto ta = intersectSequential(a, ray), tb = intersectSequential(b, ray);
            ASSERT_EQ(ta.has_value(), tb.has_value()) << a << " " << ray.origin;
            if (ta) {
                EXPECT_NEAR(*ta, *tb, 1e-11);
            }
            const auto ha = intersectFirst(a, ray, 0.0, 1e3, 15.0, false);
            const auto hb = intersectFirst(b, ray, 0.0, 1e3, 15.0, false);
            ASSERT_EQ(ha.has_value(), hb.has_value()) << a << " " << ray.origin;
            if (!ha) continue;
            ++hits;
            EXPECT_NEAR(ha->t, hb->t, 1e-11);
            EXPECT_NEAR(glm::length(ha->normal - hb->normal), 0.0, 1e-12);
        }
    }
    EXPECT_GT(hits, 2000);
}

TEST(Anamorphic, NormalIsTheSagGradient) {
    const double h = 1e-6;
    for (const SurfaceShape& s :
         {SurfaceShape{kBiconic}, SurfaceShape{kToroid}, SurfaceShape{kCylinder}}) {
        for (double x = -10.0; x <= 10.0; x += 2.5) {
            for (double y = -10.0; y <= 10.0; y += 2.5) {
                const double gx = (sagAt(s, x + h, y) - sagAt(s, x - h, y)) / (2 * h);
                const double gy = (sagAt(s, x, y + h) - sagAt(s, x, y - h)) / (2 * h);
                const Vec3 expected = glm::normalize(Vec3(-gx, -gy, 1.0));
                const Vec3 n = surfaceNormal(s, Vec3(x, y, sagAt(s, x, y)));
                EXPECT_NEAR(glm::length(n - expected), 0.0, 1e-8) << s << " at " << x << ", " << y;
            }
        }
    }
}

// Every crossing lies on the surface, and a scan of the ray finds no crossing before it.
TEST(Anamorphic, CrossingsAreOnTheSurfaceAndFirst) {
    const double kScanStep = 4e-3;  // mm
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(-12.0, 12.0);
    for (const SurfaceShape& s :
         {SurfaceShape{kBiconic}, SurfaceShape{kToroid}, SurfaceShape{kCylinder}}) {
        int hits = 0, checked = 0;
        for (int i = 0; i < 400; ++i) {
            // Rays from both sides, steep and shallow, so some cross a curved surface twice.
            const double side = i % 2 ? 1.0 : -1.0;
            Vec3 d = randomDirection(rng, i % 4 < 2 ? 0.2 : 1.5);
            d.z *= -side;
            const Ray ray{Vec3(u(rng), u(rng), side * 15.0), d};
            const double rMax = 12.0;
            const auto hit = intersectFirst(s, ray, 0.0, 100.0, rMax, false);
            const double tScan = firstSignChange(s, ray, 0.0, 100.0, rMax, kScanStep);
            if (!hit) {
                EXPECT_TRUE(std::isnan(tScan)) << s << " missed a crossing near t = " << tScan;
                continue;
            }
            ++hits;
            const Vec3& p = hit->point;
            EXPECT_NEAR(p.z, sagAt(s, p.x, p.y), 1e-12 * (1.0 + std::abs(p.z))) << s;
            EXPECT_LE(std::hypot(p.x, p.y), rMax + 1e-12);
            if (std::isfinite(tScan)) {
                ++checked;
                EXPECT_LE(hit->t, tScan + 1e-9) << s << " skipped the crossing near " << tScan;
                EXPECT_GE(hit->t, tScan - kScanStep - 1e-9) << s;
            }
            // Restarted on the surface, the ray does not find its own point again.
            const Ray onward{p, ray.direction};
            const auto next = intersectFirst(s, onward, 0.0, 100.0, rMax, true);
            if (next) {
                EXPECT_GT(next->t, 1e-6) << s;
            }
        }
        EXPECT_GT(hits, 150) << s;
        EXPECT_GT(checked, 150) << s;
    }
}

// The sequential crossing of a cylinder lens's surface: a ray in the x-z plane sees a flat
// surface (the cylinder has no power in x), one in the y-z plane sees the circle.
TEST(Anamorphic, CylinderHasPowerInYOnly) {
    const SurfaceShape s = kCylinder;
    const Vec3 d = glm::normalize(Vec3(0.3, 0.0, 1.0));
    const auto tx = intersectSequential(s, Ray{Vec3(0.0, 0.0, -5.0), d});
    ASSERT_TRUE(tx);
    EXPECT_NEAR((Vec3(0.0, 0.0, -5.0) + *tx * d).z, 0.0, 1e-14);
    const Vec3 dy = glm::normalize(Vec3(0.0, 0.3, 1.0));
    const auto ty = intersectSequential(s, Ray{Vec3(0.0, 0.0, -5.0), dy});
    const auto tSphere = intersectSequential(SurfaceShape{SphereShape{kCylinder.yCurvature}},
                                             Ray{Vec3(0.0, 0.0, -5.0), dy});
    ASSERT_TRUE(ty && tSphere);
    EXPECT_NEAR(*ty, *tSphere, 1e-12);
}

// Crossings beyond the domain are not crossings: a biconic ellipsoid's x rim.
TEST(Anamorphic, OutsideTheDomainIsAMiss) {
    const BiconicShape s{1.0 / 10.0, 0.0, 1.0 / 100.0, 0.0};  // x rim at 10 mm
    EXPECT_DOUBLE_EQ(maxRadius(SurfaceShape{s}), 10.0);
    EXPECT_TRUE(std::isnan(sagAt(SurfaceShape{s}, 10.5, 0.0)));
    // Parallel to the axis at x = 10.5: no crossing (the clamped continuation is refused).
    EXPECT_FALSE(intersectSequential(SurfaceShape{s}, Ray{Vec3(10.5, 0.0, -5.0), Vec3(0, 0, 1)}));
    EXPECT_TRUE(intersectSequential(SurfaceShape{s}, Ray{Vec3(9.5, 0.0, -5.0), Vec3(0, 0, 1)}));
}

}  // namespace
}  // namespace veil
