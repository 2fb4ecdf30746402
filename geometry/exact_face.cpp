#include "geometry/exact_face.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <type_traits>

#include "geometry/anamorphic.h"
#include "geometry/numerics.h"

namespace veil {

namespace {

constexpr double kEpsilon = std::numeric_limits<double>::epsilon();

// Tessellation and section sampling are capped so a silly tolerance cannot exhaust memory.
constexpr int kMaxRings = 2048;
constexpr int kMaxSegments = 4096;
constexpr int kMinSegments = 8;
// Samples of the profile used to bound an asphere's curvature (tessellation) and
// subintervals of the interval enclosure of its sag (bounds).
constexpr int kCurvatureSamples = 4096;
constexpr int kSagEnclosurePieces = 1024;
// An asphere's sampled curvature bound is multiplied by this (the samples may miss the
// maximum between them by a little).
constexpr double kCurvatureSafety = 1.25;
// A hit that falls outside the aperture (in a hole, or outside a rectangle within its
// bounding circle) is followed to the next crossing of the same shape at most this often.
constexpr int kMaxContinuations = 16;

// Edge allowance of a hit point computed as p + s d, the same as intersectFirst() grants at
// rMax: a few ulps of the magnitudes involved. Faces that share an edge (an optical face and
// its flat, a flat and the edge cylinder) therefore overlap by a few ulps instead of leaving
// a gap a ray could slip through.
double edgeSlack(double size, double magnitude) { return 8.0 * kEpsilon * (size + magnitude); }

bool insideAperture(const Aperture& aperture, double x, double y, double magnitude) {
    return std::visit(
        [&](const auto& a) -> bool {
            using A = std::decay_t<decltype(a)>;
            const double rSq = x * x + y * y;
            if constexpr (std::is_same_v<A, CircularAperture>) {
                const double r = a.radiusMm + edgeSlack(a.radiusMm, magnitude);
                return rSq <= r * r;
            } else if constexpr (std::is_same_v<A, AnnularAperture>) {
                const double slack = edgeSlack(a.outerRadiusMm, magnitude);
                const double ro = a.outerRadiusMm + slack;
                const double ri = std::max(0.0, a.innerRadiusMm - slack);
                return rSq >= ri * ri && rSq <= ro * ro;
            } else {
                const double slack = edgeSlack(std::max(a.halfWidthMm, a.halfHeightMm), magnitude);
                return std::abs(x) <= a.halfWidthMm + slack &&
                       std::abs(y) <= a.halfHeightMm + slack;
            }
        },
        aperture);
}

// Range of u = r^2 an aperture covers (the rectangle's corners included).
void apertureRadiusSqRange(const Aperture& aperture, double& uLo, double& uHi) {
    std::visit(
        [&](const auto& a) {
            using A = std::decay_t<decltype(a)>;
            if constexpr (std::is_same_v<A, CircularAperture>) {
                uLo = 0.0;
                uHi = a.radiusMm * a.radiusMm;
            } else if constexpr (std::is_same_v<A, AnnularAperture>) {
                uLo = a.innerRadiusMm * a.innerRadiusMm;
                uHi = a.outerRadiusMm * a.outerRadiusMm;
            } else {
                uLo = 0.0;
                uHi = a.halfWidthMm * a.halfWidthMm + a.halfHeightMm * a.halfHeightMm;
            }
        },
        aperture);
}

// Base conic (c, k) and polynomial coefficients of any shape.
struct ShapeParts {
    double c = 0.0;
    double k = 0.0;
    std::array<double, 10> a{};
    std::array<double, 9> b{};   // odd terms, b[j] r^(2j+3)
    std::array<double, 10> e{};  // terms over w, e[i] r^(2i+2) / w
    bool hasPolynomial = false;
};
ShapeParts partsOf(const SurfaceShape& shape) {
    return std::visit(
        [](const auto& s) -> ShapeParts {
            using S = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<S, PlaneShape>) {
                return {};
            } else if constexpr (std::is_same_v<S, SphereShape>) {
                return {s.curvature, 0.0, {}, {}, {}, false};
            } else if constexpr (std::is_same_v<S, ConicShape>) {
                return {s.curvature, s.conic, {}, {}, {}, false};
            } else if constexpr (std::is_same_v<S, BiconicShape> ||
                                 std::is_same_v<S, ToroidalShape>) {
                // Exact faces are surfaces of revolution; lens solids refuse anamorphic
                // surfaces before they get here (geometry/lens_solid.h).
                throw std::logic_error("exact face of an anamorphic shape");
            } else {
                const auto nonzero = [](double v) { return v != 0.0; };
                const bool poly =
                    std::any_of(s.coefficients.begin(), s.coefficients.end(), nonzero) ||
                    std::any_of(s.odd.begin(), s.odd.end(), nonzero) ||
                    std::any_of(s.overW.begin(), s.overW.end(), nonzero);
                return {s.curvature, s.conic, s.coefficients, s.odd, s.overW, poly};
            }
        },
        shape);
}

// Largest u where the sag is defined (infinite for planes, paraboloids, hyperboloids).
double domainRadiusSq(const SurfaceShape& shape) {
    const double r = maxRadius(shape);
    return std::isfinite(r) ? r * r : std::numeric_limits<double>::infinity();
}

// The range of u = x^2 + y^2 a patch covers: its aperture's, ending at the shape's rim.
void patchRadiusSqRange(const SurfacePatch& f, double& uLo, double& uHi) {
    apertureRadiusSqRange(f.aperture, uLo, uHi);
    uHi = std::min(uHi, domainRadiusSq(f.shape));
    uLo = std::min(uLo, uHi);
}

// Sag at u clamped into the shape's domain (a tessellation or section vertex that rounding or
// a rectangle's corner puts just beyond a sphere's rim sits on the rim).
double sagClamped(const SurfaceShape& shape, double u) {
    const double uMax = domainRadiusSq(shape);
    return sag(shape, std::min(u, uMax));
}
// The same at (x, y), for every shape: an anamorphic shape's point is pulled onto the radius
// of its domain's limit.
double sagClampedAt(const SurfaceShape& shape, double x, double y) {
    if (isRotational(shape)) return sagClamped(shape, x * x + y * y);
    const double u = x * x + y * y, uMax = domainRadiusSq(shape);
    if (u > uMax) {
        const double f = std::sqrt(uMax / u);
        x *= f;
        y *= f;
    }
    return sagAt(shape, x, y);
}

// Curvature bound M of the height field z = S(x^2 + y^2) over u in [uLo, uHi]: the largest
// |eigenvalue| of its Hessian, which in polar form are the radial curvature
// z''(r) = 2 S' + 4 u S'' and the tangential one z'(r) / r = 2 S'. For a conic
// S' = c / (2 w), S'' = c K / (4 w^3) with w = sqrt(1 - K u), K = (1 + k) c^2, so the
// eigenvalues are c / w^3 and c / w, monotone in u: their extremes sit at the ends of the
// range. An asphere's polynomial makes them arbitrary: they are sampled densely and the
// maximum multiplied by kCurvatureSafety. Infinite at an ellipsoid's rim (w = 0).
double curvatureBound(const SurfaceShape& shape, double uLo, double uHi) {
    if (!isRotational(shape)) return anamorphicCurvatureBound(shape, std::sqrt(uHi));
    const ShapeParts p = partsOf(shape);
    const double bigK = (1.0 + p.k) * p.c * p.c;
    auto eigen = [&](double u) {
        const double w = std::sqrt(std::max(0.0, 1.0 - bigK * u));
        double s1 = p.c / (2.0 * w);                 // S'
        double s2 = p.c * bigK / (4.0 * w * w * w);  // S''
        if (p.c == 0.0) s1 = s2 = 0.0;
        double pow = 1.0;  // u^i
        for (int i = 0; i < 10; ++i) {
            if (p.a[i] != 0.0) {
                s1 += (i + 1) * p.a[i] * pow;
                if (i >= 1) s2 += (i + 1) * i * p.a[i] * pow / u;
            }
            pow *= u;
        }
        if (u == 0.0) {  // the u^(i-1) terms above: only i = 1 survives at u = 0
            s2 = p.c == 0.0 ? 0.0 : p.c * bigK / 4.0;
            s2 += 2.0 * p.a[1];
        }
        // Terms over w, g = e u^n / w (n = i + 1): g' = n u^(n-1) / w + u^n K / (2 w^3),
        // g'' = n (n-1) u^(n-2) / w + n u^(n-1) K / w^3 + 3 K^2 u^n / (4 w^5).
        {
            double un1 = 1.0;  // u^(n-1)
            for (int i = 0; i < 10; ++i) {
                const int n = i + 1;
                const double un = un1 * u;
                if (p.e[i] != 0.0) {
                    const double w3 = w * w * w;
                    s1 += p.e[i] * (n * un1 / w + un * bigK / (2.0 * w3));
                    const double un2 = n >= 2 ? std::pow(u, n - 2) : 0.0;  // u^(n-2)
                    s2 += p.e[i] * (n * (n - 1) * un2 / w + n * un1 * bigK / w3 +
                                    3.0 * bigK * bigK * un / (4.0 * w3 * w * w));
                }
                un1 = un;
            }
        }
        // The odd terms b r^n (n = 2j + 3) in r directly: radial z'' = n (n - 1) b r^(n-2),
        // tangential z' / r = n b r^(n-2), both finite on the axis.
        double radial = 0.0, tangential = 0.0;
        const double r = std::sqrt(u);
        double rPow = r;  // r^(n-2)
        for (int j = 0; j < 9; ++j) {
            const double n = 2.0 * j + 3.0;
            radial += n * (n - 1.0) * p.b[j] * rPow;
            tangential += n * p.b[j] * rPow;
            rPow *= u;
        }
        return std::max(std::abs(2.0 * s1 + 4.0 * u * s2 + radial),
                        std::abs(2.0 * s1 + tangential));
    };
    if (!p.hasPolynomial) return std::max(eigen(uLo), eigen(uHi));
    double m = 0.0;
    const double rLo = std::sqrt(uLo), rHi = std::sqrt(uHi);
    for (int i = 0; i <= kCurvatureSamples; ++i) {
        const double r = rLo + (rHi - rLo) * i / kCurvatureSamples;
        m = std::max(m, eigen(std::min(r * r, uHi)));
    }
    return kCurvatureSafety * m;
}

}  // namespace

// Enclosure of the sag over u in [uLo, uHi]. The conic part, every term a[i] u^(i+1) and every
// odd term b[j] u^(j+1.5) are monotone in u >= 0, so over a subinterval each lies between its values at the ends; the
// sum of those ranges encloses the sag. Summed over kSagEnclosurePieces subintervals the
// overestimate is small, and the result is widened by a few ulps of the magnitudes, so it is
// a safe bound rather than a sampled guess.
void sagRange(const SurfaceShape& shape, double uLo, double uHi, double& zLo, double& zHi) {
    if (const auto* b = std::get_if<BiconicShape>(&shape))
        return anamorphicSagRange(*b, uLo, uHi, zLo, zHi);
    if (const auto* t = std::get_if<ToroidalShape>(&shape))
        return anamorphicSagRange(*t, uLo, uHi, zLo, zHi);
    const ShapeParts p = partsOf(shape);
    const SurfaceShape base = makeShape(p.c, p.k, {});
    if (!p.hasPolynomial) {
        const double z0 = sag(base, uLo), z1 = sag(base, uHi);
        const double slack = 8.0 * kEpsilon * std::max(std::abs(z0), std::abs(z1));
        zLo = std::min(z0, z1) - slack;
        zHi = std::max(z0, z1) + slack;
        return;
    }
    zLo = std::numeric_limits<double>::infinity();
    zHi = -zLo;
    for (int j = 0; j < kSagEnclosurePieces; ++j) {
        const double u0 = uLo + (uHi - uLo) * j / kSagEnclosurePieces;
        const double u1 =
            j + 1 == kSagEnclosurePieces ? uHi : uLo + (uHi - uLo) * (j + 1) / kSagEnclosurePieces;
        const double c0 = sag(base, u0), c1 = sag(base, u1);
        double lo = std::min(c0, c1), hi = std::max(c0, c1);
        double magnitude = std::max(std::abs(c0), std::abs(c1));
        // A term monotone in u lies between its values t0, t1 at the piece's ends.
        auto widen = [&](double t0, double t1) {
            lo += std::min(t0, t1);
            hi += std::max(t0, t1);
            magnitude += std::max(std::abs(t0), std::abs(t1));
        };
        double pow0 = u0, pow1 = u1;
        for (int i = 0; i < 10; ++i) {
            widen(p.a[i] * pow0, p.a[i] * pow1);
            pow0 *= u0;
            pow1 *= u1;
        }
        // Terms over w (a sphere or ellipsoid base, K >= 0): e u^(i+1) / w is monotone too.
        const double bigK = (1.0 + p.k) * p.c * p.c;
        const double w0 = std::sqrt(std::max(0.0, 1.0 - bigK * u0));
        const double w1 = std::sqrt(std::max(0.0, 1.0 - bigK * u1));
        pow0 = u0;
        pow1 = u1;
        for (int i = 0; i < 10; ++i) {
            // Skipped when zero: 0 / w at an ellipsoid's rim (w = 0) would be NaN.
            if (p.e[i] != 0.0) widen(p.e[i] * pow0 / w0, p.e[i] * pow1 / w1);
            pow0 *= u0;
            pow1 *= u1;
        }
        double odd0 = u0 * std::sqrt(u0), odd1 = u1 * std::sqrt(u1);  // u^(j+1.5)
        for (int i = 0; i < 9; ++i) {
            widen(p.b[i] * odd0, p.b[i] * odd1);
            odd0 *= u0;
            odd1 *= u1;
        }
        const double slack = 32.0 * kEpsilon * magnitude;
        zLo = std::min(zLo, lo - slack);
        zHi = std::max(zHi, hi + slack);
    }
}

namespace {

// Surface Patch Intersection

// The shape's first crossing within the aperture's bounding circle, then the aperture test.
// A crossing outside the aperture (in an annulus's hole, outside a rectangle) is not the end:
// the same shape can be crossed again further on (a ray through the hole of a curved
// primary mirror meets the ring on the far side), so the search resumes from that crossing
// as a ray starting on the surface, which skips it without an epsilon.
std::optional<ShapeHit> intersectPatch(const SurfacePatch& patch, const Ray& ray, double tMin,
                                       double tMax, bool startsOnFace) {
    const double rMax = apertureBoundingRadius(patch.aperture);
    std::optional<ShapeHit> hit = intersectFirst(patch.shape, ray, tMin, tMax, rMax, startsOnFace);
    const double originSize = glm::length(ray.origin);
    for (int i = 0; hit && i < kMaxContinuations; ++i) {
        if (insideAperture(patch.aperture, hit->point.x, hit->point.y,
                           originSize + std::abs(hit->t))) {
            return hit;
        }
        const Ray onward{hit->point, ray.direction};
        std::optional<ShapeHit> next =
            intersectFirst(patch.shape, onward, 0.0, tMax - hit->t, rMax, true);
        if (!next) return std::nullopt;
        next->t += hit->t;
        if (!(next->t > hit->t && next->t <= tMax)) return std::nullopt;
        hit = next;
    }
    return std::nullopt;
}

// Cylinder Patch Intersection
//
// Along the ray o + t d the squared distance from the axis is a t^2 + 2 b t + (|o_xy|^2),
// a = dx^2 + dy^2, b = ox dx + oy dy, and the crossings of r = R solve
//
//     a t^2 + 2 b t + C = 0,   C = ox^2 + oy^2 - R^2.
//
// A ray from elsewhere is solved from its point nearest the axis, p = o + tRef d with
// tRef = -b / a: there the linear term vanishes and the roots are s = -+sqrt(-C_p / a), with
// no cancellation between terms; an error of C_p moves the hit along the ray but only by
// C_p / (2 R) off the cylinder, so even grazing rays keep the residual at rounding level.
// A ray that starts on the cylinder is solved from its origin, where C ~ 0 and one root is
// the origin itself. The cylinder is convex: a ray leaving it (b >= 0) never meets it again,
// and one entering it (b < 0) meets it once more at q / a with q = -b + sqrt(b^2 - a C) > 0,
// the root of larger magnitude (the origin's own root is C / q). No epsilon is involved.
bool crossCylinder(const CylinderPatch& cyl, const Ray& ray, double tMin, double tMax,
                   bool startsOnFace, double& tOut, Vec3& pointOut) {
    const Vec3& o = ray.origin;
    const Vec3& d = ray.direction;
    const double a = d.x * d.x + d.y * d.y;
    if (a == 0.0) return false;  // parallel to the axis
    const double radius = cyl.radiusMm;
    // R^2 as an unevaluated sum hi + lo, so C does not inherit the rounding of R * R.
    const double rSqHi = radius * radius;
    const double rSqLo = std::fma(radius, radius, -rSqHi);

    double tRef = 0.0;
    Vec3 p = o;
    std::array<double, 2> roots{};
    int count = 0;
    if (startsOnFace) {
        const double b = o.x * d.x + o.y * d.y;
        if (!(b < 0.0)) return false;
        const double c = std::fma(o.x, o.x, std::fma(o.y, o.y, -rSqHi)) - rSqLo;
        const double disc = differenceOfProducts(b, b, a, c);
        const double q = -b + std::sqrt(std::max(disc, 0.0));
        roots[count++] = q / a;
    } else {
        tRef = -(o.x * d.x + o.y * d.y) / a;
        p = o + tRef * d;
        const double c = std::fma(p.x, p.x, std::fma(p.y, p.y, -rSqHi)) - rSqLo;
        if (c > 0.0) return false;
        const double s = std::sqrt(-c / a);
        roots[count++] = -s;
        roots[count++] = s;
    }
    const double zSize = std::max(std::abs(cyl.zMinMm), std::abs(cyl.zMaxMm));
    const double pSize = glm::length(p);
    for (int i = 0; i < count; ++i) {
        const double s = roots[i];
        const double t = tRef + s;
        if (!(t > tMin && t <= tMax)) continue;
        const Vec3 point = p + s * d;
        const double slack = edgeSlack(zSize, pSize + std::abs(s));
        if (point.z < cyl.zMinMm - slack || point.z > cyl.zMaxMm + slack) continue;
        if (cyl.rims) {
            // Between the rim curves, with the same allowance as at a plane rim (the face
            // itself accepts its points a few ulps beyond its circular aperture).
            const RimCurves& rc = *cyl.rims;
            if (rc.lower && point.z < rc.lower->zAt(point.x, point.y) - slack) continue;
            if (rc.upper && point.z > rc.upper->zAt(point.x, point.y) + slack) continue;
        }
        tOut = t;
        pointOut = point;
        return true;
    }
    return false;
}

Vec3 cylinderNormal(const CylinderPatch& cyl, const Vec3& point) {
    Vec3 normal{point.x, point.y, 0.0};
    normal /= std::hypot(point.x, point.y);
    if (!cyl.outward) normal = -normal;
    return normal;
}

std::optional<ShapeHit> intersectCylinder(const CylinderPatch& cyl, const Ray& ray, double tMin,
                                          double tMax, bool startsOnFace) {
    double t;
    Vec3 point;
    if (!crossCylinder(cyl, ray, tMin, tMax, startsOnFace, t, point)) return std::nullopt;
    return ShapeHit{t, point, cylinderNormal(cyl, point)};
}

// Tessellation

// Sample spacing along an edge (a polyline or a triangle side) for which linear
// interpolation stays within `tolerance` of a height field of curvature bound M: infinite
// for a flat one.
double spacingFor(double tolerance, double curvature, double factor) {
    if (!(curvature > 0.0)) return std::numeric_limits<double>::infinity();
    return std::sqrt(factor * tolerance / curvature);
}

// Angle step of a polygon inscribed in a circle of radius r whose sides stay within
// `tolerance` of the circle: r (1 - cos(step / 2)) <= tolerance.
double angleStepFor(double tolerance, double radius) {
    if (tolerance >= radius) return std::numbers::pi;
    return 2.0 * std::acos(1.0 - tolerance / radius);
}

int clampCount(double n, int lo, int hi) {
    if (!(n < hi)) return hi;
    return std::max(lo, static_cast<int>(std::ceil(n)));
}

// Polar grid over a disc or annulus: rings between rInner and rOuter, the same number of
// segments on each. Vertices lie on the surface; triangles are counter-clockwise seen from
// +z, so their normals follow the patch's (+z at the vertex).
TriangleMesh tessellatePolar(const SurfacePatch& patch, double rInner, double rOuter,
                             double tolerance) {
    const double uLo = rInner * rInner, uHi = rOuter * rOuter;
    const double curvature = curvatureBound(patch.shape, uLo, uHi);
    // Triangles of the grid have sides at most h, h^2 = dr^2 + (rOuter dphi)^2, so their
    // smallest enclosing circle has radius <= h / sqrt(3); linear interpolation deviates by at
    // most M rho^2 / 2 <= M h^2 / 6 (Waldron's bound). dr and rOuter dphi <= sqrt(3 tol / M)
    // keep that within tol.
    const double spacing = spacingFor(tolerance, curvature, 3.0);
    double dphi = angleStepFor(tolerance, rOuter);
    if (std::isfinite(spacing)) dphi = std::min(dphi, spacing / rOuter);
    int segments = clampCount(2.0 * std::numbers::pi / dphi, kMinSegments, kMaxSegments);
    const int rings = clampCount((rOuter - rInner) / spacing, 1, kMaxRings);
    // The inner rim of an annulus is a polygon circumscribed about the hole, so no triangle
    // reaches into it (the polygon's sides touch the hole's circle); its corners are kept
    // within a quarter of the first ring's width.
    auto innerGrowth = [&](int n) { return rInner / std::cos(std::numbers::pi / n) - rInner; };
    if (rInner > 0.0) {
        const double ringWidth = (rOuter - rInner) / rings;
        while (segments < kMaxSegments && innerGrowth(segments) > 0.25 * ringWidth) {
            segments *= 2;
        }
        segments = std::min(segments, kMaxSegments);
    }

    TriangleMesh mesh;
    auto vertex = [&](double r, double phi) {
        const double x = r * std::cos(phi), y = r * std::sin(phi);
        return Vec3{x, y, sagClampedAt(patch.shape, x, y)};
    };
    // Ring radii: ring 0 is the centre point (disc) or the circumscribed hole polygon.
    std::vector<double> radii(rings + 1);
    for (int i = 0; i <= rings; ++i) radii[i] = rInner + (rOuter - rInner) * i / rings;
    radii[rings] = rOuter;
    if (rInner > 0.0) radii[0] = rInner / std::cos(std::numbers::pi / segments);
    const double dAngle = 2.0 * std::numbers::pi / segments;
    const bool disc = rInner == 0.0;
    std::vector<uint32_t> firstOfRing(rings + 1);
    for (int i = 0; i <= rings; ++i) {
        firstOfRing[i] = static_cast<uint32_t>(mesh.vertices.size());
        if (disc && i == 0) {
            mesh.vertices.push_back(Vec3{0.0, 0.0, sagClampedAt(patch.shape, 0.0, 0.0)});
            continue;
        }
        for (int j = 0; j < segments; ++j) mesh.vertices.push_back(vertex(radii[i], j * dAngle));
    }
    auto at = [&](int ring, int seg) { return firstOfRing[ring] + (seg % segments); };
    for (int i = 0; i < rings; ++i) {
        for (int j = 0; j < segments; ++j) {
            if (disc && i == 0) {
                mesh.triangles.push_back({firstOfRing[0], at(1, j), at(1, j + 1)});
                continue;
            }
            const uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), e = at(i, j + 1);
            mesh.triangles.push_back({a, b, c});
            mesh.triangles.push_back({a, c, e});
        }
    }
    return mesh;
}

// Rectangular aperture: a regular grid, each cell split along a diagonal. A cell's right
// triangles have their smallest enclosing circle on the hypotenuse, radius
// sqrt(hx^2 + hy^2) / 2, so the deviation is at most M (hx^2 + hy^2) / 8 <= tol when hx, hy
// <= sqrt(4 tol / M). The outline is exact.
TriangleMesh tessellateRectangle(const SurfacePatch& patch, const RectangularAperture& rect,
                                 double tolerance) {
    const double uHi = rect.halfWidthMm * rect.halfWidthMm + rect.halfHeightMm * rect.halfHeightMm;
    const double spacing = spacingFor(tolerance, curvatureBound(patch.shape, 0.0, uHi), 4.0);
    const int nx = clampCount(2.0 * rect.halfWidthMm / spacing, 1, kMaxRings);
    const int ny = clampCount(2.0 * rect.halfHeightMm / spacing, 1, kMaxRings);
    TriangleMesh mesh;
    for (int j = 0; j <= ny; ++j) {
        const double y =
            j == ny ? rect.halfHeightMm : -rect.halfHeightMm + 2.0 * rect.halfHeightMm * j / ny;
        for (int i = 0; i <= nx; ++i) {
            const double x =
                i == nx ? rect.halfWidthMm : -rect.halfWidthMm + 2.0 * rect.halfWidthMm * i / nx;
            mesh.vertices.push_back(Vec3{x, y, sagClampedAt(patch.shape, x, y)});
        }
    }
    auto at = [&](int i, int j) { return static_cast<uint32_t>(j * (nx + 1) + i); };
    for (int j = 0; j < ny; ++j) {
        for (int i = 0; i < nx; ++i) {
            mesh.triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
            mesh.triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
        }
    }
    return mesh;
}

// The lower (upper = false) or upper limit of a cylinder at (x, y) on it.
double rimZ(const CylinderPatch& cyl, bool upper, double x, double y) {
    if (cyl.rims) {
        const std::optional<RimCurve>& c = upper ? cyl.rims->upper : cyl.rims->lower;
        if (c) return c->zAt(x, y);
    }
    return upper ? cyl.zMaxMm : cyl.zMinMm;
}

// The side wall as a prism inscribed in the cylinder: straight along z (exact), its sides
// within tol of the circle. Triangles face along the patch's normal.
TriangleMesh tessellateCylinder(const CylinderPatch& cyl, double tolerance) {
    const double dphi = angleStepFor(tolerance, cyl.radiusMm);
    const int segments = clampCount(2.0 * std::numbers::pi / dphi, kMinSegments, kMaxSegments);
    TriangleMesh mesh;
    for (int j = 0; j < segments; ++j) {
        const double phi = 2.0 * std::numbers::pi * j / segments;
        const double x = cyl.radiusMm * std::cos(phi), y = cyl.radiusMm * std::sin(phi);
        mesh.vertices.push_back(Vec3{x, y, rimZ(cyl, false, x, y)});
        mesh.vertices.push_back(Vec3{x, y, rimZ(cyl, true, x, y)});
    }
    for (int j = 0; j < segments; ++j) {
        const auto lo0 = static_cast<uint32_t>(2 * j), hi0 = lo0 + 1;
        const auto lo1 = static_cast<uint32_t>(2 * ((j + 1) % segments)), hi1 = lo1 + 1;
        if (cyl.outward) {
            mesh.triangles.push_back({lo0, lo1, hi1});
            mesh.triangles.push_back({lo0, hi1, hi0});
        } else {
            mesh.triangles.push_back({lo0, hi1, lo1});
            mesh.triangles.push_back({lo0, hi0, hi1});
        }
    }
    return mesh;
}

// Section

// The profile z = sag(0, y) for y in [y0, y1], sampled so that the polyline stays within tol
// of it: |z''| <= M, so a chord of length dy deviates by at most M dy^2 / 8.
std::vector<Vec2> profile(const SurfaceShape& shape, double y0, double y1, double tolerance) {
    const double uLo = (y0 <= 0.0 && y1 >= 0.0) ? 0.0 : std::min(y0 * y0, y1 * y1);
    const double uHi = std::max(y0 * y0, y1 * y1);
    const double spacing = spacingFor(tolerance, curvatureBound(shape, uLo, uHi), 8.0);
    const int n = clampCount((y1 - y0) / spacing, 1, kMaxSegments);
    std::vector<Vec2> out;
    out.reserve(n + 1);
    for (int i = 0; i <= n; ++i) {
        const double y = i == n ? y1 : y0 + (y1 - y0) * i / n;
        out.push_back(Vec2{y, sagClampedAt(shape, 0.0, y)});
    }
    return out;
}

void requirePositive(double tolerance) {
    if (!(tolerance > 0.0)) {
        throw std::invalid_argument("chord tolerance must be > 0 mm (got " +
                                    std::to_string(tolerance) + ")");
    }
}

}  // namespace

// Printing

std::ostream& operator<<(std::ostream& os, const FaceGeometry& f) {
    std::visit(
        [&os](const auto& face) {
            using F = std::decay_t<decltype(face)>;
            if constexpr (std::is_same_v<F, SurfacePatch>) {
                os << "SurfacePatch{" << face.shape << ", " << face.aperture << "}";
            } else {
                os << "CylinderPatch{radius " << face.radiusMm << " mm, z " << face.zMinMm << " .. "
                   << face.zMaxMm << " mm, " << (face.outward ? "outward" : "inward");
                if (face.rims && face.rims->lower)
                    os << ", lower rim on " << face.rims->lower->shape;
                if (face.rims && face.rims->upper)
                    os << ", upper rim on " << face.rims->upper->shape;
                os << "}";
            }
        },
        f);
    return os;
}

// Exact Face Functions

std::optional<ShapeHit> intersectFace(const FaceGeometry& face, const Ray& localRay, double tMin,
                                      double tMax, bool startsOnFace) {
    return std::visit(
        [&](const auto& f) -> std::optional<ShapeHit> {
            using F = std::decay_t<decltype(f)>;
            if constexpr (std::is_same_v<F, SurfacePatch>) {
                return intersectPatch(f, localRay, tMin, tMax, startsOnFace);
            } else {
                return intersectCylinder(f, localRay, tMin, tMax, startsOnFace);
            }
        },
        face);
}

Vec3 faceNormal(const FaceGeometry& face, const Vec3& localPoint) {
    if (const auto* cyl = std::get_if<CylinderPatch>(&face))
        return cylinderNormal(*cyl, localPoint);
    return surfaceNormal(std::get<SurfacePatch>(face).shape, localPoint);
}

PreparedFace::PreparedFace(const FaceGeometry& face) {
    if (std::holds_alternative<CylinderPatch>(face)) {
        kind_ = Kind::Cylinder;
        return;
    }
    const SurfacePatch& patch = std::get<SurfacePatch>(face);
    if (std::holds_alternative<RectangularAperture>(patch.aperture))
        return;  // General: a circle or a ring is what the crossings below assume
    rMax_ = apertureBoundingRadius(patch.aperture);
    if (std::holds_alternative<PlaneShape>(patch.shape)) {
        kind_ = Kind::Plane;
    } else if (const auto* sphere = std::get_if<SphereShape>(&patch.shape)) {
        kind_ = Kind::Conic;
        conic_ = {sphere->curvature, 0.0};
    } else if (const auto* conic = std::get_if<ConicShape>(&patch.shape)) {
        kind_ = Kind::Conic;
        conic_ = {conic->curvature, conic->conic};
    } else if (const auto* asphere = std::get_if<EvenAsphereShape>(&patch.shape)) {
        const auto zero = [](const auto& a) {
            return std::all_of(a.begin(), a.end(), [](double v) { return v == 0.0; });
        };
        // intersectFirst() solves an asphere without terms as its conic.
        if (zero(asphere->coefficients) && zero(asphere->odd) && zero(asphere->overW)) {
            kind_ = Kind::Conic;
            conic_ = {asphere->curvature, asphere->conic};
        }
    }
}

bool PreparedFace::cross(const FaceGeometry& face, const Ray& localRay, double tMin, double tMax,
                         bool startsOnFace, FaceCrossing& out) const {
    out.hasNormal = false;
    switch (kind_) {
        case Kind::Cylinder:
            return crossCylinder(*std::get_if<CylinderPatch>(&face), localRay, tMin, tMax,
                                 startsOnFace, out.t, out.point);
        case Kind::Plane: {
            // intersectFirst()'s plane, then intersectPatch()'s aperture test: a plane met
            // outside its aperture is not met again.
            const Vec3& o = localRay.origin;
            const Vec3& d = localRay.direction;
            if (startsOnFace || d.z == 0.0) return false;
            const double t = -o.z / d.z;
            if (!(t > tMin && t <= tMax)) return false;
            const Vec3 point{o.x + t * d.x, o.y + t * d.y, 0.0};
            const double originSize = glm::length(o);
            if (!root_search::withinRadius(point, rMax_, originSize + std::abs(t))) return false;
            if (!insideAperture(std::get_if<SurfacePatch>(&face)->aperture, point.x, point.y,
                                originSize + std::abs(t)))
                return false;
            out.t = t;
            out.point = point;
            return true;
        }
        case Kind::Conic: {
            if (!conicFirstCrossing(conic_, localRay, tMin, tMax, rMax_, startsOnFace, out.t,
                                    out.point))
                return false;
            if (insideAperture(std::get_if<SurfacePatch>(&face)->aperture, out.point.x, out.point.y,
                               glm::length(localRay.origin) + std::abs(out.t)))
                return true;
            break;  // in a hole: the next crossing, as intersectPatch() finds it
        }
        case Kind::General:
            break;
    }
    const auto hit = intersectFace(face, localRay, tMin, tMax, startsOnFace);
    if (!hit) return false;
    out.t = hit->t;
    out.point = hit->point;
    out.normal = hit->normal;
    out.hasNormal = true;
    return true;
}

// Bounds are padded by a relative 1e-9 so that hits the intersection accepts a few ulps
// beyond an edge (see edgeSlack) stay inside them.
Bounds3 faceBounds(const FaceGeometry& face) {
    Bounds3 b;
    std::visit(
        [&b](const auto& f) {
            using F = std::decay_t<decltype(f)>;
            if constexpr (std::is_same_v<F, SurfacePatch>) {
                double uLo, uHi;
                patchRadiusSqRange(f, uLo, uHi);
                double zLo, zHi;
                sagRange(f.shape, uLo, uHi, zLo, zHi);
                double hx, hy;
                if (const auto* rect = std::get_if<RectangularAperture>(&f.aperture)) {
                    hx = rect->halfWidthMm;
                    hy = rect->halfHeightMm;
                } else {
                    hx = hy = apertureBoundingRadius(f.aperture);
                }
                b.extend(Vec3{-hx, -hy, zLo});
                b.extend(Vec3{hx, hy, zHi});
            } else {
                b.extend(Vec3{-f.radiusMm, -f.radiusMm, f.zMinMm});
                b.extend(Vec3{f.radiusMm, f.radiusMm, f.zMaxMm});
            }
        },
        face);
    const Vec3 size = b.hi - b.lo;
    const double pad =
        1e-9 * (1.0 + std::max({size.x, size.y, size.z, glm::length(b.lo), glm::length(b.hi)}));
    b.lo -= Vec3(pad);
    b.hi += Vec3(pad);
    return b;
}

namespace {

// The x, y box of the annular sector r in [r0, r1], azimuth in [phi0, phi1] (phi1 - phi0 <=
// 2 pi): its corners, plus the outer radius where the sector crosses an axis direction.
void sectorXY(double r0, double r1, double phi0, double phi1, Bounds3& b, double zLo, double zHi) {
    auto add = [&](double r, double phi) {
        b.extend(Vec3{r * std::cos(phi), r * std::sin(phi), zLo});
        b.extend(Vec3{r * std::cos(phi), r * std::sin(phi), zHi});
    };
    add(r0, phi0);
    add(r0, phi1);
    add(r1, phi0);
    add(r1, phi1);
    for (int q = 0; q < 8; ++q) {  // axis directions, from -2 pi to 2 pi
        const double axis = (q - 4) * (M_PI / 2.0);
        if (axis > phi0 && axis < phi1) add(r1, axis);
    }
}

void padBox(Bounds3& b) {
    const Vec3 size = b.hi - b.lo;
    const double pad =
        1e-9 * (1.0 + std::max({size.x, size.y, size.z, glm::length(b.lo), glm::length(b.hi)}));
    b.lo -= Vec3(pad);
    b.hi += Vec3(pad);
}

}  // namespace

std::vector<Bounds3> facePieceBounds(const FaceGeometry& face) {
    std::vector<Bounds3> out;
    const double dPhi = 2.0 * M_PI / kFaceSectors;
    std::visit(
        [&](const auto& f) {
            using F = std::decay_t<decltype(f)>;
            if constexpr (std::is_same_v<F, SurfacePatch>) {
                if (std::holds_alternative<RectangularAperture>(f.aperture)) {
                    out.push_back(faceBounds(face));
                    return;
                }
                double uLo, uHi;
                patchRadiusSqRange(f, uLo, uHi);
                const double rLo = std::sqrt(uLo), rHi = std::sqrt(uHi);
                const bool flat = std::holds_alternative<PlaneShape>(f.shape);
                if (flat && rLo == 0.0) {
                    out.push_back(faceBounds(face));
                    return;
                }
                // Radial bands: a disc keeps a central piece (no sectors there: every sector
                // box would reach the axis); the rest is split in rings and sectors.
                const int rings = flat ? 1 : kFaceRings;
                std::vector<double> edges;
                for (int i = 0; i <= rings; ++i) edges.push_back(rLo + (rHi - rLo) * i / rings);
                edges.back() = rHi;
                for (int i = 0; i < rings; ++i) {
                    const double r0 = edges[i], r1 = edges[i + 1];
                    double zLo, zHi;
                    sagRange(f.shape, r0 * r0, std::min(r1 * r1, uHi), zLo, zHi);
                    if (r0 == 0.0) {
                        Bounds3 b;
                        b.extend(Vec3{-r1, -r1, zLo});
                        b.extend(Vec3{r1, r1, zHi});
                        padBox(b);
                        out.push_back(b);
                        continue;
                    }
                    for (int k = 0; k < kFaceSectors; ++k) {
                        Bounds3 b;
                        sectorXY(r0, r1, k * dPhi, (k + 1) * dPhi, b, zLo, zHi);
                        padBox(b);
                        out.push_back(b);
                    }
                }
            } else {
                for (int k = 0; k < kFaceSectors; ++k) {
                    Bounds3 b;
                    sectorXY(f.radiusMm, f.radiusMm, k * dPhi, (k + 1) * dPhi, b, f.zMinMm,
                             f.zMaxMm);
                    padBox(b);
                    out.push_back(b);
                }
            }
        },
        face);
    return out;
}

std::vector<FaceBand> faceBands(const FaceGeometry& face, int bands) {
    if (bands < 1) throw std::invalid_argument("faceBands: bands must be >= 1");
    std::vector<FaceBand> out;
    auto push = [&out](double rLo, double rHi, double zLo, double zHi) {
        const double pad = 1e-9 * (1.0 + std::max({rHi, std::abs(zLo), std::abs(zHi)}));
        out.push_back({std::max(0.0, rLo - pad), rHi + pad, zLo - pad, zHi + pad});
    };
    std::visit(
        [&](const auto& f) {
            using F = std::decay_t<decltype(f)>;
            if constexpr (std::is_same_v<F, SurfacePatch>) {
                double uLo, uHi;
                patchRadiusSqRange(f, uLo, uHi);
                const double rLo = std::sqrt(uLo), rHi = std::sqrt(uHi);
                const int n = std::holds_alternative<PlaneShape>(f.shape) ? 1 : bands;
                double r0 = rLo;
                for (int i = 0; i < n; ++i) {
                    const double r1 = i + 1 == n ? rHi : rLo + (rHi - rLo) * (i + 1) / n;
                    double zLo, zHi;
                    sagRange(f.shape, r0 * r0, std::min(r1 * r1, uHi), zLo, zHi);
                    push(r0, r1, zLo, zHi);
                    r0 = r1;
                }
            } else {
                push(f.radiusMm, f.radiusMm, f.zMinMm, f.zMaxMm);
            }
        },
        face);
    return out;
}

TriangleMesh tessellateFace(const FaceGeometry& face, double chordToleranceMm) {
    requirePositive(chordToleranceMm);
    return std::visit(
        [&](const auto& f) -> TriangleMesh {
            using F = std::decay_t<decltype(f)>;
            if constexpr (std::is_same_v<F, SurfacePatch>) {
                if (const auto* rect = std::get_if<RectangularAperture>(&f.aperture)) {
                    return tessellateRectangle(f, *rect, chordToleranceMm);
                }
                double rInner = 0.0, rOuter = apertureBoundingRadius(f.aperture);
                if (const auto* ring = std::get_if<AnnularAperture>(&f.aperture)) {
                    rInner = ring->innerRadiusMm;
                }
                // A sphere or ellipsoid ends at its rim.
                rOuter = std::min(rOuter, maxRadius(f.shape));
                if (!(rOuter > rInner)) return TriangleMesh{};
                return tessellatePolar(f, rInner, rOuter, chordToleranceMm);
            } else {
                return tessellateCylinder(f, chordToleranceMm);
            }
        },
        face);
}

std::vector<std::vector<Vec2>> sectionOfFace(const FaceGeometry& face, double chordToleranceMm) {
    requirePositive(chordToleranceMm);
    std::vector<std::vector<Vec2>> out;
    std::visit(
        [&](const auto& f) {
            using F = std::decay_t<decltype(f)>;
            if constexpr (std::is_same_v<F, SurfacePatch>) {
                const double rim = maxRadius(f.shape);
                if (const auto* ring = std::get_if<AnnularAperture>(&f.aperture)) {
                    const double ro = std::min(ring->outerRadiusMm, rim);
                    const double ri = ring->innerRadiusMm;
                    if (!(ro >= ri)) return;
                    out.push_back(profile(f.shape, -ro, -ri, chordToleranceMm));
                    out.push_back(profile(f.shape, ri, ro, chordToleranceMm));
                } else {
                    double half = apertureBoundingRadius(f.aperture);
                    if (const auto* rect = std::get_if<RectangularAperture>(&f.aperture)) {
                        half = rect->halfHeightMm;
                    }
                    half = std::min(half, rim);
                    out.push_back(profile(f.shape, -half, half, chordToleranceMm));
                }
            } else {
                for (double y : {-f.radiusMm, f.radiusMm})
                    out.push_back({Vec2{y, rimZ(f, false, 0.0, y)}, Vec2{y, rimZ(f, true, 0.0, y)}});
            }
        },
        face);
    return out;
}

}  // namespace veil
