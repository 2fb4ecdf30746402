#pragma once
// Exact optical surfaces in their local frame: vertex at the origin, axis along +z.
//
// Every shape is a height field z = sag(x, y) over the aperture; for spheres and conics it
// is the sheet through the vertex (the other sheet is never part of a lens surface). All
// arithmetic is double precision; intersections are written to avoid cancellation near the
// vertex and for radii up to 1e9 mm, and aspheres are refined by bracketed Newton steps.
//
//   plane          z = 0
//   sphere         z = c r^2 / (1 + sqrt(1 - c^2 r^2))
//   conic          z = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2))
//   even asphere   conic + sum_i a[i] r^(2i+2)      (a[0] r^2, a[1] r^4 = A4, ... a[9] = A20)
//                  + sum_j b[j] r^(2j+3)            (odd terms r^3, r^5, ... r^19: Zemax's
//                                                    ODDASPH; no r^1 term, which would put a
//                                                    cone's tip at the vertex)
//                  + sum_i e[i] r^(2i+2) / w        (terms over the base's w = sqrt(1 - (1+k)
//                                                    c^2 r^2): Forbes's Qbfs departure,
//                                                    geometry/qtype.h; only on a sphere or
//                                                    ellipsoid base, (1 + k) >= 0)
//
// Two anamorphic shapes (no symmetry of revolution; mirror-symmetric in x and in y) follow
// the lens design programs' definitions (geometry/anamorphic.h has their algebra):
//
//   biconic        z = (cx x^2 + cy y^2) / (1 + sqrt(1 - (1 + kx) cx^2 x^2 - (1 + ky) cy^2 y^2))
//                  (its x-z and y-z sections are conics of their own curvature and conic
//                  constant; cx = 0 or cy = 0 makes a cylinder)
//   toroidal       the y-z profile zy(y) = c y^2 / (1 + sqrt(1 - (1 + k) c^2 y^2))
//                  + sum_i a[i] y^(2i+2), swept about the axis parallel to y that crosses
//                  the z axis at z = 1 / cx (the radius of rotation):
//                  z = zy + q x^2 / (1 + sqrt(1 - q^2 x^2)),  q = cx / (1 - cx zy);
//                  cx = 0 (an infinite radius of rotation) is a cylinder, flat in x
//
// Units: lengths in mm, curvature c in 1/mm (c > 0 when the centre of curvature is at +z),
// k dimensionless (k > 0 oblate ellipsoid, 0 sphere, (-1, 0) prolate ellipsoid, -1
// paraboloid, < -1 hyperboloid), a[i] in mm^-(2i+1).
//
// Normals are unit vectors along grad(z - sag): at the vertex (0, 0, 1), that is toward +z.
// The closed set of shapes is a std::variant dispatched with std::visit, without virtual
// calls.
//
// Rays are given in the surface's local frame; their direction should be a unit vector, so
// that the distances t are in mm.

#include <array>
#include <optional>
#include <ostream>
#include <variant>

#include "geometry/vec.h"

namespace veil {

struct PlaneShape {};
struct SphereShape {
    double curvature = 0.0;  // 1/mm
};
struct ConicShape {
    double curvature = 0.0;
    double conic = 0.0;
};
struct EvenAsphereShape {
    double curvature = 0.0;
    double conic = 0.0;
    std::array<double, 10> coefficients{};  // coefficients[i] multiplies r^(2i+2)
    std::array<double, 9> odd{};            // odd[j] multiplies r^(2j+3), in mm^-(2j+2)
    std::array<double, 10> overW{};         // overW[i] multiplies r^(2i+2) / w, in mm^-(2i+1)
};

struct BiconicShape {
    double xCurvature = 0.0;  // 1/mm, the x-z section
    double xConic = 0.0;
    double yCurvature = 0.0;  // 1/mm, the y-z section
    double yConic = 0.0;
};
struct ToroidalShape {
    double yCurvature = 0.0;  // 1/mm, the y-z profile's base conic
    double yConic = 0.0;
    std::array<double, 10> yCoefficients{};  // yCoefficients[i] multiplies y^(2i+2)
    double xCurvature = 0.0;  // 1 / the radius of rotation; 0: a cylinder, flat in x
};

using SurfaceShape = std::variant<PlaneShape, SphereShape, ConicShape, EvenAsphereShape,
                                  BiconicShape, ToroidalShape>;
std::ostream& operator<<(std::ostream& os, const PlaneShape& s);
std::ostream& operator<<(std::ostream& os, const SphereShape& s);
std::ostream& operator<<(std::ostream& os, const ConicShape& s);
std::ostream& operator<<(std::ostream& os, const EvenAsphereShape& s);
std::ostream& operator<<(std::ostream& os, const BiconicShape& s);
std::ostream& operator<<(std::ostream& os, const ToroidalShape& s);
std::ostream& operator<<(std::ostream& os, const SurfaceShape& s);

// True for the surfaces of revolution about z (every shape but the anamorphic ones).
bool isRotational(const SurfaceShape& shape);

// The simplest shape that represents the given parameters exactly: a plane when c == 0 and
// every a[i] == 0 (the conic constant of a flat surface has no effect), a sphere when also
// k == 0, a conic when only the a[i] vanish, an even asphere otherwise (a[0] r^2 curves a
// flat base, so it makes an asphere too).
// Terms over w need 1 + k >= 0 (each is then monotone in r, which the intersections rely
// on): std::invalid_argument otherwise.
SurfaceShape makeShape(double curvature, double conic, const std::array<double, 10>& asphere,
                       const std::array<double, 9>& odd = {},
                       const std::array<double, 10>& overW = {});

// Sag z at radial distance squared rSq (mm^2) of a surface of revolution. NaN outside the
// conic's domain. An anamorphic shape has no such sag: std::logic_error (use sagAt()).
double sag(const SurfaceShape& shape, double rSq);
// Sag z at (x, y), every shape. NaN outside the shape's domain.
double sagAt(const SurfaceShape& shape, double x, double y);
// Unit normal at a point on (or near) the surface; +z at the vertex.
Vec3 surfaceNormal(const SurfaceShape& shape, const Vec3& point);
// Largest radial distance where the surface is defined (infinite for planes, paraboloids,
// hyperboloids and aspheres without a conic limit). For an anamorphic shape, the smaller of
// the limits along its x and y sections.
double maxRadius(const SurfaceShape& shape);

// Even aspheres have no closed-form intersection; their roots are searched for on the part
// of the ray with radial distance below min(maxRadius, rMax, kAsphereSearchRadiusMm). The
// limit only matters for aspheres on a paraboloid or hyperboloid base (or a flat one)
// traced sequentially or with an infinite rMax.
inline constexpr double kAsphereSearchRadiusMm = 1e6;

// Sequential intersection: the crossing of the surface sheet nearest to where the ray meets
// the vertex tangent plane (the Spencer and Murty convention). The distance t along the
// ray may be negative (virtual segments are allowed in sequential tracing). nullopt if the
// ray misses the surface. A ray parallel to the tangent plane takes the crossing nearest
// to its origin.
std::optional<double> intersectSequential(const SurfaceShape& shape, const Ray& localRay);

// Nonsequential intersection: the smallest t in (tMin, tMax] where the ray crosses the sheet
// at radial distance r <= rMax. Rays that start on the surface pass tMin = 0 with
// `startsOnSurface` set, so the crossing at t ~ 0 is skipped without an epsilon offset; the
// ray can still meet the same surface again elsewhere (a chord inside a curved surface).
// A point on the edge r == rMax counts as inside, also after the rounding of the hit point
// (a few units in the last place of the ray's coordinates).
struct ShapeHit {
    double t = 0.0;
    Vec3 point{0.0};
    Vec3 normal{0.0};  // unit, +z at the vertex
};
std::ostream& operator<<(std::ostream& os, const ShapeHit& h);

std::optional<ShapeHit> intersectFirst(const SurfaceShape& shape, const Ray& localRay, double tMin,
                                       double tMax, double rMax, bool startsOnSurface);

}  // namespace veil
