#pragma once
// Biconic and toroidal surfaces (their sag formulas are in geometry/surface_shape.h): sag,
// normal, domain and exact intersections in double. surface_shape.h dispatches to these; use
// them through SurfaceShape.
//
// Neither shape has a usable closed-form intersection (a biconic with cx != cy meets a line in
// a quartic, a toroid in higher degree), so crossings are isolated by the branch and bound of
// geometry/root_search.h, as for the even aspheres, on f(s) = z(s) - S(x(s)^2, y(s)^2). The
// enclosures of f and f' over a segment come from one templated sag per shape evaluated in
// interval arithmetic with a forward derivative (the same template gives the point value and
// Newton's slope), widened by a few ulps of the magnitudes involved and tightened by the
// mean-value form once segments are short.
//
// Domain: a biconic exists where 1 - (1 + kx) cx^2 x^2 - (1 + ky) cy^2 y^2 >= 0; a toroid where
// its profile exists (1 - (1 + k) c^2 y^2 >= 0), stays on the vertex's side of the axis of
// rotation (1 - cx zy > 0) and where 1 - q^2 x^2 >= 0. A root outside is not a crossing.

#include <optional>

#include "geometry/surface_shape.h"

namespace veil {

double anamorphicSag(const BiconicShape& s, double x, double y);
double anamorphicSag(const ToroidalShape& s, double x, double y);

// Whether (x, y) lies in the shape's domain (a few ulps of rounding allowed at its rim).
bool anamorphicInDomain(const BiconicShape& s, double x, double y);
bool anamorphicInDomain(const ToroidalShape& s, double x, double y);

// Unit normal at a point on the surface, +z at the vertex.
Vec3 anamorphicNormal(const BiconicShape& s, const Vec3& point);
Vec3 anamorphicNormal(const ToroidalShape& s, const Vec3& point);

// The smaller of the domain's limits along the x and y axes.
double anamorphicMaxRadius(const BiconicShape& s);
double anamorphicMaxRadius(const ToroidalShape& s);

// An enclosure of the sag over the annulus uLo <= x^2 + y^2 <= uHi (every sag there lies in
// [zLo, zHi]; infinite where the shape has none): interval evaluations over cells of
// (x^2, y^2), widened by a few ulps.
void anamorphicSagRange(const BiconicShape& s, double uLo, double uHi, double& zLo, double& zHi);
void anamorphicSagRange(const ToroidalShape& s, double uLo, double uHi, double& zLo, double& zHi);

// A bound on the magnitude of the sag's curvature (the Hessian's eigenvalues) over the disc
// r <= rMax, for tessellation: the Gershgorin bound of finite-difference Hessians sampled on
// a polar grid, times 1.25 (a sample, as for the aspheres, not an enclosure).
double anamorphicCurvatureBound(const SurfaceShape& s, double rMax);

// As intersectSequential() and intersectFirst() in surface_shape.h.
std::optional<double> anamorphicSequential(const BiconicShape& s, const Ray& localRay);
std::optional<double> anamorphicSequential(const ToroidalShape& s, const Ray& localRay);
std::optional<ShapeHit> anamorphicFirst(const BiconicShape& s, const Ray& localRay, double tMin,
                                        double tMax, double rMax, bool startsOnSurface);
std::optional<ShapeHit> anamorphicFirst(const ToroidalShape& s, const Ray& localRay, double tMin,
                                        double tMax, double rMax, bool startsOnSurface);

}  // namespace veil
