#pragma once
// The roots of a ray with a conic's implicit quadric, shared by the surface shapes
// (geometry/surface_shape.cpp) and the exact faces' prepared queries (geometry/exact_face.cpp),
// which must find the same t bit for bit. Internal to geometry/.
//
// On the vertex sheet z = c u / (1 + w), w = sqrt(1 - (1+k) c^2 u), so z (1 + w) = c u, and
// squaring (c u - z)^2 = z^2 w^2 gives the implicit quadric
//
//     G(x, y, z) = c (x^2 + y^2 + (1 + k) z^2) - 2 z = 0,
//
// which also holds on the far sheet z = c u / (1 - w) (the other half of a sphere or
// ellipsoid, the mirror sheet of a hyperboloid). Since dG/dz = 2 ((1 + k) c z - 1) and on
// the vertex sheet (1 + k) c z = 1 - w, the vertex sheet is where (1 + k) c z <= 1; roots
// beyond are dropped. Along the ray p + s d,
//
//     G(s) = A s^2 + 2 B s + C,   A = c (dx^2 + dy^2 + (1 + k) dz^2),
//                                 B = c (px dx + py dy + (1 + k) pz dz) - dz,   C = G(p).
//
// The roots (-B -+ sqrt(B^2 - AC)) / A are, after multiplying above and below by
// (-B +- sqrt(B^2 - AC)), also C / (-B +- sqrt(B^2 - AC)). With
//
//     q = -(B + sign(B) sqrt(B^2 - AC))
//
// the two roots are C / q and q / A, and q adds two terms of the same sign, so neither root
// cancels. Near the vertex C / q is the vertex-sheet root: as c -> 0 it tends to the plane
// root -pz / dz (A -> 0, B -> -dz, q -> 2 dz), at the vertex it is exactly 0 (C = 0), and
// q / A -> infinity is the far sheet. In general both roots are kept and the sheet test and
// the caller's convention choose. For A = 0 (a paraboloid met parallel to its axis) only the
// root C / q exists. B^2 - AC is evaluated with fma so grazing rays keep their digits.
//
// The reference point p is the point of the ray nearest the vertex (p . d = 0), so that the
// terms c |p|^2 and pz in B and C are never larger than the hit point itself: a ray from
// 1 m away still meets a 1 um sphere to full relative precision.

#include <array>
#include <cmath>

#include "geometry/numerics.h"
#include "geometry/root_search.h"
#include "geometry/vec.h"

namespace veil {

// Base conic of a shape: curvature c and conic constant k (a plane is c = 0).
struct ConicBase {
    double c = 0.0;
    double k = 0.0;
    // K = (1 + k) c^2: the sag's square root is w = sqrt(1 - K u), u = r^2.
    double bigK() const { return (1.0 + k) * c * c; }
};

struct QuadraticRoots {
    int count = 0;
    std::array<double, 2> s{};
};

inline QuadraticRoots conicRoots(const ConicBase& b, const Vec3& p, const Vec3& d) {
    const double kp1 = 1.0 + b.k;
    const double qa = b.c * (d.x * d.x + d.y * d.y + kp1 * d.z * d.z);
    const double qb = b.c * (p.x * d.x + p.y * d.y + kp1 * p.z * d.z) - d.z;
    const double qc = b.c * (p.x * p.x + p.y * p.y + kp1 * p.z * p.z) - 2.0 * p.z;
    const double disc = differenceOfProducts(qb, qb, qa, qc);
    if (!(disc >= 0.0)) return {};
    const double q = -(qb + std::copysign(std::sqrt(disc), qb));
    if (q == 0.0) {
        // qb == 0 and qa * qc == 0: either the ray touches the vertex sheet at p (qc == 0) or
        // the equation degenerates (qa == 0 with no linear term).
        if (qc == 0.0) return {1, {0.0, 0.0}};
        return {};
    }
    QuadraticRoots r;
    r.s[r.count++] = qc / q;
    if (qa != 0.0) r.s[r.count++] = q / qa;
    return r;
}

inline bool onVertexSheet(const ConicBase& b, double z) { return (1.0 + b.k) * b.c * z <= 1.0; }

// The first crossing of the vertex sheet with t in (tMin, tMax] and within radius rMax (see
// intersectFirst() in surface_shape.h): its t and local point; the normal is the caller's.
inline bool conicFirstCrossing(const ConicBase& b, const Ray& ray, double tMin, double tMax,
                               double rMax, bool startsOnSurface, double& tOut, Vec3& pointOut) {
    const Vec3& d = ray.direction;
    // A ray that starts on the surface is solved from its origin, where one root is the
    // origin itself (C ~ 0): the root of smaller magnitude, C / q or q / A, is that one and is
    // dropped; the other is computed without cancellation, and no offset is needed.
    const double tRef = startsOnSurface ? 0.0 : root_search::nearestToVertex(ray);
    const Vec3 p = ray.origin + tRef * d;
    QuadraticRoots roots = conicRoots(b, p, d);
    if (startsOnSurface) {
        if (roots.count < 2) return false;
        if (std::abs(roots.s[0]) < std::abs(roots.s[1])) roots.s[0] = roots.s[1];
        roots.count = 1;
    }
    bool found = false;
    for (int i = 0; i < roots.count; ++i) {
        const double s = roots.s[i];
        const double t = tRef + s;
        if (!(t > tMin && t <= tMax)) continue;
        if (found && t >= tOut) continue;
        const Vec3 point = p + s * d;
        if (!onVertexSheet(b, point.z)) continue;
        if (!root_search::withinRadius(point, rMax, glm::length(p) + std::abs(s))) continue;
        found = true;
        tOut = t;
        pointOut = point;
    }
    return found;
}

}  // namespace veil
