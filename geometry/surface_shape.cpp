#include "geometry/surface_shape.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "geometry/anamorphic.h"
#include "geometry/conic_roots.h"
#include "geometry/numerics.h"
#include "geometry/root_search.h"

namespace veil {

namespace {

using namespace root_search;

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kEpsilon = std::numeric_limits<double>::epsilon();

ConicBase conicBase(const SurfaceShape& shape) {
    return std::visit(
        [](const auto& s) -> ConicBase {
            using S = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<S, PlaneShape>) {
                return {};
            } else if constexpr (std::is_same_v<S, SphereShape>) {
                return {s.curvature, 0.0};
            } else if constexpr (std::is_same_v<S, ConicShape> ||
                                 std::is_same_v<S, EvenAsphereShape>) {
                return {s.curvature, s.conic};
            } else {
                throw std::logic_error("conicBase: an anamorphic shape has no base conic");
            }
        },
        shape);
}

// Conic sag in the rationalized form c u / (1 + w): no cancellation at the vertex (u -> 0)
// nor for tiny curvature, where the textbook (1 - w) / ((1 + k) c) loses every digit.
// At the rim 1 - K u may round to a few ulps below zero (maxRadius^2 is rounded); that is
// still the rim. Beyond it the sag is NaN.
double conicSag(const ConicBase& b, double u) {
    double w2 = 1.0 - b.bigK() * u;
    if (w2 < 0.0 && w2 >= -8.0 * kEpsilon) w2 = 0.0;
    return b.c * u / (1.0 + std::sqrt(w2));
}
// The same with w clamped at 0, for evaluations that may overshoot the rim by rounding, and
// dz/du = c / (2 w), infinite at the rim of an ellipsoid.
void conicSagAndSlopeClamped(const ConicBase& b, double u, double& z, double& dzdu) {
    const double w = std::sqrt(std::max(0.0, 1.0 - b.bigK() * u));
    z = b.c * u / (1.0 + w);
    dzdu = b.c / (2.0 * w);
}
double conicSagClamped(const ConicBase& b, double u) {
    return b.c * u / (1.0 + std::sqrt(std::max(0.0, 1.0 - b.bigK() * u)));
}

// Polynomial part P(u) = sum a[i] u^(i+1) and dP/du = sum (i+1) a[i] u^i (Horner).
double polySag(const std::array<double, 10>& a, double u) {
    double acc = 0.0;
    for (int i = 9; i >= 0; --i) acc = acc * u + a[i];
    return acc * u;
}
double polySlope(const std::array<double, 10>& a, double u) {
    double acc = 0.0;
    for (int i = 9; i >= 1; --i) acc = acc * u + (i + 1) * a[i];
    return acc * u + a[0];
}

template <size_t N>
bool allZero(const std::array<double, N>& a) {
    return std::all_of(a.begin(), a.end(), [](double v) { return v == 0.0; });
}

// Odd part O(u) = sum b[j] r^(2j+3) = r u Q(u) with Q(u) = sum b[j] u^j, r = sqrt(u), and
// dO/du = r (1.5 Q(u) + u Q'(u)): finite, and 0 on the axis.
double oddSag(const std::array<double, 9>& b, double u) {
    double q = 0.0;
    for (int j = 8; j >= 0; --j) q = q * u + b[j];
    return std::sqrt(u) * u * q;
}
double oddSlope(const std::array<double, 9>& b, double u) {
    double q = 0.0, dq = 0.0;
    for (int j = 8; j >= 0; --j) {
        dq = dq * u + q;
        q = q * u + b[j];
    }
    return std::sqrt(u) * (1.5 * q + u * dq);
}

// Part over w, W(u) = P_e(u) / w with w = sqrt(1 - K u) clamped at 0, and
// dW/du = P_e'(u) / w + P_e(u) K / (2 w^3).
double overWSag(const std::array<double, 10>& e, double bigK, double u) {
    return polySag(e, u) / std::sqrt(std::max(0.0, 1.0 - bigK * u));
}
double overWSlope(const std::array<double, 10>& e, double bigK, double u) {
    const double w = std::sqrt(std::max(0.0, 1.0 - bigK * u));
    return polySlope(e, u) / w + polySag(e, u) * bigK / (2.0 * w * w * w);
}

// Conic Intersection: conicRoots() and onVertexSheet() (geometry/conic_roots.h).

std::optional<double> conicSequential(const ConicBase& b, const Ray& ray) {
    const Vec3& d = ray.direction;
    const double tRef = nearestToVertex(ray);
    const Vec3 p = ray.origin + tRef * d;
    const QuadraticRoots roots = conicRoots(b, p, d);
    // The crossing nearest the tangent-plane crossing has the smallest |z| (|z| = |dz| |t -
    // t0|); with dz == 0 all candidates share z and the one nearest the origin wins.
    std::optional<double> best;
    double bestZ = kInfinity;
    double bestT = kInfinity;
    for (int i = 0; i < roots.count; ++i) {
        const double s = roots.s[i];
        const double z = p.z + s * d.z;
        if (!std::isfinite(s) || !onVertexSheet(b, z)) continue;
        const double t = tRef + s;
        const double az = std::abs(z);
        if (az < bestZ || (az == bestZ && std::abs(t) < bestT)) {
            best = t;
            bestZ = az;
            bestT = std::abs(t);
        }
    }
    return best;
}

std::optional<ShapeHit> conicFirst(const SurfaceShape& shape, const ConicBase& b, const Ray& ray,
                                   double tMin, double tMax, double rMax, bool startsOnSurface) {
    double t;
    Vec3 point;
    if (!conicFirstCrossing(b, ray, tMin, tMax, rMax, startsOnSurface, t, point))
        return std::nullopt;
    return ShapeHit{t, point, surfaceNormal(shape, point)};
}

// Even Asphere Intersection
//
// The asphere is the height field z = S(u), u = x^2 + y^2, S(u) = c u / (1 + w) + P(u).
// Along the ray p + s d its crossings are the roots of
//
//     f(s) = z(s) - S(u(s)),   f'(s) = dz - S'(u) u'(s),   u'(s) = 2 (x dx + y dy),
//
// and every root is on the surface (there is no far sheet to reject). f has no closed-form
// roots and may have several, so the wanted one (nearest the tangent-plane crossing, or the
// first after tMin) is isolated by branch and bound before it is polished:
//
//   * Interval bounds of f and f' over a segment [a, b] come from the exact range of u(s)
//     (a quadratic in s), the monotonicity in u of the conic sag, of its slope and of every
//     a[i] u^(i+1) term (u >= 0), and the mean-value form f(m) + f'([a, b]) [-h, h]. Bounds
//     are widened by a few ulps of the magnitudes involved, so no root is lost to rounding.
//   * A segment whose f-range excludes 0 holds no root and is dropped. A segment whose
//     f'-range excludes 0 is monotone: it holds at most one root, present exactly when f
//     changes sign between its ends, and that root is polished by bracketed Newton (Newton
//     steps, replaced by bisection whenever they leave the bracket or shrink too slowly), which
//     always converges. Other segments are split.
//   * Segments are visited nearest first from a reference point sRef (the tangent-plane
//     crossing, or the start of the range) on two sorted stacks, one on each side, and are
//     pruned once farther than the best root found; far segments are split geometrically
//     (lengths doubling away from sRef) so a root near sRef is reached in a few steps even
//     when the search range is long.
//   * A ray starting on the surface has its own root at s = 0: a monotone segment that ends
//     at 0 holds only that root and is dropped, by the sign of f' rather than an offset.
//   * The number of segments and of Newton steps is bounded; if either runs out, the ray is
//     reported as missing rather than looping.
class AsphereAlongRay {
  public:
    AsphereAlongRay(const EvenAsphereShape& shape, const Vec3& p, const Vec3& d)
        : base_{shape.curvature, shape.conic},
          a_(shape.coefficients),
          b_(shape.odd),
          e_(shape.overW),
          hasOdd_(!allZero(shape.odd)),
          hasOverW_(!allZero(shape.overW)),
          p_(p),
          d_(d) {
        bigK_ = base_.bigK();
    }

    double value(double s) const {
        const double x = p_.x + s * d_.x, y = p_.y + s * d_.y, z = p_.z + s * d_.z;
        const double u = x * x + y * y;
        return z - (conicSagClamped(base_, u) + polySag(a_, u) + (hasOdd_ ? oddSag(b_, u) : 0.0) +
                    (hasOverW_ ? overWSag(e_, bigK_, u) : 0.0));
    }
    void valueAndSlope(double s, double& f, double& df) const {
        const double x = p_.x + s * d_.x, y = p_.y + s * d_.y, z = p_.z + s * d_.z;
        const double u = x * x + y * y;
        double zc, dzc;
        conicSagAndSlopeClamped(base_, u, zc, dzc);
        const double odd = hasOdd_ ? oddSag(b_, u) : 0.0;
        const double oddSlopeU = hasOdd_ ? oddSlope(b_, u) : 0.0;
        const double overW = hasOverW_ ? overWSag(e_, bigK_, u) : 0.0;
        const double overWSlopeU = hasOverW_ ? overWSlope(e_, bigK_, u) : 0.0;
        f = z - (zc + polySag(a_, u) + odd + overW);
        df = d_.z -
             (dzc + polySlope(a_, u) + oddSlopeU + overWSlopeU) * 2.0 * (x * d_.x + y * d_.y);
    }

    // Enclosure of S and S' over u in [uLo, uHi], and a bound on the magnitudes summed.
    struct SagRange {
        double lo, hi, slopeLo, slopeHi, magnitude;
    };
    SagRange sagRange(double uLo, double uHi) const {
        double c0, c1, d0, d1;
        conicSagAndSlopeClamped(base_, uLo, c0, d0);
        conicSagAndSlopeClamped(base_, uHi, c1, d1);
        SagRange r{std::min(c0, c1), std::max(c0, c1), std::min(d0, d1), std::max(d0, d1),
                   std::max(std::abs(c0), std::abs(c1))};
        double powLo = uLo, powHi = uHi;  // u^(i+1)
        double derLo = 1.0, derHi = 1.0;  // u^i
        for (int i = 0; i < 10; ++i) {
            if (a_[i] != 0.0) {
                const double t0 = a_[i] * powLo, t1 = a_[i] * powHi;
                r.lo += std::min(t0, t1);
                r.hi += std::max(t0, t1);
                r.magnitude += std::max(std::abs(t0), std::abs(t1));
                const double e0 = (i + 1) * a_[i] * derLo, e1 = (i + 1) * a_[i] * derHi;
                r.slopeLo += std::min(e0, e1);
                r.slopeHi += std::max(e0, e1);
            }
            derLo = powLo;
            derHi = powHi;
            powLo *= uLo;
            powHi *= uHi;
        }
        // Terms over w, e[i] u^(i+1) / w, and their u-slopes e[i] ((i+1) u^i / w +
        // u^(i+1) K / (2 w^3)): with K >= 0 every factor is positive and increasing in u, so
        // each term is monotone and between its values at the ends.
        if (hasOverW_) {
            const double wLo = std::sqrt(std::max(0.0, 1.0 - bigK_ * uLo));
            const double wHi = std::sqrt(std::max(0.0, 1.0 - bigK_ * uHi));
            double pLo = uLo, pHi = uHi;  // u^(i+1)
            double qLo = 1.0, qHi = 1.0;  // u^i
            for (int i = 0; i < 10; ++i) {
                if (e_[i] != 0.0) {
                    const double t0 = e_[i] * pLo / wLo, t1 = e_[i] * pHi / wHi;
                    r.lo += std::min(t0, t1);
                    r.hi += std::max(t0, t1);
                    r.magnitude += std::max(std::abs(t0), std::abs(t1));
                    const double e0 = e_[i] * ((i + 1) * qLo / wLo +
                                               pLo * bigK_ / (2.0 * wLo * wLo * wLo));
                    const double e1 = e_[i] * ((i + 1) * qHi / wHi +
                                               pHi * bigK_ / (2.0 * wHi * wHi * wHi));
                    r.slopeLo += std::min(e0, e1);
                    r.slopeHi += std::max(e0, e1);
                }
                qLo = pLo;
                qHi = pHi;
                pLo *= uLo;
                pHi *= uHi;
            }
        }
        // Odd terms b[j] u^(j + 1.5) and their u-slopes (j + 1.5) b[j] u^(j + 0.5): each
        // monotone in u >= 0, so between its values at the ends.
        if (!hasOdd_) return r;
        const double sLo = std::sqrt(uLo), sHi = std::sqrt(uHi);
        double oLo = uLo * sLo, oHi = uHi * sHi;  // u^(j+1.5)
        double qLo = sLo, qHi = sHi;              // u^(j+0.5)
        for (int j = 0; j < 9; ++j) {
            if (b_[j] != 0.0) {
                const double t0 = b_[j] * oLo, t1 = b_[j] * oHi;
                r.lo += std::min(t0, t1);
                r.hi += std::max(t0, t1);
                r.magnitude += std::max(std::abs(t0), std::abs(t1));
                const double e0 = (j + 1.5) * b_[j] * qLo, e1 = (j + 1.5) * b_[j] * qHi;
                r.slopeLo += std::min(e0, e1);
                r.slopeHi += std::max(e0, e1);
            }
            oLo *= uLo;
            oHi *= uHi;
            qLo *= uLo;
            qHi *= uHi;
        }
        return r;
    }

    double radiusSqAt(double s) const {
        const double x = p_.x + s * d_.x, y = p_.y + s * d_.y;
        return x * x + y * y;
    }

    using Bounds = AlongRayBounds;
    Bounds bounds(double a, double b) const {
        // Exact range of u(s) = |pxy + s dxy|^2 on [a, b], then a few ulps of slack.
        const double ua = radiusSqAt(a), ub = radiusSqAt(b);
        double uLo = std::min(ua, ub), uHi = std::max(ua, ub);
        const double dxy2 = d_.x * d_.x + d_.y * d_.y;
        if (dxy2 > 0.0) {
            const double sStar = -(p_.x * d_.x + p_.y * d_.y) / dxy2;
            if (sStar > a && sStar < b) uLo = std::min(uLo, radiusSqAt(sStar));
        }
        uLo = std::max(0.0, uLo * (1.0 - 8.0 * kEpsilon));
        uHi *= 1.0 + 8.0 * kEpsilon;
        if (bigK_ > 0.0) {
            uHi = std::min(uHi, 1.0 / bigK_);
            uLo = std::min(uLo, uHi);
        }
        const SagRange sr = sagRange(uLo, uHi);

        const double za = p_.z + a * d_.z, zb = p_.z + b * d_.z;
        const double magnitude = sr.magnitude + std::max(std::abs(za), std::abs(zb));
        const double fTol = 32.0 * kEpsilon * magnitude;
        Bounds r;
        r.fLo = std::min(za, zb) - sr.hi - fTol;
        r.fHi = std::max(za, zb) - sr.lo + fTol;

        // f' = dz - S'(u) u'(s); u'(s) is linear in s. An undefined product (0 times the
        // infinite slope at an ellipsoid's rim) leaves f' unbounded.
        const double up0 = 2.0 * ((p_.x + a * d_.x) * d_.x + (p_.y + a * d_.y) * d_.y);
        const double up1 = 2.0 * ((p_.x + b * d_.x) * d_.x + (p_.y + b * d_.y) * d_.y);
        const double upLo = std::min(up0, up1), upHi = std::max(up0, up1);
        const double pr[4] = {sr.slopeLo * upLo, sr.slopeLo * upHi, sr.slopeHi * upLo,
                              sr.slopeHi * upHi};
        double prLo = kInfinity, prHi = -kInfinity;
        bool undefined = false;
        for (double v : pr) {
            if (std::isnan(v)) undefined = true;
            prLo = std::min(prLo, v);
            prHi = std::max(prHi, v);
        }
        if (undefined) {
            r.dfLo = -kInfinity;
            r.dfHi = kInfinity;
        } else {
            const double dfTol = 32.0 * kEpsilon * (std::abs(d_.z) + std::max(-prLo, prHi));
            r.dfLo = d_.z - prHi - dfTol;
            r.dfHi = d_.z - prLo + dfTol;
        }

        // Mean-value form, tighter than the natural bounds once the segment is short.
        const double h = 0.5 * (b - a);
        const double slopeMax = std::max(std::abs(r.dfLo), std::abs(r.dfHi));
        if (std::isfinite(slopeMax)) {
            const double fm = value(a + h);
            r.fLo = std::max(r.fLo, fm - h * slopeMax - fTol);
            r.fHi = std::min(r.fHi, fm + h * slopeMax + fTol);
        }
        return r;
    }

  private:
    ConicBase base_;
    double bigK_ = 0.0;
    std::array<double, 10> a_;
    std::array<double, 9> b_;
    std::array<double, 10> e_;
    bool hasOdd_ = false;    // any odd term: else their sums are skipped
    bool hasOverW_ = false;  // any term over w: likewise
    Vec3 p_, d_;
};

// The range of s to search: radial distance within rLimit (a quadratic inequality in s) and
// z within the range of the sag over that disc (linear in s). At least one of the two is
// bounded since d is a unit vector; false if the range is empty.
bool asphereSearchRange(const AsphereAlongRay& f, const Vec3& p, const Vec3& d, double rLimit,
                        double& lo, double& hi) {
    const double uMax = rLimit * rLimit * (1.0 + 64.0 * kEpsilon);
    if (!clipToCylinder(p, d, uMax, lo, hi)) return false;
    const double qa = d.x * d.x + d.y * d.y;
    // A ray parallel to the axis stays at one radius: the sag there bounds it (terms over w
    // grow without bound toward the rim, so the whole range would not).
    const double u0 = p.x * p.x + p.y * p.y;
    const AsphereAlongRay::SagRange sr =
        qa == 0.0 ? f.sagRange(u0 * (1.0 - 8.0 * kEpsilon), std::min(uMax, u0 * (1.0 + 8.0 * kEpsilon)))
                  : f.sagRange(0.0, uMax);
    const double zTol = 32.0 * kEpsilon * sr.magnitude;
    const double zLo = sr.lo - zTol, zHi = sr.hi + zTol;
    return clipToSlab(p, d, zLo, zHi, lo, hi);
}

double asphereRadiusLimit(const EvenAsphereShape& s, double rMax) {
    return std::min({rMax, maxRadius(s), kAsphereSearchRadiusMm});
}

std::optional<double> asphereSequential(const EvenAsphereShape& shape, const Ray& ray) {
    const Vec3& d = ray.direction;
    const double tRef = nearestToVertex(ray);
    const Vec3 p = ray.origin + tRef * d;
    const AsphereAlongRay f(shape, p, d);
    double lo = -kInfinity, hi = kInfinity;
    if (!asphereSearchRange(f, p, d, asphereRadiusLimit(shape, kInfinity), lo, hi)) {
        return std::nullopt;
    }
    // Tangent-plane crossing, or the ray origin for rays parallel to the plane; clamping it
    // to the range does not change which root is nearest.
    double sRef = d.z != 0.0 ? -p.z / d.z : -tRef;
    if (!std::isfinite(sRef)) sRef = -tRef;
    sRef = std::clamp(sRef, lo, hi);
    // The base conic's crossing is usually close to the asphere's: it sets the length of the
    // first segments and starts Newton.
    double guess = kNaN;
    const ConicBase base{shape.curvature, shape.conic};
    const QuadraticRoots roots = conicRoots(base, p, d);
    for (int i = 0; i < roots.count; ++i) {
        const double sc = roots.s[i];
        if (std::isfinite(sc) && onVertexSheet(base, p.z + sc * d.z) &&
            !(std::abs(sc - sRef) >= std::abs(guess - sRef))) {
            guess = sc;
        }
    }
    const double firstStep = std::isfinite(guess)
                                 ? std::max(kInitialSegmentMm, 2.0 * std::abs(guess - sRef))
                                 : kInitialSegmentMm;
    const std::optional<double> s =
        findRoot(f, lo, hi, sRef, kNaN, firstStep, guess, [](double) { return true; });
    if (!s) return std::nullopt;
    return tRef + *s;
}

std::optional<ShapeHit> asphereFirst(const EvenAsphereShape& shape, const Ray& ray, double tMin,
                                     double tMax, double rMax, bool startsOnSurface) {
    const Vec3& d = ray.direction;
    const double tRef = startsOnSurface ? 0.0 : nearestToVertex(ray);
    const Vec3 p = ray.origin + tRef * d;
    const AsphereAlongRay f(shape, p, d);
    double lo = tMin - tRef, hi = tMax - tRef;
    const double rLimit = asphereRadiusLimit(shape, rMax + 8.0 * kEpsilon * rMax);
    if (!(lo <= hi) || !asphereSearchRange(f, p, d, rLimit, lo, hi)) return std::nullopt;
    // The origin of a ray that starts on the surface may fall just outside the range by
    // rounding (an origin on the aperture edge); keep it inside so that its own root is
    // recognised as such.
    if (startsOnSurface && tMin <= 0.0 && lo > 0.0 && hi >= 0.0) lo = 0.0;
    const double pLength = glm::length(p);
    auto accept = [&](double s) {
        const double t = tRef + s;
        return t > tMin && t <= tMax && withinRadius(p + s * d, rMax, pLength + std::abs(s));
    };
    const std::optional<double> s = findRoot(f, lo, hi, lo, startsOnSurface ? 0.0 : kNaN,
                                                    kInitialSegmentMm, kNaN, accept);
    if (!s) return std::nullopt;
    const Vec3 point = p + *s * d;
    return ShapeHit{tRef + *s, point, surfaceNormal(SurfaceShape{shape}, point)};
}

}  // namespace

// Printing

std::ostream& operator<<(std::ostream& os, const PlaneShape&) { return os << "Plane{}"; }
std::ostream& operator<<(std::ostream& os, const SphereShape& s) {
    return os << "Sphere{curvature " << s.curvature << " /mm}";
}
std::ostream& operator<<(std::ostream& os, const ConicShape& s) {
    return os << "Conic{curvature " << s.curvature << " /mm, conic " << s.conic << "}";
}
std::ostream& operator<<(std::ostream& os, const EvenAsphereShape& s) {
    os << "EvenAsphere{curvature " << s.curvature << " /mm, conic " << s.conic << ", a [";
    for (size_t i = 0; i < s.coefficients.size(); ++i) {
        os << (i ? ", " : "") << s.coefficients[i];
    }
    if (!allZero(s.odd)) {
        os << "], odd r^3.. [";
        for (size_t j = 0; j < s.odd.size(); ++j) os << (j ? ", " : "") << s.odd[j];
    }
    if (!allZero(s.overW)) {
        os << "], over w [";
        for (size_t i = 0; i < s.overW.size(); ++i) os << (i ? ", " : "") << s.overW[i];
    }
    return os << "]}";
}
std::ostream& operator<<(std::ostream& os, const BiconicShape& s) {
    return os << "Biconic{x curvature " << s.xCurvature << " /mm, x conic " << s.xConic
              << ", y curvature " << s.yCurvature << " /mm, y conic " << s.yConic << "}";
}
std::ostream& operator<<(std::ostream& os, const ToroidalShape& s) {
    os << "Toroidal{y curvature " << s.yCurvature << " /mm, y conic " << s.yConic << ", a [";
    for (size_t i = 0; i < s.yCoefficients.size(); ++i)
        os << (i ? ", " : "") << s.yCoefficients[i];
    return os << "], x curvature " << s.xCurvature << " /mm}";
}
std::ostream& operator<<(std::ostream& os, const SurfaceShape& s) {
    std::visit([&os](const auto& shape) { os << shape; }, s);
    return os;
}
std::ostream& operator<<(std::ostream& os, const ShapeHit& h) {
    return os << "ShapeHit{t " << h.t << " mm, point " << h.point << ", normal " << h.normal << "}";
}

// Surface Shape Functions

SurfaceShape makeShape(double curvature, double conic, const std::array<double, 10>& asphere,
                       const std::array<double, 9>& odd, const std::array<double, 10>& overW) {
    if (!allZero(overW) && !(1.0 + conic >= 0.0))
        throw std::invalid_argument("terms over w need a sphere or ellipsoid base (1 + k >= 0)");
    if (!allZero(asphere) || !allZero(odd) || !allZero(overW))
        return EvenAsphereShape{curvature, conic, asphere, odd, overW};
    if (curvature == 0.0) return PlaneShape{};
    if (conic == 0.0) return SphereShape{curvature};
    return ConicShape{curvature, conic};
}

bool isRotational(const SurfaceShape& shape) {
    return !std::holds_alternative<BiconicShape>(shape) &&
           !std::holds_alternative<ToroidalShape>(shape);
}

double sagAt(const SurfaceShape& shape, double x, double y) {
    if (const auto* b = std::get_if<BiconicShape>(&shape)) return anamorphicSag(*b, x, y);
    if (const auto* t = std::get_if<ToroidalShape>(&shape)) return anamorphicSag(*t, x, y);
    return sag(shape, x * x + y * y);
}

double sag(const SurfaceShape& shape, double rSq) {
    return std::visit(
        [rSq](const auto& s) -> double {
            using S = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<S, BiconicShape> || std::is_same_v<S, ToroidalShape>) {
                throw std::logic_error("sag(r^2) of an anamorphic shape; use sagAt(x, y)");
            } else if constexpr (std::is_same_v<S, PlaneShape>) {
                return 0.0;
            } else if constexpr (std::is_same_v<S, SphereShape>) {
                return conicSag({s.curvature, 0.0}, rSq);
            } else if constexpr (std::is_same_v<S, ConicShape>) {
                return conicSag({s.curvature, s.conic}, rSq);
            } else {
                const double odd = allZero(s.odd) ? 0.0 : oddSag(s.odd, rSq);
                const ConicBase b{s.curvature, s.conic};
                // Beyond the rim the conic sag is NaN, and so is the sum.
                const double overW = allZero(s.overW) ? 0.0 : overWSag(s.overW, b.bigK(), rSq);
                return conicSag(b, rSq) + polySag(s.coefficients, rSq) + odd + overW;
            }
        },
        shape);
}

// The normal is grad(z - S(u)) = (-2 x S', -2 y S', 1) scaled by w = sqrt(1 - K u) >= 0,
// which keeps it finite at an ellipsoid's rim: (-x (c + 2 w P'), -y (c + 2 w P'), w). For a
// pure conic w is taken from the implicit form, w = 1 - (1 + k) c z (equal on the vertex
// sheet, and well conditioned near the rim where 1 - K u cancels); for a sphere the normal
// is then exactly along the radius. No term divides by c, so tiny curvatures are harmless.
Vec3 surfaceNormal(const SurfaceShape& shape, const Vec3& point) {
    const Vec3 g = std::visit(
        [&point](const auto& s) -> Vec3 {
            using S = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<S, BiconicShape> || std::is_same_v<S, ToroidalShape>) {
                return anamorphicNormal(s, point);
            } else if constexpr (std::is_same_v<S, PlaneShape>) {
                return {0.0, 0.0, 1.0};
            } else if constexpr (std::is_same_v<S, EvenAsphereShape>) {
                const ConicBase b{s.curvature, s.conic};
                const double u = point.x * point.x + point.y * point.y;
                const double w = std::sqrt(std::max(0.0, 1.0 - b.bigK() * u));
                const double odd = allZero(s.odd) ? 0.0 : oddSlope(s.odd, u);
                const double overW =
                    allZero(s.overW) ? 0.0 : overWSlope(s.overW, b.bigK(), u);
                const double m = b.c + 2.0 * w * (polySlope(s.coefficients, u) + odd + overW);
                return {-point.x * m, -point.y * m, w};
            } else {
                const ConicBase b = conicBase(s);
                return {-b.c * point.x, -b.c * point.y, 1.0 - (1.0 + b.k) * b.c * point.z};
            }
        },
        shape);
    return glm::normalize(g);
}

double maxRadius(const SurfaceShape& shape) {
    if (const auto* a = std::get_if<BiconicShape>(&shape)) return anamorphicMaxRadius(*a);
    if (const auto* a = std::get_if<ToroidalShape>(&shape)) return anamorphicMaxRadius(*a);
    const ConicBase b = conicBase(shape);
    // Spheres and ellipsoids end where 1 - (1 + k) c^2 r^2 = 0 (decided on 1 + k and c, not on
    // (1 + k) c^2, which underflows for tiny c).
    if (b.c == 0.0 || !(1.0 + b.k > 0.0)) return kInfinity;
    return 1.0 / (std::abs(b.c) * std::sqrt(1.0 + b.k));
}

std::optional<double> intersectSequential(const SurfaceShape& shape, const Ray& localRay) {
    return std::visit(
        [&](const auto& s) -> std::optional<double> {
            using S = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<S, BiconicShape> || std::is_same_v<S, ToroidalShape>) {
                return anamorphicSequential(s, localRay);
            } else if constexpr (std::is_same_v<S, PlaneShape>) {
                if (localRay.direction.z == 0.0) return std::nullopt;
                return -localRay.origin.z / localRay.direction.z;
            } else if constexpr (std::is_same_v<S, EvenAsphereShape>) {
                if (allZero(s.coefficients) && allZero(s.odd) && allZero(s.overW)) {
                    return conicSequential({s.curvature, s.conic}, localRay);
                }
                return asphereSequential(s, localRay);
            } else {
                return conicSequential(conicBase(s), localRay);
            }
        },
        shape);
}

std::optional<ShapeHit> intersectFirst(const SurfaceShape& shape, const Ray& localRay, double tMin,
                                       double tMax, double rMax, bool startsOnSurface) {
    return std::visit(
        [&](const auto& s) -> std::optional<ShapeHit> {
            using S = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<S, BiconicShape> || std::is_same_v<S, ToroidalShape>) {
                return anamorphicFirst(s, localRay, tMin, tMax, rMax, startsOnSurface);
            } else if constexpr (std::is_same_v<S, PlaneShape>) {
                // A ray that starts on a plane cannot meet it again.
                const Vec3& o = localRay.origin;
                const Vec3& d = localRay.direction;
                if (startsOnSurface || d.z == 0.0) return std::nullopt;
                const double t = -o.z / d.z;
                if (!(t > tMin && t <= tMax)) return std::nullopt;
                const Vec3 point{o.x + t * d.x, o.y + t * d.y, 0.0};
                if (!withinRadius(point, rMax, glm::length(o) + std::abs(t))) return std::nullopt;
                return ShapeHit{t, point, {0.0, 0.0, 1.0}};
            } else if constexpr (std::is_same_v<S, EvenAsphereShape>) {
                if (allZero(s.coefficients) && allZero(s.odd) && allZero(s.overW)) {
                    return conicFirst(shape, {s.curvature, s.conic}, localRay, tMin, tMax, rMax,
                                      startsOnSurface);
                }
                return asphereFirst(s, localRay, tMin, tMax, rMax, startsOnSurface);
            } else {
                return conicFirst(shape, conicBase(s), localRay, tMin, tMax, rMax, startsOnSurface);
            }
        },
        shape);
}

}  // namespace veil
