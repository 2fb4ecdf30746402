#include "geometry/anamorphic.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "geometry/numerics.h"
#include "geometry/root_search.h"

namespace veil {

namespace {

using namespace root_search;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kEps = std::numeric_limits<double>::epsilon();

// Numbers the sag templates run on: double (a point), Interval (an enclosure), and Dual<V>
// (a value with its derivative along one parameter).

struct Interval {
    double lo, hi;
};
Interval whole() { return {-kInf, kInf}; }
// An undefined end (inf - inf, 0 * inf) makes the enclosure unbounded on that side.
Interval fix(Interval a) {
    if (std::isnan(a.lo)) a.lo = -kInf;
    if (std::isnan(a.hi)) a.hi = kInf;
    return a;
}
Interval operator+(Interval a, Interval b) { return fix({a.lo + b.lo, a.hi + b.hi}); }
Interval operator-(Interval a, Interval b) { return fix({a.lo - b.hi, a.hi - b.lo}); }
Interval operator*(Interval a, Interval b) {
    const double p[4] = {a.lo * b.lo, a.lo * b.hi, a.hi * b.lo, a.hi * b.hi};
    Interval r{kInf, -kInf};
    for (double v : p) {
        if (std::isnan(v)) return whole();
        r.lo = std::min(r.lo, v);
        r.hi = std::max(r.hi, v);
    }
    return r;
}
Interval operator/(Interval a, Interval b) {
    if (!(b.lo > 0.0 || b.hi < 0.0)) return whole();
    return a * Interval{1.0 / b.hi, 1.0 / b.lo};
}
Interval operator*(double k, Interval a) {
    if (k == 0.0) return {0.0, 0.0};
    return fix(k > 0.0 ? Interval{k * a.lo, k * a.hi} : Interval{k * a.hi, k * a.lo});
}
Interval operator+(double k, Interval a) { return fix({k + a.lo, k + a.hi}); }
Interval operator-(double k, Interval a) { return fix({k - a.hi, k - a.lo}); }
Interval operator/(double k, Interval a) { return Interval{k, k} / a; }
Interval square(Interval a) {
    const double l = a.lo * a.lo, h = a.hi * a.hi;
    if (a.lo >= 0.0) return {l, h};
    if (a.hi <= 0.0) return {h, l};
    return {0.0, std::max(l, h)};
}
// The square root with its argument clamped at 0: beyond a conic's rim the surface goes on
// at the rim's value, which keeps f continuous for the search (such roots are then refused
// by the domain test).
Interval sqrtClamped(Interval a) {
    return {std::sqrt(std::max(0.0, a.lo)), std::sqrt(std::max(0.0, a.hi))};
}

double square(double a) { return a * a; }
double sqrtClamped(double a) { return std::sqrt(std::max(0.0, a)); }

template <typename V>
struct Dual {
    V v, d;
};
template <typename V>
Dual<V> operator+(const Dual<V>& a, const Dual<V>& b) {
    return {a.v + b.v, a.d + b.d};
}
template <typename V>
Dual<V> operator-(const Dual<V>& a, const Dual<V>& b) {
    return {a.v - b.v, a.d - b.d};
}
template <typename V>
Dual<V> operator*(const Dual<V>& a, const Dual<V>& b) {
    return {a.v * b.v, a.d * b.v + a.v * b.d};
}
template <typename V>
Dual<V> operator/(const Dual<V>& a, const Dual<V>& b) {
    return {a.v / b.v, (a.d * b.v - a.v * b.d) / square(b.v)};
}
template <typename V>
Dual<V> operator*(double k, const Dual<V>& a) {
    return {k * a.v, k * a.d};
}
template <typename V>
Dual<V> operator+(double k, const Dual<V>& a) {
    return {k + a.v, a.d};
}
template <typename V>
Dual<V> operator-(double k, const Dual<V>& a) {
    return {k - a.v, -1.0 * a.d};
}
template <typename V>
Dual<V> operator/(double k, const Dual<V>& a) {
    return {k / a.v, (-k) * a.d / square(a.v)};
}
template <typename V>
Dual<V> square(const Dual<V>& a) {
    return {square(a.v), 2.0 * (a.v * a.d)};
}
// Where the argument is clamped the value is constant (slope 0); at the clamp itself the
// slope is unbounded.
Dual<double> sqrtClamped(const Dual<double>& a) {
    if (!(a.v > 0.0)) return {0.0, 0.0};
    const double r = std::sqrt(a.v);
    return {r, a.d / (2.0 * r)};
}
Dual<Interval> sqrtClamped(const Dual<Interval>& a) {
    const Interval r = sqrtClamped(a.v);
    if (!(a.v.hi > 0.0)) return {{0.0, 0.0}, {0.0, 0.0}};
    if (!(a.v.lo > 0.0)) return {r, whole()};
    return {r, a.d / (2.0 * r)};
}

// The base conic c u / (1 + sqrt(1 - (1 + k) c^2 u)) of a section or profile, u = x^2 or y^2.
template <typename T>
T conicProfile(double c, double k, const T& u) {
    return (c * u) / (1.0 + sqrtClamped(1.0 - ((1.0 + k) * c * c) * u));
}

// Sags as functions of X = x^2 and Y = y^2.
template <typename T>
T sagOf(const BiconicShape& s, const T& X, const T& Y) {
    const double ax = (1.0 + s.xConic) * s.xCurvature * s.xCurvature;
    const double ay = (1.0 + s.yConic) * s.yCurvature * s.yCurvature;
    return (s.xCurvature * X + s.yCurvature * Y) / (1.0 + sqrtClamped(1.0 - ax * X - ay * Y));
}

template <typename T>
T profileOf(const ToroidalShape& s, const T& Y) {
    T zy = conicProfile(s.yCurvature, s.yConic, Y);
    int last = static_cast<int>(s.yCoefficients.size()) - 1;
    while (last >= 0 && s.yCoefficients[last] == 0.0) --last;
    if (last < 0) return zy;
    T acc = s.yCoefficients[last] * Y;  // Horner: sum a[i] Y^(i+1)
    for (int i = last - 1; i >= 0; --i) acc = (s.yCoefficients[i] + acc) * Y;
    return zy + acc;
}

template <typename T>
T sagOf(const ToroidalShape& s, const T& X, const T& Y) {
    const T zy = profileOf(s, Y);
    if (s.xCurvature == 0.0) return zy;
    const T q = s.xCurvature / (1.0 - s.xCurvature * zy);
    return zy + (q * X) / (1.0 + sqrtClamped(1.0 - square(q) * X));
}

// An upper bound on the magnitudes of the terms summed in the sag over a box of X and Y, for
// the rounding allowance: the same sag with every coefficient made positive.
Interval termMagnitude(const BiconicShape& s, Interval X, Interval Y) {
    const BiconicShape a{std::abs(s.xCurvature), s.xConic, std::abs(s.yCurvature), s.yConic};
    return sagOf(a, X, Y);
}
Interval termMagnitude(const ToroidalShape& s, Interval X, Interval Y) {
    ToroidalShape a = s;
    a.yCurvature = std::abs(s.yCurvature);
    a.xCurvature = std::abs(s.xCurvature);
    for (double& c : a.yCoefficients) c = std::abs(c);
    return sagOf(a, X, Y);
}

double limitOf(double c, double k) {
    if (c == 0.0 || !(1.0 + k > 0.0)) return kInf;
    return 1.0 / (std::abs(c) * std::sqrt(1.0 + k));
}

// Rounding allowance at a conic's rim, as conicSag() in surface_shape.cpp.
constexpr double kRimSlack = 8.0 * kEps;

bool inDomain(const BiconicShape& s, double x, double y) {
    const double tx = (1.0 + s.xConic) * square(s.xCurvature * x);
    const double ty = (1.0 + s.yConic) * square(s.yCurvature * y);
    return 1.0 - tx - ty >= -kRimSlack * (1.0 + std::abs(tx) + std::abs(ty));
}
bool inDomain(const ToroidalShape& s, double x, double y) {
    const double ty = (1.0 + s.yConic) * square(s.yCurvature * y);
    if (!(1.0 - ty >= -kRimSlack * (1.0 + std::abs(ty)))) return false;
    if (s.xCurvature == 0.0) return true;
    const double zy = profileOf(s, y * y);
    const double rho = 1.0 - s.xCurvature * zy;
    if (!(rho > 0.0)) return false;
    const double tx = square(s.xCurvature * x / rho);
    return 1.0 - tx >= -kRimSlack * (1.0 + tx);
}

// The surface along the ray p + s d (see root_search.h).
template <typename Shape>
class AlongRay {
  public:
    AlongRay(const Shape& shape, const Vec3& p, const Vec3& d) : shape_(shape), p_(p), d_(d) {}

    double value(double s) const {
        const double x = p_.x + s * d_.x, y = p_.y + s * d_.y, z = p_.z + s * d_.z;
        return z - sagOf(shape_, x * x, y * y);
    }
    void valueAndSlope(double s, double& f, double& df) const {
        const Dual<double> x{p_.x + s * d_.x, d_.x}, y{p_.y + s * d_.y, d_.y};
        const Dual<double> S = sagOf(shape_, square(x), square(y));
        f = p_.z + s * d_.z - S.v;
        df = d_.z - S.d;
    }
    AlongRayBounds bounds(double a, double b) const {
        const Dual<Interval> x{span(p_.x, d_.x, a, b), {d_.x, d_.x}};
        const Dual<Interval> y{span(p_.y, d_.y, a, b), {d_.y, d_.y}};
        const Dual<Interval> X = square(x), Y = square(y);
        const Dual<Interval> S = sagOf(shape_, X, Y);
        const Interval z = span(p_.z, d_.z, a, b);
        const Interval m = termMagnitude(shape_, X.v, Y.v);
        const double magnitude = std::max({std::abs(m.lo), std::abs(m.hi), std::abs(S.v.lo),
                                           std::abs(S.v.hi), std::abs(z.lo), std::abs(z.hi)});
        const double fTol = 64.0 * kEps * magnitude;
        AlongRayBounds r;
        r.fLo = z.lo - S.v.hi - fTol;
        r.fHi = z.hi - S.v.lo + fTol;
        if (std::isnan(r.fLo)) r.fLo = -kInf;
        if (std::isnan(r.fHi)) r.fHi = kInf;
        const double slope = std::max(std::abs(S.d.lo), std::abs(S.d.hi));
        const double dfTol = 64.0 * kEps * (std::abs(d_.z) + slope);
        r.dfLo = d_.z - S.d.hi - dfTol;
        r.dfHi = d_.z - S.d.lo + dfTol;
        if (!(std::isfinite(r.dfLo) && std::isfinite(r.dfHi))) {
            r.dfLo = -kInf;
            r.dfHi = kInf;
            return r;
        }
        // Mean-value form, tighter than the natural enclosure once the segment is short.
        const double h = 0.5 * (b - a);
        const double slopeMax = std::max(std::abs(r.dfLo), std::abs(r.dfHi));
        const double fm = value(a + h);
        if (std::isfinite(fm)) {
            r.fLo = std::max(r.fLo, fm - h * slopeMax - fTol);
            r.fHi = std::min(r.fHi, fm + h * slopeMax + fTol);
        }
        return r;
    }

  private:
    static Interval span(double p, double d, double a, double b) {
        const double u = p + a * d, v = p + b * d;
        return {std::min(u, v), std::max(u, v)};
    }
    const Shape& shape_;
    Vec3 p_, d_;
};

// The range of s to search: radial distance within rLimit and z within the sag's enclosure
// over that disc (the square |x|, |y| <= rLimit); false if empty.
template <typename Shape>
bool searchRange(const Shape& shape, const Vec3& p, const Vec3& d, double rLimit, double& lo,
                 double& hi) {
    const double uMax = rLimit * rLimit * (1.0 + 64.0 * kEps);
    if (!clipToCylinder(p, d, uMax, lo, hi)) return false;
    const double qa = d.x * d.x + d.y * d.y;
    // A ray parallel to the axis stays at one (x, y).
    const Interval X = qa == 0.0 ? Interval{p.x * p.x, p.x * p.x} : Interval{0.0, uMax};
    const Interval Y = qa == 0.0 ? Interval{p.y * p.y, p.y * p.y} : Interval{0.0, uMax};
    const Interval S = sagOf(shape, X, Y);
    const Interval m = termMagnitude(shape, X, Y);
    const double zTol = 64.0 * kEps * std::max(std::abs(m.lo), std::abs(m.hi));
    const double zLo = S.lo - zTol, zHi = S.hi + zTol;
    return clipToSlab(p, d, zLo, zHi, lo, hi);
}

template <typename Shape>
double radiusLimit(const Shape& s, double rMax) {
    return std::min({rMax, anamorphicMaxRadius(s), kAsphereSearchRadiusMm});
}

template <typename Shape>
std::optional<double> sequential(const Shape& shape, const Ray& ray) {
    const Vec3& d = ray.direction;
    const double tRef = nearestToVertex(ray);
    const Vec3 p = ray.origin + tRef * d;
    const AlongRay<Shape> f(shape, p, d);
    double lo = -kInf, hi = kInf;
    if (!searchRange(shape, p, d, radiusLimit(shape, kInf), lo, hi)) return std::nullopt;
    double sRef = d.z != 0.0 ? -p.z / d.z : -tRef;
    if (!std::isfinite(sRef)) sRef = -tRef;
    sRef = std::clamp(sRef, lo, hi);
    const auto s = findRoot(f, lo, hi, sRef, kNaN, kInitialSegmentMm, kNaN, [&](double at) {
        const Vec3 q = p + at * d;
        return inDomain(shape, q.x, q.y);
    });
    if (!s) return std::nullopt;
    return tRef + *s;
}

template <typename Shape>
std::optional<ShapeHit> first(const Shape& shape, const Ray& ray, double tMin, double tMax,
                              double rMax, bool startsOnSurface) {
    const Vec3& d = ray.direction;
    const double tRef = startsOnSurface ? 0.0 : nearestToVertex(ray);
    const Vec3 p = ray.origin + tRef * d;
    const AlongRay<Shape> f(shape, p, d);
    double lo = tMin - tRef, hi = tMax - tRef;
    const double rLimit = radiusLimit(shape, rMax + 8.0 * kEps * rMax);
    if (!(lo <= hi) || !searchRange(shape, p, d, rLimit, lo, hi)) return std::nullopt;
    if (startsOnSurface && tMin <= 0.0 && lo > 0.0 && hi >= 0.0) lo = 0.0;
    const double pLength = glm::length(p);
    auto accept = [&](double s) {
        const double t = tRef + s;
        const Vec3 q = p + s * d;
        return t > tMin && t <= tMax && withinRadius(q, rMax, pLength + std::abs(s)) &&
               inDomain(shape, q.x, q.y);
    };
    const auto s =
        findRoot(f, lo, hi, lo, startsOnSurface ? 0.0 : kNaN, kInitialSegmentMm, kNaN, accept);
    if (!s) return std::nullopt;
    const Vec3 point = p + *s * d;
    return ShapeHit{tRef + *s, point, anamorphicNormal(shape, point)};
}

template <typename Shape>
void sagRangeOf(const Shape& shape, double uLo, double uHi, double& zLo, double& zHi) {
    // Cells of equal width in X = x^2 and Y = y^2 over [0, uHi]^2, those whose X + Y range
    // meets [uLo, uHi].
    constexpr int kCells = 16;
    zLo = kInf;
    zHi = -kInf;
    const double step = uHi / kCells;
    for (int i = 0; i < kCells; ++i) {
        const Interval X{i * step, i + 1 == kCells ? uHi : (i + 1) * step};
        for (int j = 0; j < kCells; ++j) {
            const Interval Y{j * step, j + 1 == kCells ? uHi : (j + 1) * step};
            if (X.lo + Y.lo > uHi || X.hi + Y.hi < uLo) continue;
            const Interval S = sagOf(shape, X, Y);
            const Interval m = termMagnitude(shape, X, Y);
            const double tol = 64.0 * kEps * std::max(std::abs(m.lo), std::abs(m.hi));
            zLo = std::min(zLo, S.lo - tol);
            zHi = std::max(zHi, S.hi + tol);
        }
    }
    if (uHi == 0.0) {
        zLo = std::min(zLo, 0.0);
        zHi = std::max(zHi, 0.0);
    }
    if (std::isnan(zLo)) zLo = -kInf;
    if (std::isnan(zHi)) zHi = kInf;
}

}  // namespace

void anamorphicSagRange(const BiconicShape& s, double uLo, double uHi, double& zLo, double& zHi) {
    sagRangeOf(s, uLo, uHi, zLo, zHi);
}
void anamorphicSagRange(const ToroidalShape& s, double uLo, double uHi, double& zLo, double& zHi) {
    sagRangeOf(s, uLo, uHi, zLo, zHi);
}

double anamorphicCurvatureBound(const SurfaceShape& s, double rMax) {
    constexpr int kRings = 24, kSpokes = 48;
    const double h = 1e-4 * std::max(rMax, 1e-3);
    double bound = 0.0;
    for (int i = 0; i <= kRings; ++i) {
        const double r = rMax * i / kRings;
        for (int j = 0; j < kSpokes; ++j) {
            const double phi = 2.0 * std::numbers::pi * j / kSpokes;
            // Keep the stencil inside the disc.
            const double rc = std::max(0.0, std::min(r, rMax - 2.0 * h));
            const double x = rc * std::cos(phi), y = rc * std::sin(phi);
            const double z = sagAt(s, x, y);
            const double fxx = (sagAt(s, x + h, y) - 2.0 * z + sagAt(s, x - h, y)) / (h * h);
            const double fyy = (sagAt(s, x, y + h) - 2.0 * z + sagAt(s, x, y - h)) / (h * h);
            const double fxy = (sagAt(s, x + h, y + h) - sagAt(s, x + h, y - h) -
                                sagAt(s, x - h, y + h) + sagAt(s, x - h, y - h)) /
                               (4.0 * h * h);
            const double g = std::max(std::abs(fxx), std::abs(fyy)) + std::abs(fxy);
            if (std::isfinite(g)) bound = std::max(bound, g);
        }
    }
    return 1.25 * bound;
}

double anamorphicSag(const BiconicShape& s, double x, double y) {
    if (!inDomain(s, x, y)) return kNaN;
    return sagOf(s, x * x, y * y);
}
double anamorphicSag(const ToroidalShape& s, double x, double y) {
    if (!inDomain(s, x, y)) return kNaN;
    return sagOf(s, x * x, y * y);
}

bool anamorphicInDomain(const BiconicShape& s, double x, double y) { return inDomain(s, x, y); }
bool anamorphicInDomain(const ToroidalShape& s, double x, double y) { return inDomain(s, x, y); }

// grad(z - S) = (-2 x S_X, -2 y S_Y, 1). For the biconic S = A / (1 + w), A = cx X + cy Y,
// w^2 = 1 - ax X - ay Y, so S_X = cx / (1 + w) + A ax / (2 w (1 + w)^2); scaled by w the
// gradient stays finite at the rim: (-2 x w S_X, -2 y w S_Y, w).
Vec3 anamorphicNormal(const BiconicShape& s, const Vec3& point) {
    const double X = point.x * point.x, Y = point.y * point.y;
    const double ax = (1.0 + s.xConic) * s.xCurvature * s.xCurvature;
    const double ay = (1.0 + s.yConic) * s.yCurvature * s.yCurvature;
    const double w = sqrtClamped(1.0 - ax * X - ay * Y);
    const double A = s.xCurvature * X + s.yCurvature * Y;
    const double onePlusW = 1.0 + w;
    const double common = A / (2.0 * onePlusW * onePlusW);
    const double wSx = s.xCurvature * w / onePlusW + common * ax;
    const double wSy = s.yCurvature * w / onePlusW + common * ay;
    return glm::normalize(Vec3{-2.0 * point.x * wSx, -2.0 * point.y * wSy, w});
}

// The toroid's slopes by forward derivatives in x and in y. At the rim of the sweep (where
// 1 - q^2 x^2 reaches 0) a slope is infinite and the normal lies in the x-y plane.
Vec3 anamorphicNormal(const ToroidalShape& s, const Vec3& point) {
    const Dual<double> xs{point.x, 1.0}, ys{point.y, 1.0};
    const Dual<double> x0{point.x, 0.0}, y0{point.y, 0.0};
    const double gx = sagOf(s, square(xs), square(y0)).d;
    const double gy = sagOf(s, square(x0), square(ys)).d;
    if (std::isfinite(gx) && std::isfinite(gy)) return glm::normalize(Vec3{-gx, -gy, 1.0});
    auto limit = [](double g) { return std::isinf(g) ? -std::copysign(1.0, g) : 0.0; };
    const Vec3 n{limit(gx), limit(gy), 0.0};
    return n == Vec3(0.0) ? Vec3{0.0, 0.0, 1.0} : glm::normalize(n);
}

double anamorphicMaxRadius(const BiconicShape& s) {
    return std::min(limitOf(s.xCurvature, s.xConic), limitOf(s.yCurvature, s.yConic));
}
double anamorphicMaxRadius(const ToroidalShape& s) {
    const double x = s.xCurvature == 0.0 ? kInf : 1.0 / std::abs(s.xCurvature);
    return std::min(x, limitOf(s.yCurvature, s.yConic));
}

std::optional<double> anamorphicSequential(const BiconicShape& s, const Ray& localRay) {
    return sequential(s, localRay);
}
std::optional<double> anamorphicSequential(const ToroidalShape& s, const Ray& localRay) {
    return sequential(s, localRay);
}
std::optional<ShapeHit> anamorphicFirst(const BiconicShape& s, const Ray& localRay, double tMin,
                                        double tMax, double rMax, bool startsOnSurface) {
    return first(s, localRay, tMin, tMax, rMax, startsOnSurface);
}
std::optional<ShapeHit> anamorphicFirst(const ToroidalShape& s, const Ray& localRay, double tMin,
                                        double tMax, double rMax, bool startsOnSurface) {
    return first(s, localRay, tMin, tMax, rMax, startsOnSurface);
}

}  // namespace veil
