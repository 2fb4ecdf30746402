// Exact faces against independent truths: the cylinder equation x^2 + y^2 = R^2 in long
// double (residuals and a long double root oracle), apertures with holes against the
// crossings worked out by hand, tessellations against the exact surface (the distance of
// sampled triangle points from the face, found by a 1D search in the meridional plane in long
// double), bounds against dense samples of the face.

#include "geometry/exact_face.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <memory>
#include <numbers>
#include <random>
#include <sstream>

namespace veil {
namespace {

using LD = long double;
constexpr double kInf = std::numeric_limits<double>::infinity();

LD cylinderResidual(const Vec3& p, double radius) {
    const LD x = p.x, y = p.y;
    return std::abs(std::sqrt(x * x + y * y) - static_cast<LD>(radius));
}

Vec3 unit(std::mt19937_64& rng) {
    std::normal_distribution<double> g;
    return glm::normalize(Vec3{g(rng), g(rng), g(rng)});
}

// Cylinder

TEST(ExactFace, CylinderHitsMatchLongDoubleOracle) {
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    const CylinderPatch cyl{12.5, -3.0, 7.0, true, nullptr};
    int hits = 0;
    LD worst = 0;
    for (int i = 0; i < 20000; ++i) {
        const Ray ray{Vec3{40.0 * uni(rng), 40.0 * uni(rng), 20.0 * uni(rng)}, unit(rng)};
        // Oracle: a t^2 + 2 b t + c = 0 in long double, smallest root > 0 with z in range.
        const LD ox = ray.origin.x, oy = ray.origin.y, dx = ray.direction.x, dy = ray.direction.y;
        const LD a = dx * dx + dy * dy, b = ox * dx + oy * dy,
                 c = ox * ox + oy * oy - LD(cyl.radiusMm) * cyl.radiusMm;
        const LD disc = b * b - a * c;
        LD expect = -1;
        if (disc >= 0 && a > 0) {
            for (LD t : {(-b - std::sqrt(disc)) / a, (-b + std::sqrt(disc)) / a}) {
                const LD z = ray.origin.z + t * LD(ray.direction.z);
                if (t > 0 && z >= cyl.zMinMm && z <= cyl.zMaxMm) {
                    expect = t;
                    break;
                }
            }
        }
        const auto hit = intersectFace(cyl, ray, 0.0, kInf, false);
        ASSERT_EQ(hit.has_value(), expect >= 0) << ray;
        if (!hit) continue;
        ++hits;
        EXPECT_NEAR(hit->t, static_cast<double>(expect), 1e-9 * (1.0 + hit->t)) << ray;
        const LD r = cylinderResidual(hit->point, cyl.radiusMm);
        worst = std::max(worst, r);
        EXPECT_LT(r, 1e-9L) << ray;
        // Outward normal, unit, perpendicular to the axis.
        EXPECT_NEAR(glm::length(hit->normal), 1.0, 1e-15);
        EXPECT_EQ(hit->normal.z, 0.0);
        EXPECT_GT(glm::dot(hit->normal, Vec3(hit->point.x, hit->point.y, 0.0)), 0.0);
        // The point is where the ray says.
        EXPECT_LT(glm::length(ray.origin + hit->t * ray.direction - hit->point), 1e-12);
    }
    EXPECT_GT(hits, 500);
    std::cout << "cylinder: " << hits << " hits, worst residual " << static_cast<double>(worst)
              << " mm\n";
}

TEST(ExactFace, CylinderGrazingRaysStayOnTheSurface) {
    // A ray entering at a point p at an angle alpha to the tangent plane (cosine alpha to the
    // normal) leaves again about 2 alpha / kappa further on, kappa = |T_xy|^2 / R the normal
    // curvature along its tangent direction T, and dips only alpha^2 / (2 kappa) inside. At
    // alpha = 1e-8 on a tangent across the axis that depth is 5e-17 R, below the rounding of
    // the ray's own coordinates, so whether it hits is not decided by its data; at 1e-6, or at
    // 1e-8 along a tangent within 1e-3 of the axis direction, it is, and a hit is required.
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    LD worst = 0;
    int required = 0, optional = 0, optionalHits = 0;
    for (double radius : {1e-3, 1.0, 12.5, 1e4}) {
        const CylinderPatch cyl{radius, -1e3 * radius, 1e3 * radius, true, nullptr};
        for (int kind = 0; kind < 3; ++kind) {
            const double cosine = kind == 0 ? 1e-6 : 1e-8;
            const bool mustHit = kind != 2;
            for (int i = 0; i < 1000; ++i) {
                const double phi = 2.0 * std::numbers::pi * uni(rng);
                const Vec3 n{std::cos(phi), std::sin(phi), 0.0};
                const Vec3 p = radius * n + Vec3(0.0, 0.0, radius * (uni(rng) - 0.5));
                const Vec3 along{-std::sin(phi), std::cos(phi), 0.0};
                // Angle of the tangent from the circumferential direction toward the axis.
                const double psi = kind == 1 ? std::numbers::pi / 2 - 1e-3 * uni(rng)
                                             : (std::numbers::pi / 2) * uni(rng);
                const Vec3 tangent = std::cos(psi) * along + std::sin(psi) * Vec3(0, 0, 1);
                const Vec3 d =
                    glm::normalize(std::sqrt(1.0 - cosine * cosine) * tangent - cosine * n);
                const double kappa = std::cos(psi) * std::cos(psi) / radius;
                const Ray ray{p - 0.5 * radius * d, d};
                const auto hit = intersectFace(cyl, ray, 0.0, kInf, false);
                if (mustHit) {
                    ASSERT_TRUE(hit.has_value()) << ray;
                    ++required;
                } else {
                    ++optional;
                    optionalHits += hit.has_value();
                }
                if (!hit) continue;
                const LD r = cylinderResidual(hit->point, radius);
                worst = std::max(worst, r);
                ASSERT_LT(r, 1e-9L) << ray;
                // Where along the ray a grazing hit lies is known only to about
                // eps R / (2 alpha): the rounding of R^2 moved along a nearly tangent line.
                const double reach = 2.5 * cosine / kappa + 1e-15 * radius / cosine;
                ASSERT_LT(glm::length(hit->point - p), reach);
                // ... and it leaves again a short chord later, still on the surface.
                const auto out = intersectFace(cyl, Ray{hit->point, d}, 0.0, kInf, true);
                if (out) {
                    ASSERT_LT(cylinderResidual(out->point, radius), 1e-9L);
                    ASSERT_LT(out->t, reach)
                        << "radius " << radius << " kind " << kind << " psi " << psi;
                }
            }
        }
    }
    std::cout << "cylinder grazing: " << required << " required hits, " << optionalHits << " of "
              << optional << " undecided rays hit, worst residual " << static_cast<double>(worst)
              << " mm\n";
}

TEST(ExactFace, CylinderRayStartingOnItFindsTheChord) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const CylinderPatch cyl{8.0, -50.0, 50.0, false, nullptr};  // inward normal: a bore
    int chords = 0;
    for (int i = 0; i < 20000; ++i) {
        const double phi = 2.0 * std::numbers::pi * uni(rng);
        const Vec3 o{8.0 * std::cos(phi), 8.0 * std::sin(phi), 10.0 * (uni(rng) - 0.5)};
        const Vec3 d = unit(rng);
        const auto hit = intersectFace(cyl, Ray{o, d}, 0.0, kInf, true);
        const double b = o.x * d.x + o.y * d.y;
        if (b >= 0.0) {
            EXPECT_FALSE(hit.has_value()) << "a ray leaving a convex wall cannot meet it again";
            continue;
        }
        // The chord: t = -2 b / a in long double.
        const LD a = LD(d.x) * d.x + LD(d.y) * d.y;
        const LD expect = -2 * (LD(o.x) * d.x + LD(o.y) * d.y) / a;
        const LD z = o.z + expect * LD(d.z);
        if (z < cyl.zMinMm || z > cyl.zMaxMm) {
            EXPECT_FALSE(hit.has_value());
            continue;
        }
        ASSERT_TRUE(hit.has_value()) << o << " " << d;
        ++chords;
        EXPECT_NEAR(hit->t, static_cast<double>(expect), 1e-9 * (1.0 + hit->t));
        EXPECT_LT(cylinderResidual(hit->point, 8.0), 1e-9L);
        // Inward normal.
        EXPECT_LT(glm::dot(hit->normal, Vec3(hit->point.x, hit->point.y, 0.0)), 0.0);
    }
    EXPECT_GT(chords, 5000);
    // Without the flag the origin's own root is found (t ~ 0): the flag matters.
    const Vec3 o{8.0, 0.0, 0.0};
    const Vec3 d = glm::normalize(Vec3{-1.0, 0.3, 0.1});
    const auto self = intersectFace(cyl, Ray{o, d}, -1.0, kInf, false);
    ASSERT_TRUE(self.has_value());
    EXPECT_NEAR(self->t, 0.0, 1e-12);
    const auto chord = intersectFace(cyl, Ray{o, d}, 0.0, kInf, true);
    ASSERT_TRUE(chord.has_value());
    EXPECT_GT(chord->t, 1.0);
}

TEST(ExactFace, CylinderRespectsItsZRangeAndRayRange) {
    const CylinderPatch cyl{5.0, 0.0, 2.0, true, nullptr};
    // Aimed at z = 1: hit at t = 5; aimed above zMax: miss.
    const Ray in{Vec3{-10.0, 0.0, 1.0}, Vec3{1.0, 0.0, 0.0}};
    const auto hit = intersectFace(cyl, in, 0.0, kInf, false);
    ASSERT_TRUE(hit.has_value());
    EXPECT_DOUBLE_EQ(hit->t, 5.0);
    EXPECT_EQ(hit->normal, Vec3(-1.0, 0.0, 0.0));
    EXPECT_FALSE(
        intersectFace(cyl, Ray{Vec3{-10.0, 0.0, 2.5}, Vec3{1.0, 0.0, 0.0}}, 0.0, kInf, false));
    // The far side when the near one is out of range; nothing when both are.
    const auto far = intersectFace(cyl, in, 6.0, kInf, false);
    ASSERT_TRUE(far.has_value());
    EXPECT_DOUBLE_EQ(far->t, 15.0);
    EXPECT_FALSE(intersectFace(cyl, in, 0.0, 4.9, false));
    // Exactly on the rim z = zMax is inside.
    const auto rim =
        intersectFace(cyl, Ray{Vec3{-10.0, 0.0, 2.0}, Vec3{1.0, 0.0, 0.0}}, 0.0, kInf, false);
    EXPECT_TRUE(rim.has_value());
    // Parallel to the axis: no hit.
    EXPECT_FALSE(
        intersectFace(cyl, Ray{Vec3{5.0, 0.0, -1.0}, Vec3{0.0, 0.0, 1.0}}, 0.0, kInf, false));
}

// Surface Patches with Holes

TEST(ExactFace, AnnulusHoleIsSkippedToTheFarRing) {
    // A concave mirror bowl (centre of curvature at -z) with a central hole of radius 10.
    const double c = -1.0 / 100.0;
    const SurfaceShape shape = SphereShape{c};
    const SurfacePatch ring{shape, AnnularAperture{10.0, 50.0}};
    auto sagAt = [&](double r) { return sag(shape, r * r); };
    // The line through (-5, 0, sag(5)) and (30, 0, sag(30)) crosses the sphere in the hole
    // first and in the ring second.
    const Vec3 a{-5.0, 0.0, sagAt(5.0)}, b{30.0, 0.0, sagAt(30.0)};
    const Vec3 d = glm::normalize(b - a);
    const Ray ray{a - 20.0 * d, d};
    const auto hit = intersectFace(ring, ray, 0.0, kInf, false);
    ASSERT_TRUE(hit.has_value());
    EXPECT_NEAR(hit->point.x, 30.0, 1e-9);
    EXPECT_NEAR(hit->point.z, sagAt(30.0), 1e-9);
    EXPECT_NEAR(hit->t, 20.0 + glm::length(b - a), 1e-9);
    // The full disc takes the first crossing.
    const auto disc =
        intersectFace(SurfacePatch{shape, CircularAperture{50.0}}, ray, 0.0, kInf, false);
    ASSERT_TRUE(disc.has_value());
    EXPECT_NEAR(disc->point.x, -5.0, 1e-9);
    // Reversed, the ray meets the ring first at r = 30.
    const Ray back{b + 20.0 * d, -d};
    const auto first = intersectFace(ring, back, 0.0, kInf, false);
    ASSERT_TRUE(first.has_value());
    EXPECT_NEAR(first->point.x, 30.0, 1e-9);
    // Starting on the ring at r = 30 heading through the hole: nothing more (a line meets a
    // sphere twice).
    EXPECT_FALSE(intersectFace(ring, Ray{first->point, -d}, 0.0, kInf, true));
    // A chord across the bowl from ring to ring.
    const Vec3 p{-30.0, 0.0, sagAt(30.0)};
    const auto across = intersectFace(ring, Ray{p, Vec3{1.0, 0.0, 0.0}}, 0.0, kInf, true);
    ASSERT_TRUE(across.has_value());
    EXPECT_NEAR(across->t, 60.0, 1e-9);
    // Straight through the hole along the axis: no hit.
    EXPECT_FALSE(
        intersectFace(ring, Ray{Vec3{0.0, 0.0, -10.0}, Vec3{0.0, 0.0, 1.0}}, 0.0, kInf, false));
    EXPECT_FALSE(
        intersectFace(ring, Ray{Vec3{3.0, 4.0, 10.0}, Vec3{0.0, 0.0, -1.0}}, 0.0, kInf, false));
}

TEST(ExactFace, AnnulusRandomRaysMatchTheDiscWithTheHoleCut) {
    // Oracle: the crossings of the full sphere (disc aperture, followed crossing by
    // crossing), of which the first with inner <= r <= outer is the annulus hit.
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    for (const SurfaceShape& shape :
         {SurfaceShape{PlaneShape{}}, SurfaceShape{SphereShape{1.0 / 40.0}},
          SurfaceShape{ConicShape{-1.0 / 60.0, -1.0}},
          SurfaceShape{EvenAsphereShape{1.0 / 50.0, 0.0, {0.0, 2e-6, -1e-9}}}}) {
        const SurfacePatch ring{shape, AnnularAperture{6.0, 20.0}};
        const SurfacePatch disc{shape, CircularAperture{20.0}};
        int viaHole = 0;
        for (int i = 0; i < 4000; ++i) {
            const Ray ray{Vec3{30.0 * uni(rng), 30.0 * uni(rng), 30.0 * uni(rng)}, unit(rng)};
            std::optional<ShapeHit> expect;
            auto h = intersectFace(disc, ray, 0.0, kInf, false);
            for (int k = 0; h && k < 8; ++k) {
                const double r = std::hypot(h->point.x, h->point.y);
                if (r >= 6.0) {
                    expect = h;
                    break;
                }
                ++viaHole;
                h = intersectFace(disc, ray, h->t, kInf, false);
            }
            const auto got = intersectFace(ring, ray, 0.0, kInf, false);
            ASSERT_EQ(got.has_value(), expect.has_value()) << shape << " " << ray;
            if (got) {
                EXPECT_NEAR(got->t, expect->t, 1e-9 * (1.0 + got->t)) << shape << " " << ray;
            }
        }
        EXPECT_GT(viaHole, 10) << shape;
    }
}

TEST(ExactFace, RectangleCornersCountButNotTheBoundingCircle) {
    const SurfacePatch rect{SphereShape{1.0 / 80.0}, RectangularAperture{6.0, 3.0}};
    auto down = [](double x, double y) { return Ray{Vec3{x, y, 10.0}, Vec3{0.0, 0.0, -1.0}}; };
    EXPECT_TRUE(intersectFace(rect, down(6.0, 3.0), 0.0, kInf, false));
    EXPECT_TRUE(intersectFace(rect, down(-5.9, 0.0), 0.0, kInf, false));
    EXPECT_FALSE(intersectFace(rect, down(0.0, 3.5), 0.0, kInf, false));
    EXPECT_FALSE(intersectFace(rect, down(6.01, 0.0), 0.0, kInf, false));
}

// Bounds

TEST(ExactFace, BoundsHoldDenseSamplesAndAreTight) {
    std::mt19937_64 rng(13);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const std::vector<FaceGeometry> faces = {
        SurfacePatch{SphereShape{1.0 / 30.0}, CircularAperture{12.0}},
        SurfacePatch{SphereShape{-1.0 / 15.0}, AnnularAperture{5.0, 14.0}},
        SurfacePatch{ConicShape{1.0 / 100.0, -2.5}, CircularAperture{40.0}},
        // An asphere whose sag turns over inside the aperture (a maximum near r = 14).
        SurfacePatch{EvenAsphereShape{1.0 / 50.0, 0.0, {0.0, 0.0, -3e-7}}, CircularAperture{20.0}},
        // Odd terms r^3 and r^5 on a weak sphere, turning over inside the aperture.
        SurfacePatch{EvenAsphereShape{1.0 / 200.0, 0.0, {}, {1e-4, -8e-7}}, CircularAperture{18.0}},
        // Terms over w (Qbfs) on a steep sphere, turning over inside the aperture.
        SurfacePatch{EvenAsphereShape{1.0 / 40.0, 0.0, {}, {}, {0.0, 5e-6, -2e-8}},
                     CircularAperture{22.0}},
        SurfacePatch{PlaneShape{}, RectangularAperture{4.0, 2.0}},
        CylinderPatch{9.0, -1.0, 4.0, true, nullptr},
    };
    for (const FaceGeometry& face : faces) {
        const Bounds3 b = faceBounds(face);
        Bounds3 samples;
        for (int i = 0; i < 200000; ++i) {
            Vec3 p;
            if (const auto* patch = std::get_if<SurfacePatch>(&face)) {
                const double rMax = apertureBoundingRadius(patch->aperture);
                const double r = rMax * std::sqrt(uni(rng)), phi = 2 * std::numbers::pi * uni(rng);
                const double x = r * std::cos(phi), y = r * std::sin(phi);
                if (!apertureContains(patch->aperture, x, y)) continue;
                p = Vec3{x, y, sag(patch->shape, x * x + y * y)};
            } else {
                const auto& cyl = std::get<CylinderPatch>(face);
                const double phi = 2 * std::numbers::pi * uni(rng);
                p = Vec3{cyl.radiusMm * std::cos(phi), cyl.radiusMm * std::sin(phi),
                         cyl.zMinMm + (cyl.zMaxMm - cyl.zMinMm) * uni(rng)};
            }
            samples.extend(p);
            ASSERT_TRUE(p.x >= b.lo.x && p.y >= b.lo.y && p.z >= b.lo.z && p.x <= b.hi.x &&
                        p.y <= b.hi.y && p.z <= b.hi.z)
                << face << " " << p << " " << b;
        }
        // Tight: within 1 % of the extent (+ 1 um) of what the samples reach.
        const Vec3 extent = samples.hi - samples.lo;
        for (int a = 0; a < 3; ++a) {
            const double slack = 0.01 * std::max({extent.x, extent.y, extent.z}) + 1e-3;
            EXPECT_LT(samples.lo[a] - b.lo[a], slack) << face << " axis " << a;
            EXPECT_LT(b.hi[a] - samples.hi[a], slack) << face << " axis " << a;
        }
    }
}

// Tessellation

// Distance of a point q from a rotationally symmetric patch whose radial range is
// [rLo, rHi]. The nearest point lies in q's meridional plane, at a signed radius r within
// delta = |q.z - sag(rho)| of q's own radius rho (the point of the face straight above or
// below q is that close), so a golden-section search of |q - (r, sag(r^2))| over that short
// interval in long double finds it.
LD distanceToProfile(const SurfaceShape& shape, const Vec3& q, double rLo, double rHi) {
    const LD rho = std::hypot(LD(q.x), LD(q.y));
    auto f = [&](LD r) {
        const LD s = sag(shape, static_cast<double>(r * r));
        const LD dr = rho - r, dz = LD(q.z) - s;
        return dr * dr + dz * dz;
    };
    const LD rhoIn = std::clamp(rho, LD(rLo), LD(rHi));
    const LD delta = std::sqrt(f(rhoIn)) + 1e-12L;
    LD lo = rhoIn - delta, hi = rhoIn + delta;
    if (rLo > 0.0) lo = std::max(lo, LD(rLo));  // an annulus: no crossing into the hole
    hi = std::min(hi, LD(rHi));
    const LD g = (std::sqrt(5.0L) - 1) / 2;
    LD best = f(rhoIn);
    for (int it = 0; it < 60; ++it) {
        const LD m1 = hi - g * (hi - lo), m2 = lo + g * (hi - lo);
        const LD f1 = f(m1), f2 = f(m2);
        best = std::min({best, f1, f2});
        if (f1 < f2) {
            hi = m2;
        } else {
            lo = m1;
        }
    }
    return std::sqrt(best);
}

struct Measured {
    double maxDistance = 0.0;
    size_t triangles = 0;
};

// Points of the triangles (a barycentric grid: vertices, edge points, interior), each
// measured against the exact face. Large meshes are measured on every k-th triangle (at
// least 5000): the triangles are laid out ring by ring (row by row), so every ring is
// still visited.
Measured measureTessellation(const FaceGeometry& face, double tol) {
    const TriangleMesh mesh = tessellateFace(face, tol);
    Measured m;
    m.triangles = mesh.triangles.size();
    const int grid = 4;
    const size_t stride = std::max<size_t>(1, mesh.triangles.size() / 5000);
    for (size_t t = 0; t < mesh.triangles.size(); t += stride) {
        const auto& tri = mesh.triangles[t];
        const Vec3 a = mesh.vertices[tri[0]], b = mesh.vertices[tri[1]], c = mesh.vertices[tri[2]];
        for (int i = 0; i <= grid; ++i) {
            for (int j = 0; i + j <= grid; ++j) {
                const double u = double(i) / grid, v = double(j) / grid;
                const Vec3 q = a + u * (b - a) + v * (c - a);
                LD d;
                if (const auto* patch = std::get_if<SurfacePatch>(&face)) {
                    double rLo = 0.0, rHi = apertureBoundingRadius(patch->aperture);
                    if (const auto* ring = std::get_if<AnnularAperture>(&patch->aperture))
                        rLo = ring->innerRadiusMm;
                    d = distanceToProfile(patch->shape, q, rLo, rHi);
                } else {
                    d = cylinderResidual(q, std::get<CylinderPatch>(face).radiusMm);
                }
                m.maxDistance = std::max(m.maxDistance, static_cast<double>(d));
            }
        }
    }
    return m;
}

TEST(ExactFace, TessellationChordErrorStaysWithinTolerance) {
    struct Case {
        const char* name;
        FaceGeometry face;
        double countExponent;  // triangles ~ tol^-exponent
        bool curved = true;    // a flat face's triangles lie on it exactly
    };
    const std::vector<Case> cases = {
        {"sphere disc", SurfacePatch{SphereShape{1.0 / 30.0}, CircularAperture{12.0}}, 1.0},
        {"steep sphere", SurfacePatch{SphereShape{-1.0 / 12.75}, CircularAperture{9.1}}, 1.0},
        {"paraboloid ring",
         SurfacePatch{ConicShape{-1.0 / 200.0, -1.0}, AnnularAperture{15.0, 50.0}}, 1.0},
        {"asphere",
         SurfacePatch{EvenAsphereShape{1.0 / 50.0, -0.5, {0.0, 1e-6, -2e-9}},
                      CircularAperture{18.0}},
         1.0},
        {"odd asphere",
         SurfacePatch{EvenAsphereShape{1.0 / 60.0, 0.0, {}, {2e-5, -1e-8}}, CircularAperture{16.0}},
         1.0},
        {"terms over w (Qbfs)",
         SurfacePatch{EvenAsphereShape{1.0 / 45.0, 0.0, {}, {}, {2e-4, -3e-7, 1e-10}},
                      CircularAperture{17.0}},
         1.0},
        {"sphere rectangle", SurfacePatch{SphereShape{1.0 / 40.0}, RectangularAperture{8.0, 5.0}},
         1.0},
        {"flat ring", SurfacePatch{PlaneShape{}, AnnularAperture{10.5, 12.0}}, 0.5, false},
        {"cylinder", CylinderPatch{12.0, -1.0, 3.0, true, nullptr}, 0.5},
    };
    for (const Case& c : cases) {
        std::cout << c.name << ":";
        size_t previous = 0;
        for (double tol : {0.03, 0.003, 0.0003}) {
            const Measured m = measureTessellation(c.face, tol);
            std::cout << "  tol " << tol << " -> " << m.triangles << " triangles, max distance "
                      << m.maxDistance;
            EXPECT_LE(m.maxDistance, tol) << c.name << " tol " << tol;
            // Not wastefully fine either: the rule uses a good part of its budget.
            if (c.curved) {
                EXPECT_GE(m.maxDistance, 0.1 * tol) << c.name << " tol " << tol;
            }
            if (previous > 0) {
                // Ten times finer: 10^exponent times as many triangles, within a factor 1.5.
                const double ratio = double(m.triangles) / double(previous);
                const double expect = std::pow(10.0, c.countExponent);
                EXPECT_GT(ratio, expect / 1.5) << c.name << " tol " << tol;
                EXPECT_LT(ratio, expect * 1.5) << c.name << " tol " << tol;
            }
            previous = m.triangles;
        }
        std::cout << "\n";
    }
}

TEST(ExactFace, TessellationFacesAlongTheNormal) {
    for (const FaceGeometry& face :
         {FaceGeometry{SurfacePatch{SphereShape{1.0 / 30.0}, CircularAperture{12.0}}},
          FaceGeometry{SurfacePatch{SphereShape{-1.0 / 30.0}, AnnularAperture{4.0, 12.0}}},
          FaceGeometry{SurfacePatch{PlaneShape{}, RectangularAperture{2.0, 1.0}}},
          FaceGeometry{CylinderPatch{5.0, 0.0, 1.0, true, nullptr}},
          FaceGeometry{CylinderPatch{5.0, 0.0, 1.0, false, nullptr}}}) {
        const TriangleMesh mesh = tessellateFace(face, 0.01);
        ASSERT_FALSE(mesh.triangles.empty());
        for (size_t t = 0; t < mesh.triangles.size(); ++t) {
            const auto& tri = mesh.triangles[t];
            const Vec3 centre =
                (mesh.vertices[tri[0]] + mesh.vertices[tri[1]] + mesh.vertices[tri[2]]) / 3.0;
            Vec3 expect;
            if (const auto* patch = std::get_if<SurfacePatch>(&face)) {
                expect = surfaceNormal(patch->shape, centre);
            } else {
                const auto& cyl = std::get<CylinderPatch>(face);
                expect = glm::normalize(Vec3(centre.x, centre.y, 0.0)) * (cyl.outward ? 1.0 : -1.0);
            }
            ASSERT_GT(glm::dot(mesh.triangleNormal(t), expect), 0.9) << face << " triangle " << t;
        }
    }
    EXPECT_THROW(tessellateFace(CylinderPatch{1.0, 0.0, 1.0, true, nullptr}, 0.0), std::invalid_argument);
}

// Sections

TEST(ExactFace, SectionsFollowTheProfile) {
    const SurfaceShape shape = SphereShape{1.0 / 25.0};
    const double tol = 1e-3;
    // Disc: one polyline from -R to R on z = sag(y^2), chords within tol.
    const auto disc = sectionOfFace(SurfacePatch{shape, CircularAperture{10.0}}, tol);
    ASSERT_EQ(disc.size(), 1u);
    EXPECT_EQ(disc[0].front(), Vec2(-10.0, sag(shape, 100.0)));
    EXPECT_EQ(disc[0].back(), Vec2(10.0, sag(shape, 100.0)));
    for (size_t i = 0; i + 1 < disc[0].size(); ++i) {
        const Vec2 a = disc[0][i], b = disc[0][i + 1];
        EXPECT_GT(b.x, a.x);
        EXPECT_NEAR(a.y, sag(shape, a.x * a.x), 1e-15);
        const double ym = 0.5 * (a.x + b.x);
        EXPECT_LE(std::abs(0.5 * (a.y + b.y) - sag(shape, ym * ym)), tol);
    }
    // Annulus: two pieces, hole left out.
    const auto ring = sectionOfFace(SurfacePatch{shape, AnnularAperture{3.0, 10.0}}, tol);
    ASSERT_EQ(ring.size(), 2u);
    EXPECT_EQ(ring[0].front().x, -10.0);
    EXPECT_EQ(ring[0].back().x, -3.0);
    EXPECT_EQ(ring[1].front().x, 3.0);
    EXPECT_EQ(ring[1].back().x, 10.0);
    // Cylinder: two vertical segments at y = -+R.
    const auto wall = sectionOfFace(CylinderPatch{7.0, -1.0, 2.0, true, nullptr}, tol);
    ASSERT_EQ(wall.size(), 2u);
    EXPECT_EQ(wall[0], (std::vector<Vec2>{{-7.0, -1.0}, {-7.0, 2.0}}));
    EXPECT_EQ(wall[1], (std::vector<Vec2>{{7.0, -1.0}, {7.0, 2.0}}));
}

// Prepared faces

// PreparedFace::cross() and faceNormal() against intersectFace(), the general path they must
// reproduce bit for bit: every kind of face a lens has (spheres, conics, an asphere without
// terms, planes, each with a disc or a ring; butt ends with and without rim curves) and the
// kinds left to the general path (an asphere, a rectangle, a biconic), for rays from
// everywhere, rays starting on the face, short ray ranges and rays along the axis.
TEST(ExactFace, PreparedFacesCrossExactlyAsIntersectFace) {
    EvenAsphereShape bare;
    bare.curvature = 1.0 / 40.0;
    bare.conic = -0.6;
    EvenAsphereShape asphere = bare;
    asphere.coefficients[1] = 2e-7;
    BiconicShape biconic;
    biconic.xCurvature = 1.0 / 50.0;
    biconic.yCurvature = -1.0 / 80.0;
    auto rims = std::make_shared<RimCurves>();
    rims->upper = RimCurve{SphereShape{1.0 / 60.0}, 4.0};
    const std::vector<FaceGeometry> faces = {
        SurfacePatch{SphereShape{1.0 / 30.0}, CircularAperture{12.0}},
        SurfacePatch{SphereShape{-1.0 / 55.0}, AnnularAperture{4.0, 20.0}},
        SurfacePatch{ConicShape{1.0 / 25.0, -1.0}, CircularAperture{15.0}},
        SurfacePatch{ConicShape{-1.0 / 70.0, 0.4}, AnnularAperture{6.0, 18.0}},
        SurfacePatch{bare, CircularAperture{14.0}},
        SurfacePatch{PlaneShape{}, CircularAperture{10.0}},
        SurfacePatch{PlaneShape{}, AnnularAperture{10.0, 16.0}},
        CylinderPatch{16.0, -3.0, 5.0, true, nullptr},
        CylinderPatch{16.0, -3.0, 5.0, false, nullptr},
        CylinderPatch{12.0, -2.0, 6.0, true, rims},
        SurfacePatch{asphere, CircularAperture{14.0}},
        SurfacePatch{SphereShape{1.0 / 30.0}, RectangularAperture{8.0, 5.0}},
        SurfacePatch{biconic, CircularAperture{10.0}},
    };
    std::mt19937_64 rng(2024);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    auto same = [](const Vec3& a, const Vec3& b) { return a.x == b.x && a.y == b.y && a.z == b.z; };
    for (size_t f = 0; f < faces.size(); ++f) {
        const PreparedFace prepared(faces[f]);
        int hits = 0, fromFace = 0;
        for (int i = 0; i < 20000; ++i) {
            // Most rays aim at a point near the faces; some go anywhere, some along the axis.
            Ray ray{Vec3{25.0 * u(rng), 25.0 * u(rng), 25.0 * u(rng)}, unit(rng)};
            const Vec3 target{18.0 * u(rng), 18.0 * u(rng), 4.0 * u(rng)};
            if (i % 4 != 0) ray.direction = glm::normalize(target - ray.origin);
            if (i % 10 == 0) ray.direction = Vec3{0.0, 0.0, i % 20 == 0 ? 1.0 : -1.0};
            double tMax = i % 7 == 0 ? 10.0 * std::abs(u(rng)) : kInf;
            bool starts = false;
            // Every third ray restarts from a hit of the face, bounced at random.
            if (i % 3 == 0) {
                if (const auto h = intersectFace(faces[f], ray, 0.0, kInf, false)) {
                    ray = Ray{h->point, unit(rng)};
                    starts = true;
                    ++fromFace;
                }
            }
            const auto want = intersectFace(faces[f], ray, 0.0, tMax, starts);
            FaceCrossing got;
            const bool crossed = prepared.cross(faces[f], ray, 0.0, tMax, starts, got);
            ASSERT_EQ(crossed, want.has_value()) << "face " << f << " ray " << i;
            if (!crossed) continue;
            ++hits;
            const Vec3 normal = got.hasNormal ? got.normal : faceNormal(faces[f], got.point);
            ASSERT_EQ(got.t, want->t) << "face " << f << " ray " << i;
            ASSERT_TRUE(same(got.point, want->point)) << "face " << f << " ray " << i;
            ASSERT_TRUE(same(normal, want->normal)) << "face " << f << " ray " << i;
        }
        EXPECT_GT(hits, 1000) << "face " << f;
        EXPECT_GT(fromFace, 500) << "face " << f;
    }
}

TEST(ExactFace, PrintsItself) {
    std::ostringstream os;
    os << FaceGeometry{CylinderPatch{2.0, 0.0, 1.0, true, nullptr}} << " "
       << FaceGeometry{SurfacePatch{PlaneShape{}, AnnularAperture{1.0, 2.0}}};
    EXPECT_EQ(os.str(),
              "CylinderPatch{radius 2 mm, z 0 .. 1 mm, outward} SurfacePatch{Plane{}, "
              "AnnularAperture{inner 1 mm, outer 2 mm}}");
}

}  // namespace
}  // namespace veil
