#pragma once
// Branch and bound for the crossings of a ray with a height-field surface, shared by the
// even aspheres (geometry/surface_shape.cpp) and the anamorphic surfaces
// (geometry/anamorphic.cpp). The surface is given along the ray as f(s) = z(s) - S(x(s), y(s))
// by a type F with
//
//     double value(double s) const;                                   // f(s)
//     void valueAndSlope(double s, double& f, double& df) const;      // f(s), f'(s)
//     AlongRayBounds bounds(double a, double b) const;                // enclosures on [a, b]
//
// findRoot() isolates the wanted root (nearest a reference point, among those `accept`
// takes) and polishRoot() refines it; the method is described in geometry/surface_shape.cpp
// (Even Asphere Intersection). Internal to geometry/.

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

#include "geometry/numerics.h"
#include "geometry/vec.h"

namespace veil::root_search {

// Asphere root search limits. The first segment of the search is kInitialSegmentMm long (or
// twice the distance to the base conic's crossing, if longer) and later ones double in
// length away from the reference point; a segment narrower than
// kMinSegmentMm (plus a few ulps of its position) is not split again. kMaxSegments and
// kMaxPolishIterations bound the work per ray: past them the ray is reported as missing.
constexpr double kInitialSegmentMm = 1.0;
constexpr double kMinSegmentMm = 1e-15;
constexpr int kMaxSegments = 4000;
constexpr int kMaxPolishIterations = 200;
constexpr int kStackCapacity = 256;

// Parameter of the ray point nearest the vertex (the origin of the surface's frame).
inline double nearestToVertex(const Ray& ray) {
    const double dd = glm::dot(ray.direction, ray.direction);
    return dd > 0.0 ? -glm::dot(ray.origin, ray.direction) / dd : 0.0;
}

// Edge test of a hit point p + s d against the radius rMax, with an allowance for the
// rounding of the point (magnitude: |p| + |s|; see intersectFirst() in surface_shape.h).
inline bool withinRadius(const Vec3& point, double rMax, double magnitude) {
    if (rMax == std::numeric_limits<double>::infinity()) return true;
    const double r = std::sqrt(point.x * point.x + point.y * point.y);
    return r <= rMax + 8.0 * std::numeric_limits<double>::epsilon() * (rMax + magnitude);
}

// The search range [lo, hi] of the ray p + s d narrowed to where it stays within the cylinder
// x^2 + y^2 <= uMax (a quadratic in s, solved without cancellation); false if it never does.
inline bool clipToCylinder(const Vec3& p, const Vec3& d, double uMax, double& lo, double& hi) {
    const double qa = d.x * d.x + d.y * d.y;
    const double qb = p.x * d.x + p.y * d.y;
    const double qc = p.x * p.x + p.y * p.y - uMax;
    if (qa == 0.0) return !(qc > 0.0);
    const double disc = differenceOfProducts(qb, qb, qa, qc);
    if (!(disc >= 0.0)) return false;
    const double q = -(qb + std::copysign(std::sqrt(disc), qb));
    const double s1 = q / qa, s2 = q != 0.0 ? qc / q : 0.0;
    lo = std::max(lo, std::min(s1, s2));
    hi = std::min(hi, std::max(s1, s2));
    return true;
}

// [lo, hi] narrowed to where z lies in the slab [zLo, zHi] (a sag enclosure); false if the
// range ends up empty or unbounded.
inline bool clipToSlab(const Vec3& p, const Vec3& d, double zLo, double zHi, double& lo,
                       double& hi) {
    if (d.z != 0.0) {
        const double s1 = (zLo - p.z) / d.z, s2 = (zHi - p.z) / d.z;
        if (std::isfinite(s1) && std::isfinite(s2)) {
            lo = std::max(lo, std::min(s1, s2));
            hi = std::min(hi, std::max(s1, s2));
        }
    } else if (p.z < zLo || p.z > zHi) {
        return false;
    }
    return lo <= hi && std::isfinite(lo) && std::isfinite(hi);
}

// Enclosures of f and f' over a segment of the ray.
struct AlongRayBounds {
    double fLo, fHi, dfLo, dfHi;
};

// Bracketed Newton on [a, b], where f(a) and f(b) differ in sign (or one is 0), from
// `start` if it lies inside, else from the regula falsi point.
template <typename F>
double polishRoot(const F& f, double a, double b, double fa, double fb, double start) {
    if (fa == 0.0) return a;
    if (fb == 0.0) return b;
    double lo = fa < 0.0 ? a : b;  // f(lo) < 0 < f(hi)
    double hi = fa < 0.0 ? b : a;
    double x = start;
    if (!(x > a && x < b)) x = a - fa * (b - a) / (fb - fa);
    if (!(x > a && x < b)) x = 0.5 * (a + b);
    double stepOld = std::abs(b - a);
    double step = stepOld;
    double fx, df;
    f.valueAndSlope(x, fx, df);
    for (int i = 0; i < kMaxPolishIterations && fx != 0.0; ++i) {
        if (fx < 0.0) {
            lo = x;
        } else {
            hi = x;
        }
        const double newton = x - fx / df;
        const bool inside = newton > std::min(lo, hi) && newton < std::max(lo, hi);
        if (!inside || !std::isfinite(newton) || std::abs(2.0 * fx) > std::abs(stepOld * df)) {
            stepOld = step;
            step = 0.5 * (hi - lo);
            x = lo + step;
        } else {
            stepOld = step;
            step = newton - x;
            x = newton;
        }
        constexpr double eps = std::numeric_limits<double>::epsilon();
        if (std::abs(step) <= 2.0 * eps * std::abs(x) + kMinSegmentMm * 1e-3 ||
            std::abs(hi - lo) <= 2.0 * eps * std::max(std::abs(lo), std::abs(hi))) {
            break;
        }
        f.valueAndSlope(x, fx, df);
    }
    return x;
}

struct Segment {
    double a, b;
};

// A stack of disjoint segments on one side of sRef, nearest on top.
class SegmentStack {
  public:
    bool empty() const { return size_ == 0; }
    bool push(const Segment& s) {
        if (size_ == kStackCapacity) return false;
        items_[size_++] = s;
        return true;
    }
    const Segment& top() const { return items_[size_ - 1]; }
    Segment pop() { return items_[--size_]; }
    void clear() { size_ = 0; }

  private:
    std::array<Segment, kStackCapacity> items_;
    int size_ = 0;
};

// Root of f in [lo, hi] nearest to sRef (lo <= sRef <= hi) that `accept` takes. sSelf is
// the parameter of the ray origin when the ray starts on the surface (NaN otherwise).
// `firstStep` is the length of the first segment on each side and `guess` a likely root
// where Newton starts when its bracket holds it (NaN if none).
template <typename F, typename Accept>
std::optional<double> findRoot(const F& f, double lo, double hi, double sRef, double sSelf,
                               double firstStep, double guess, Accept&& accept) {
    constexpr double inf = std::numeric_limits<double>::infinity();
    constexpr double eps = std::numeric_limits<double>::epsilon();
    SegmentStack right, left;  // right: segments at >= sRef; left: <= sRef
    auto pushSide = [&](SegmentStack& stack, Segment seg, bool isRight) {
        // Split at the origin of a ray that starts on the surface so that its own root sits
        // at a segment end.
        if (sSelf > seg.a && sSelf < seg.b) {
            const Segment nearPart = isRight ? Segment{seg.a, sSelf} : Segment{sSelf, seg.b};
            const Segment farPart = isRight ? Segment{sSelf, seg.b} : Segment{seg.a, sSelf};
            stack.push(farPart);
            stack.push(nearPart);
        } else {
            stack.push(seg);
        }
    };
    if (hi > sRef) pushSide(right, {sRef, hi}, true);
    if (sRef > lo) pushSide(left, {lo, sRef}, false);
    if (hi == lo) pushSide(right, {lo, hi}, true);

    std::optional<double> best;
    double bestKey = inf;
    for (int evaluated = 0;;) {
        const double keyRight = right.empty() ? inf : right.top().a - sRef;
        const double keyLeft = left.empty() ? inf : sRef - left.top().b;
        if (right.empty() && left.empty()) break;
        const bool isRight = keyRight <= keyLeft;
        SegmentStack& stack = isRight ? right : left;
        if (std::min(keyRight, keyLeft) >= bestKey) {
            stack.clear();  // the whole stack is farther than the best root
            continue;
        }
        const Segment seg = stack.pop();
        if (++evaluated > kMaxSegments) return std::nullopt;

        const AlongRayBounds bd = f.bounds(seg.a, seg.b);
        if (!(bd.fLo <= 0.0 && bd.fHi >= 0.0)) continue;
        const bool monotone = bd.dfLo > 0.0 || bd.dfHi < 0.0;

        // Split point: geometric while the segment is long compared with its distance from
        // sRef, halving otherwise.
        const double nearEnd = isRight ? seg.a : seg.b;
        const double step = std::max(std::abs(nearEnd - sRef), firstStep);
        double m = 0.5 * (seg.a + seg.b);
        if (seg.b - seg.a > 4.0 * step) m = isRight ? seg.a + step : seg.b - step;
        const double minWidth =
            kMinSegmentMm + 8.0 * eps * std::max(std::abs(seg.a), std::abs(seg.b));
        const bool leaf = !(m > seg.a && m < seg.b) || seg.b - seg.a <= minWidth;

        if (monotone || leaf) {
            // A monotone segment ending at the origin of a ray that starts on the surface
            // holds only the origin's own root.
            if (seg.a == sSelf || seg.b == sSelf) continue;
            const double fa = f.value(seg.a), fb = f.value(seg.b);
            if (!((fa <= 0.0 && fb >= 0.0) || (fa >= 0.0 && fb <= 0.0))) continue;
            const double s = polishRoot(f, seg.a, seg.b, fa, fb, guess);
            const double key = std::abs(s - sRef);
            if (key < bestKey && accept(s)) {
                best = s;
                bestKey = key;
            }
            continue;
        }
        const Segment nearPart = isRight ? Segment{seg.a, m} : Segment{m, seg.b};
        const Segment farPart = isRight ? Segment{m, seg.b} : Segment{seg.a, m};
        if (!stack.push(farPart) || !stack.push(nearPart)) return std::nullopt;
    }
    return best;
}

}  // namespace veil::root_search
