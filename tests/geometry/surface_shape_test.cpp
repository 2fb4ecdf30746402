// Tests of the exact surfaces against independent truths: closed forms in long double, the
// sphere as |p - centre|^2 = R^2, and a brute-force root finder (dense sampling of
// z(t) - sag(r(t)) along the ray, then bisection, all in long double).
//
// The surface residual reported is the distance of the hit from the surface, to first order:
// |F| / |grad F| in long double, with F the implicit quadric c (x^2 + y^2 + (1+k) z^2) - 2 z
// for conics (defined across the rim) and F = z - sag(r) for aspheres. Where the surface is
// not steep this equals |z - sag(x, y)|, which is checked too.

#include "geometry/surface_shape.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace veil {
namespace {

using LD = long double;
// Binary128 (GCC's soft float, no library needed) for the sphere reference, where long double
// alone loses more digits to the |o - c|^2 - R^2 cancellation than the library does.
__extension__ typedef __float128 Quad;
Quad quadSqrt(Quad x) {
    Quad y = std::sqrt(static_cast<LD>(x));
    for (int i = 0; i < 3; ++i) y = (y + x / y) / 2;
    return y;
}
Quad quadAbs(Quad x) { return x < 0 ? -x : x; }
constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr LD kNaNLd = std::numeric_limits<LD>::quiet_NaN();

// Reference Surfaces (long double, written from the formulas, not from the library)

struct RefShape {
    LD c = 0, k = 0;
    std::array<LD, 10> a{};
    std::array<LD, 9> b{};   // odd terms b[j] r^(2j+3)
    std::array<LD, 10> e{};  // terms over w, e[i] r^(2i+2) / w
    bool quadric = true;     // plane, sphere or conic: the implicit form holds
};

RefShape refShape(const SurfaceShape& shape) {
    RefShape r;
    if (const auto* sphere = std::get_if<SphereShape>(&shape)) {
        r.c = sphere->curvature;
    } else if (const auto* conic = std::get_if<ConicShape>(&shape)) {
        r.c = conic->curvature;
        r.k = conic->conic;
    } else if (const auto* asphere = std::get_if<EvenAsphereShape>(&shape)) {
        r.c = asphere->curvature;
        r.k = asphere->conic;
        for (int i = 0; i < 10; ++i) r.a[i] = asphere->coefficients[i];
        for (int j = 0; j < 9; ++j) r.b[j] = asphere->odd[j];
        for (int i = 0; i < 10; ++i) r.e[i] = asphere->overW[i];
        r.quadric = false;
    }
    return r;
}

LD refSag(const RefShape& s, LD u) {
    const LD w2 = 1 - (1 + s.k) * s.c * s.c * u;
    if (w2 < 0) return kNaNLd;
    LD z = s.c * u / (1 + std::sqrt(w2));
    LD pw = u;
    for (int i = 0; i < 10; ++i) {
        z += s.a[i] * pw;
        pw *= u;
    }
    LD po = u * std::sqrt(u);  // r^3
    for (int j = 0; j < 9; ++j) {
        z += s.b[j] * po;
        po *= u;
    }
    LD pe = u;
    for (int i = 0; i < 10; ++i) {
        z += s.e[i] * pe / std::sqrt(w2);
        pe *= u;
    }
    return z;
}
LD refSlope(const RefShape& s, LD u) {  // dS/du
    LD d = s.c / (2 * std::sqrt(1 - (1 + s.k) * s.c * s.c * u));
    LD pw = 1;
    for (int i = 0; i < 10; ++i) {
        d += (i + 1) * s.a[i] * pw;
        pw *= u;
    }
    LD po = std::sqrt(u);  // u^(j + 1/2)
    for (int j = 0; j < 9; ++j) {
        d += (j + LD(1.5)) * s.b[j] * po;
        po *= u;
    }
    const LD bigK = (1 + s.k) * s.c * s.c, w = std::sqrt(1 - bigK * u);
    LD pe = 1;  // u^i
    for (int i = 0; i < 10; ++i) {
        d += s.e[i] * ((i + 1) * pe / w + pe * u * bigK / (2 * w * w * w));
        pe *= u;
    }
    return d;
}

// Distance of p from the surface to first order (mm).
LD surfaceDistance(const RefShape& s, const Vec3& p) {
    const LD x = p.x, y = p.y, z = p.z, u = x * x + y * y;
    if (s.quadric) {
        const LD g = s.c * (u + (1 + s.k) * z * z) - 2 * z;
        const LD gz = s.c * (1 + s.k) * z - 1;
        return std::abs(g) / (2 * std::sqrt(s.c * s.c * u + gz * gz));
    }
    const LD f = z - refSag(s, u);
    const LD sl = refSlope(s, u);
    return std::abs(f) / std::sqrt(1 + 4 * u * sl * sl);
}
// |z - sag(x, y)| in long double.
LD sagResidual(const RefShape& s, const Vec3& p) {
    return std::abs(LD(p.z) - refSag(s, LD(p.x) * p.x + LD(p.y) * p.y));
}

struct Worst {
    std::string name;
    LD distance = 0, sagResidual = 0, tError = 0;
    int count = 0;
    ~Worst() {
        std::cout << "[ worst    ] " << name << ": " << count << " hits, distance "
                  << double(distance) << " mm, |z - sag| " << double(sagResidual)
                  << " mm, |t - t_ref| " << double(tError) << " mm\n";
    }
    void hit(const RefShape& s, const Vec3& p) {
        ++count;
        distance = std::max(distance, surfaceDistance(s, p));
        // |z - sag| is the stated acceptance measure where the surface is not steep.
        const LD u = LD(p.x) * p.x + LD(p.y) * p.y;
        if (4 * u * refSlope(s, u) * refSlope(s, u) < 1) {
            sagResidual = std::max(sagResidual, ::veil::sagResidual(s, p));
        }
    }
};

// Every crossing of the sag height field in [t0, t1]: sign changes of f(t) = z(t) - sag(u(t))
// on n samples, each refined by long double bisection. Samples outside the sag's domain are
// skipped.
std::vector<LD> bruteForceRoots(const RefShape& s, const Ray& ray, LD t0, LD t1, int n) {
    const Vec3& o = ray.origin;
    const Vec3& d = ray.direction;
    auto f = [&](LD t) {
        const LD x = o.x + t * d.x, y = o.y + t * d.y, z = o.z + t * d.z;
        return z - refSag(s, x * x + y * y);
    };
    std::vector<LD> roots;
    LD tPrev = t0, fPrev = f(t0);
    for (int i = 1; i <= n; ++i) {
        const LD t = t0 + (t1 - t0) * i / n;
        const LD ft = f(t);
        if (std::isfinite(fPrev) && std::isfinite(ft) && ((fPrev < 0) != (ft < 0))) {
            LD lo = tPrev, hi = t;
            const bool loNeg = fPrev < 0;
            for (int it = 0; it < 90; ++it) {
                const LD m = (lo + hi) / 2;
                if ((f(m) < 0) == loNeg) {
                    lo = m;
                } else {
                    hi = m;
                }
            }
            roots.push_back((lo + hi) / 2);
        }
        tPrev = t;
        fPrev = ft;
    }
    return roots;
}

// Oracle for intersectSequential: the crossing nearest the tangent-plane crossing t0,
// searched in [t0 - window, t0 + window]; nothing if the nearest is not provably inside.
std::optional<LD> oracleSequential(const RefShape& s, const Ray& ray, LD window, int n) {
    const LD t0 = -LD(ray.origin.z) / ray.direction.z;
    std::optional<LD> best;
    for (LD t : bruteForceRoots(s, ray, t0 - window, t0 + window, n)) {
        if (!best || std::abs(t - t0) < std::abs(*best - t0)) best = t;
    }
    if (best && std::abs(*best - t0) > 0.99L * window) return std::nullopt;
    return best;
}

// Ray interval where the radial distance is at most rMax (long double), clipped to [lo, hi].
bool radialInterval(const Ray& ray, LD rMax, LD& lo, LD& hi) {
    const LD ox = ray.origin.x, oy = ray.origin.y, dx = ray.direction.x, dy = ray.direction.y;
    const LD a = dx * dx + dy * dy, b = ox * dx + oy * dy, c = ox * ox + oy * oy - rMax * rMax;
    if (a == 0) return c <= 0;
    const LD disc = b * b - a * c;
    if (disc < 0) return false;
    lo = std::max(lo, (-b - std::sqrt(disc)) / a);
    hi = std::min(hi, (-b + std::sqrt(disc)) / a);
    return lo <= hi;
}

// Oracle for intersectFirst with tMin = 0: the first crossing in (0, tMax] with r <= rMax.
std::optional<LD> oracleFirst(const RefShape& s, const Ray& ray, LD tMax, LD rMax, int n,
                              LD tMin = 0) {
    LD lo = tMin, hi = tMax;
    if (!radialInterval(ray, rMax, lo, hi)) return std::nullopt;
    for (LD t : bruteForceRoots(s, ray, lo, hi, n)) {
        if (t > tMin) return t;
    }
    return std::nullopt;
}

// Vec3 is a glm type, so gtest cannot find veil's operator<< for it by argument-dependent
// lookup; messages print it through this.
std::string text(const Vec3& v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

// Random test material

double logUniform(std::mt19937_64& rng, double lo, double hi) {
    return std::exp(std::uniform_real_distribution<double>(std::log(lo), std::log(hi))(rng));
}
double randomSign(std::mt19937_64& rng) {
    return std::uniform_int_distribution<int>(0, 1)(rng) ? 1.0 : -1.0;
}

// A unit direction within maxAngle of the +z or -z axis.
Vec3 randomDirection(std::mt19937_64& rng, double maxAngleRad) {
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const double cosMax = std::cos(maxAngleRad);
    const double cz = 1.0 - uni(rng) * (1.0 - cosMax);
    const double sz = std::sqrt(1.0 - cz * cz);
    const double phi = 2.0 * M_PI * uni(rng);
    return {sz * std::cos(phi), sz * std::sin(phi), randomSign(rng) * cz};
}

// A unit direction between minAngle and maxAngle from the +z or -z axis (uniform in angle).
Vec3 shallowDirection(std::mt19937_64& rng, double minAngleRad, double maxAngleRad) {
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const double theta = minAngleRad + (maxAngleRad - minAngleRad) * uni(rng);
    const double phi = 2.0 * M_PI * uni(rng);
    return {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
            randomSign(rng) * std::cos(theta)};
}

// A ray through a random point of the surface with r <= rTarget, starting `back` mm before it.
Ray rayThroughSurface(std::mt19937_64& rng, const SurfaceShape& shape, double rTarget,
                      double maxAngleRad, double back, double minAngleRad = -1.0) {
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    const double r = rTarget * std::sqrt(uni(rng));
    const double phi = 2.0 * M_PI * uni(rng);
    const Vec3 target{r * std::cos(phi), r * std::sin(phi), sag(shape, r * r)};
    const Vec3 d = minAngleRad < 0.0 ? randomDirection(rng, maxAngleRad)
                                     : shallowDirection(rng, minAngleRad, maxAngleRad);
    return {target - back * d, d};
}

// A random even asphere whose polynomial terms each reach up to `amplitudeMm` at r = rNorm.
EvenAsphereShape randomAsphere(std::mt19937_64& rng, double rNorm, double amplitudeMm) {
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    EvenAsphereShape s;
    const int kind = std::uniform_int_distribution<int>(0, 3)(rng);
    s.curvature = kind == 0 ? 0.0 : randomSign(rng) * logUniform(rng, 1.0 / 400.0, 1.0 / 40.0);
    s.conic = kind == 1 ? -1.0 : std::uniform_real_distribution<double>(-3.0, 1.0)(rng);
    const int terms = std::uniform_int_distribution<int>(1, 6)(rng);
    for (int i = 0; i < terms; ++i) {
        const int index = std::uniform_int_distribution<int>(0, 9)(rng);
        s.coefficients[index] = uni(rng) * amplitudeMm / std::pow(rNorm, 2 * index + 2);
    }
    if (std::all_of(s.coefficients.begin(), s.coefficients.end(),
                    [](double v) { return v == 0.0; })) {
        s.coefficients[1] = 1e-5;
    }
    return s;
}

// Shape Construction and Evaluation

TEST(SurfaceShape, MakeShapePicksSimplestExactType) {
    const std::array<double, 10> none{};
    std::array<double, 10> a4{};
    a4[1] = 1e-6;
    std::array<double, 10> a2{};
    a2[0] = 1e-3;
    EXPECT_TRUE(std::holds_alternative<PlaneShape>(makeShape(0.0, 0.0, none)));
    EXPECT_TRUE(std::holds_alternative<PlaneShape>(makeShape(0.0, -1.0, none)));
    EXPECT_TRUE(std::holds_alternative<SphereShape>(makeShape(0.02, 0.0, none)));
    EXPECT_TRUE(std::holds_alternative<ConicShape>(makeShape(0.02, -1.0, none)));
    EXPECT_TRUE(std::holds_alternative<ConicShape>(makeShape(-0.02, 0.5, none)));
    EXPECT_TRUE(std::holds_alternative<EvenAsphereShape>(makeShape(0.02, 0.0, a4)));
    // The r^2 term curves a flat base: it is an asphere, not a plane.
    const SurfaceShape flatA2 = makeShape(0.0, 0.0, a2);
    ASSERT_TRUE(std::holds_alternative<EvenAsphereShape>(flatA2));
    EXPECT_DOUBLE_EQ(sag(flatA2, 4.0), 4e-3);
    EXPECT_EQ(std::get<SphereShape>(makeShape(0.02, 0.0, none)).curvature, 0.02);
    const ConicShape conic = std::get<ConicShape>(makeShape(0.03, -2.0, none));
    EXPECT_EQ(conic.curvature, 0.03);
    EXPECT_EQ(conic.conic, -2.0);
}

TEST(SurfaceShape, SagMatchesClosedForms) {
    // Sphere: R - sqrt(R^2 - r^2) in long double (no cancellation at these sizes in 64 bits).
    for (double radius : {10.0, -37.5, 1e3}) {
        const SurfaceShape s = SphereShape{1.0 / radius};
        for (double r : {0.0, 1e-6, 0.5, 3.0, 9.0}) {
            const LD R = radius, expected = R - (R > 0 ? 1 : -1) * std::sqrt(R * R - LD(r) * r);
            EXPECT_NEAR(sag(s, r * r), double(expected), 1e-15 * std::abs(radius)) << s;
        }
    }
    // Near the vertex and for huge radii, against the binomial series
    // c u (1/2 + x/8 + x^2/16 + 5 x^3/128), x = (1 + k) c^2 u, to a relative 1e-15: the
    // textbook (1 - w) / ((1 + k) c) would be wrong in every digit.
    for (double c : {1e-9, -1e-9, 0.05}) {
        for (double k : {0.0, 2.0, -1.0, -4.0}) {
            const SurfaceShape s = ConicShape{c, k};
            for (double u : {1e-20, 1e-10, 1e-4}) {
                const LD x = (1 + LD(k)) * LD(c) * c * u;
                const LD expected = LD(c) * u * (0.5L + x / 8 + x * x / 16 + 5 * x * x * x / 128);
                EXPECT_NEAR(sag(s, u), double(expected), 1e-15 * std::abs(double(expected)))
                    << s << " u " << u;
            }
        }
    }
    // Paraboloid sag is exactly c r^2 / 2; beyond an ellipsoid's rim the sag is NaN.
    EXPECT_DOUBLE_EQ(sag(ConicShape{0.1, -1.0}, 400.0), 20.0);
    EXPECT_TRUE(std::isnan(sag(SphereShape{0.1}, 100.0 * (1 + 1e-12))));
    EXPECT_DOUBLE_EQ(sag(SphereShape{0.1}, 100.0), 10.0);  // the rim itself
    EXPECT_TRUE(std::isnan(sag(ConicShape{0.1, 1.0}, 60.0)));
    EXPECT_EQ(sag(PlaneShape{}, 1e6), 0.0);
    // Asphere: base conic plus the polynomial, against long double.
    EvenAsphereShape a{0.02, -0.7, {}};
    a.coefficients = {1e-4, 2e-6, -3e-9, 4e-12, 0, 0, 0, 0, 0, 1e-40};
    for (double r : {0.0, 1.0, 7.5, 15.0}) {
        EXPECT_NEAR(sag(a, r * r), double(refSag(refShape(a), LD(r) * r)), 1e-14) << r;
    }
}

TEST(SurfaceShape, MaxRadiusIsTheConicDomain) {
    EXPECT_EQ(maxRadius(PlaneShape{}), kInf);
    EXPECT_DOUBLE_EQ(maxRadius(SphereShape{0.05}), 20.0);
    EXPECT_DOUBLE_EQ(maxRadius(SphereShape{-0.05}), 20.0);
    EXPECT_DOUBLE_EQ(maxRadius(ConicShape{0.05, 3.0}), 10.0);                // oblate
    EXPECT_DOUBLE_EQ(maxRadius(ConicShape{0.05, -0.75}), 40.0);              // prolate
    EXPECT_EQ(maxRadius(ConicShape{0.05, -1.0}), kInf);                      // paraboloid
    EXPECT_EQ(maxRadius(ConicShape{0.05, -2.5}), kInf);                      // hyperboloid
    EXPECT_EQ(maxRadius(SphereShape{0.0}), kInf);                            // flat
    EXPECT_DOUBLE_EQ(maxRadius(SphereShape{1e-300}), 1e300);                 // no overflow
    EXPECT_DOUBLE_EQ(maxRadius(EvenAsphereShape{0.05, 0.0, {1e-3}}), 20.0);  // conic limit
    EXPECT_EQ(maxRadius(EvenAsphereShape{0.05, -1.0, {1e-3}}), kInf);
    // At maxRadius the sag is defined, just beyond it is not.
    const SurfaceShape oblate = ConicShape{0.05, 3.0};
    EXPECT_TRUE(std::isfinite(sag(oblate, 100.0)));
    EXPECT_TRUE(std::isnan(sag(oblate, 100.0 * (1 + 1e-9))));
}

TEST(SurfaceShape, NormalMatchesFiniteDifferencesOfSag) {
    std::mt19937_64 rng(11);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    std::vector<SurfaceShape> shapes = {
        PlaneShape{},          SphereShape{0.04},       SphereShape{-1e-9},
        ConicShape{0.03, 1.5}, ConicShape{-0.02, -1.0}, ConicShape{0.05, -3.0}};
    for (int i = 0; i < 4; ++i) shapes.push_back(randomAsphere(rng, 15.0, 1.0));
    LD worst = 0;
    for (const SurfaceShape& shape : shapes) {
        const RefShape ref = refShape(shape);
        const double rLim = std::min(0.9 * maxRadius(shape), 15.0);
        EXPECT_TRUE(surfaceNormal(shape, {0.0, 0.0, 0.0}) == Vec3(0.0, 0.0, 1.0)) << shape;
        for (int j = 0; j < 200; ++j) {
            const double x = rLim * uni(rng) / std::sqrt(2.0), y = rLim * uni(rng) / std::sqrt(2.0);
            const Vec3 p{x, y, sag(shape, x * x + y * y)};
            const Vec3 n = surfaceNormal(shape, p);
            // Central differences of the sag in long double, step 1e-5 mm.
            const LD h = 1e-5L;
            auto s = [&](LD px, LD py) { return refSag(ref, px * px + py * py); };
            const LD sx = (s(x + h, y) - s(x - h, y)) / (2 * h);
            const LD sy = (s(x, y + h) - s(x, y - h)) / (2 * h);
            const LD len = std::sqrt(1 + sx * sx + sy * sy);
            const LD err = std::max(
                {std::abs(n.x + sx / len), std::abs(n.y + sy / len), std::abs(n.z - 1 / len)});
            worst = std::max(worst, err);
            ASSERT_LT(err, 1e-8) << shape << " at " << text(p) << " normal " << text(n);
            ASSERT_NEAR(glm::length(n), 1.0, 4e-16);
            ASSERT_GT(n.z, 0.0);
        }
    }
    // Tiny curvature: the normal tilts by c r without loss.
    const Vec3 n = surfaceNormal(SphereShape{1e-9}, {10.0, 0.0, sag(SphereShape{1e-9}, 100.0)});
    EXPECT_NEAR(n.x, -1e-8, 1e-22);
    // An ellipsoid's rim: the normal is horizontal, not NaN.
    const SurfaceShape ell = ConicShape{0.05, 3.0};
    const Vec3 rim = surfaceNormal(ell, {10.0, 0.0, sag(ell, 100.0)});
    EXPECT_NEAR(rim.x, -1.0, 1e-12);
    EXPECT_NEAR(rim.z, 0.0, 1e-7);
    std::cout << "[ worst    ] normal vs finite differences: " << double(worst) << "\n";
}

// Sequential Intersection

TEST(SurfaceShape, SequentialPicksVertexSheetNearestTangentPlane) {
    const SurfaceShape sphere = SphereShape{1.0 / 20.0};
    const LD sag25 = 20 - std::sqrt(400.0L - 25);
    // Forward, backward (after a mirror) and from behind the surface (virtual, t < 0).
    EXPECT_NEAR(*intersectSequential(sphere, {{5, 0, -10}, {0, 0, 1}}), double(10 + sag25), 1e-14);
    EXPECT_NEAR(*intersectSequential(sphere, {{0, 5, 100}, {0, 0, -1}}), double(100 - sag25),
                1e-13);
    EXPECT_NEAR(*intersectSequential(sphere, {{5, 0, 5}, {0, 0, 1}}), double(sag25 - 5), 1e-14);
    // Hyperboloid: an axial ray crosses the mirror sheet at z = -10 first; the vertex sheet
    // at z = 0 is the surface.
    EXPECT_NEAR(*intersectSequential(ConicShape{0.1, -3.0}, {{0, 0, -100}, {0, 0, 1}}), 100.0,
                1e-13);
    // Paraboloid met parallel to its axis: the quadratic degenerates to a linear equation.
    EXPECT_NEAR(*intersectSequential(ConicShape{0.1, -1.0}, {{3, 0, -100}, {0, 0, 1}}), 100.45,
                1e-12);
    // Oblate ellipsoid: inside and beyond its rim (maxRadius 10).
    EXPECT_TRUE(intersectSequential(ConicShape{0.05, 3.0}, {{9.9, 0, -1}, {0, 0, 1}}));
    EXPECT_FALSE(intersectSequential(ConicShape{0.05, 3.0}, {{10.1, 0, -1}, {0, 0, 1}}));
    EXPECT_FALSE(intersectSequential(sphere, {{25, 0, -1}, {0, 0, 1}}));
    // A shallow ray crossing the vertex hemisphere twice: the crossing nearer the tangent
    // plane crossing (at x = -100) is the first one.
    const Vec3 d = glm::normalize(Vec3(1.0, 0.0, 0.05));
    const Ray shallow{{-100.0, 0.0, 0.0}, d};
    const LD t = *intersectSequential(sphere, shallow);
    const std::vector<LD> roots = bruteForceRoots(refShape(sphere), shallow, 0, 200, 20000);
    ASSERT_EQ(roots.size(), 2u);
    EXPECT_NEAR(double(t), double(roots[0]), 1e-12);
    // Parallel to the tangent plane: the crossing nearest the origin.
    const Ray flat{{-30.0, 0.0, 2.0}, {1.0, 0.0, 0.0}};
    const LD xHit = std::sqrt(400.0L - 18.0L * 18.0L);
    EXPECT_NEAR(*intersectSequential(sphere, flat), double(30 - xHit), 1e-13);
    // Plane.
    EXPECT_DOUBLE_EQ(*intersectSequential(PlaneShape{}, {{1, 2, -3}, {0, 0.6, 0.8}}), 3.75);
    EXPECT_FALSE(intersectSequential(PlaneShape{}, {{1, 2, -3}, {1, 0, 0}}));
}

TEST(SurfaceShape, SphereMatchesCentreFormulation) {
    std::mt19937_64 rng(1);
    Worst worst{"sphere vs |p - c|^2 = R^2"};
    for (int i = 0; i < 2000; ++i) {
        const double radius = randomSign(rng) * logUniform(rng, 1e-3, 1e4);
        const SurfaceShape shape = SphereShape{1.0 / radius};
        const double back = logUniform(rng, 1e-3, 1e3);
        const Ray ray = rayThroughSurface(rng, shape, 0.95 * std::abs(radius), 1.2, back);
        // |o + t d - (0, 0, R)|^2 = R^2 in binary128, both roots.
        const Vec3& o = ray.origin;
        const Vec3& d = ray.direction;
        const Quad R = radius, ox = o.x, oy = o.y, oz = Quad(o.z) - R;
        const Quad b = ox * d.x + oy * d.y + oz * d.z;
        const Quad c = ox * ox + oy * oy + oz * oz - R * R;
        const Quad a = Quad(d.x) * d.x + Quad(d.y) * d.y + Quad(d.z) * d.z;
        const Quad disc = b * b - a * c;
        ASSERT_TRUE(disc >= 0) << ray;  // the ray goes through a point of the sphere
        const Quad t0 = -Quad(o.z) / d.z;
        std::optional<Quad> expected;
        for (Quad tRoot : {(-b - quadSqrt(disc)) / a, (-b + quadSqrt(disc)) / a}) {
            const Quad z = Quad(o.z) + tRoot * d.z;
            if (z / R > 1) continue;  // far hemisphere
            if (!expected || quadAbs(tRoot - t0) < quadAbs(*expected - t0)) expected = tRoot;
        }
        ASSERT_TRUE(expected) << ray;
        const std::optional<double> t = intersectSequential(shape, ray);
        ASSERT_TRUE(t) << shape << " " << ray;
        const LD err = static_cast<LD>(quadAbs(*t - *expected));
        worst.tError = std::max(worst.tError, err);
        ASSERT_LT(err, 1e-9) << shape << " " << ray;
        const Vec3 hit = o + *t * d;
        worst.hit(refShape(shape), hit);
        ASSERT_LT(surfaceDistance(refShape(shape), hit), 1e-9) << shape << " " << ray;
    }
}

TEST(SurfaceShape, ConicMatchesBruteForce) {
    std::mt19937_64 rng(2);
    Worst seq{"conic sequential vs brute force"};
    Worst first{"conic first vs brute force"};
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    const double conics[] = {0.0, 0.6, 3.0, -0.5, -1.0, -1.0001, -2.5, -8.0};
    for (int i = 0; i < 400; ++i) {
        const double k = conics[i % 8];
        const double c = randomSign(rng) * logUniform(rng, 1.0 / 300.0, 1.0 / 15.0);
        const SurfaceShape shape = ConicShape{c, k};
        const RefShape ref = refShape(shape);
        const double rAp = std::min(0.8 * maxRadius(shape), 20.0);
        Ray ray = rayThroughSurface(rng, shape, rAp, 1.2, logUniform(rng, 0.1, 100.0));
        if (i % 4 == 3) ray.origin += Vec3(uni(rng), uni(rng), 0.0) * 15.0;  // may miss

        const std::optional<LD> expectSeq = oracleSequential(ref, ray, 300, 12000);
        const std::optional<double> tSeq = intersectSequential(shape, ray);
        if (expectSeq) {
            ASSERT_TRUE(tSeq) << shape << " " << ray;
            const LD err = std::abs(*tSeq - *expectSeq);
            seq.tError = std::max(seq.tError, err);
            ASSERT_LT(err, 1e-9) << shape << " " << ray << " oracle " << double(*expectSeq);
            seq.hit(ref, ray.origin + *tSeq * ray.direction);
        }

        const std::optional<LD> expectFirst = oracleFirst(ref, ray, 500, rAp, 10000);
        const std::optional<ShapeHit> hit = intersectFirst(shape, ray, 0.0, 500.0, rAp, false);
        ASSERT_EQ(bool(expectFirst), bool(hit)) << shape << " " << ray;
        if (hit) {
            const LD err = std::abs(hit->t - *expectFirst);
            first.tError = std::max(first.tError, err);
            ASSERT_LT(err, 1e-9) << shape << " " << ray << " oracle " << double(*expectFirst);
            first.hit(ref, hit->point);
            ASSERT_LT(surfaceDistance(ref, hit->point), 1e-9);
            ASSERT_LT(glm::length(hit->point - (ray.origin + hit->t * ray.direction)), 1e-12);
            ASSERT_NEAR(glm::length(hit->normal), 1.0, 1e-15);
        }
    }
    EXPECT_GT(seq.count, 250);
    EXPECT_GT(first.count, 150);
}

TEST(SurfaceShape, AsphereMatchesBruteForce) {
    std::mt19937_64 rng(3);
    Worst seq{"asphere sequential vs brute force"};
    Worst first{"asphere first vs brute force"};
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    int firstMisses = 0, severalCrossings = 0;
    for (int i = 0; i < 300; ++i) {
        // Every other case is a wavy asphere met by a shallow ray (70 to 89 degrees from
        // the axis), which crosses it several times.
        const bool wavy = i % 2 == 1;
        const double rAp = 20.0;
        const EvenAsphereShape asphere =
            randomAsphere(rng, rAp, wavy ? logUniform(rng, 1.0, 6.0) : logUniform(rng, 0.01, 3.0));
        const SurfaceShape shape = asphere;
        const RefShape ref = refShape(shape);
        const double rIn = std::min(0.8 * maxRadius(shape), rAp);
        Ray ray = wavy ? rayThroughSurface(rng, shape, rIn, 1.55, logUniform(rng, 0.1, 30.0), 1.22)
                       : rayThroughSurface(rng, shape, rIn, 1.3, logUniform(rng, 0.1, 100.0));
        if (i % 4 == 3) ray.origin += Vec3(uni(rng), uni(rng), 0.0) * 15.0;  // may miss

        const std::optional<LD> expectSeq = oracleSequential(ref, ray, 100, 15000);
        const std::optional<double> tSeq = intersectSequential(shape, ray);
        if (expectSeq) {
            ASSERT_TRUE(tSeq) << shape << " " << ray;
            const LD err = std::abs(*tSeq - *expectSeq);
            seq.tError = std::max(seq.tError, err);
            ASSERT_LT(err, 1e-9) << shape << " " << ray << " oracle " << double(*expectSeq);
            seq.hit(ref, ray.origin + *tSeq * ray.direction);
            ASSERT_LT(surfaceDistance(ref, ray.origin + *tSeq * ray.direction), 1e-9);
        }

        const double rMax = std::min(rAp, 0.99 * maxRadius(shape));
        const std::optional<LD> expectFirst = oracleFirst(ref, ray, 400, rMax, 20000);
        {
            LD lo = 0, hi = 400;
            if (radialInterval(ray, rMax, lo, hi) &&
                bruteForceRoots(ref, ray, lo, hi, 20000).size() > 1) {
                ++severalCrossings;
            }
        }
        const std::optional<ShapeHit> hit = intersectFirst(shape, ray, 0.0, 400.0, rMax, false);
        ASSERT_EQ(bool(expectFirst), bool(hit)) << shape << " " << ray;
        if (!hit) {
            ++firstMisses;
            continue;
        }
        const LD err = std::abs(hit->t - *expectFirst);
        first.tError = std::max(first.tError, err);
        ASSERT_LT(err, 1e-9) << shape << " " << ray << " oracle " << double(*expectFirst);
        first.hit(ref, hit->point);
        ASSERT_LT(surfaceDistance(ref, hit->point), 1e-9);
    }
    EXPECT_GT(seq.count, 200);
    EXPECT_GT(first.count, 100);
    EXPECT_GT(firstMisses, 10);
    EXPECT_GT(severalCrossings, 10);
    std::cout << "[ info     ] asphere first: " << firstMisses << " rays with no crossing, "
              << severalCrossings << " with several\n";
}

// Odd asphere terms (Zemax ODDASPH): the even asphere plus b r^3, b r^5, ...
EvenAsphereShape randomOddAsphere(std::mt19937_64& rng, double rNorm, double amplitudeMm) {
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    EvenAsphereShape s = randomAsphere(rng, rNorm, amplitudeMm);
    const int terms = std::uniform_int_distribution<int>(1, 3)(rng);
    for (int t = 0; t < terms; ++t) {
        const int j = std::uniform_int_distribution<int>(0, 4)(rng);
        s.odd[j] = uni(rng) * amplitudeMm / std::pow(rNorm, 2 * j + 3);
    }
    return s;
}

// The normal at radius r (on the x axis) is along grad(z - sag): a central difference in x.
void expectNormalAlongSagGradient(const SurfaceShape& shape, double r) {
    const Vec3 p(r, 0.0, sag(shape, r * r));
    const double h = 1e-6;
    const double dzdx = (sag(shape, (r + h) * (r + h)) - sag(shape, (r - h) * (r - h))) / (2 * h);
    const Vec3 n = surfaceNormal(shape, p);
    const Vec3 expectedN = glm::normalize(Vec3(-dzdx, 0.0, 1.0));
    EXPECT_NEAR(n.x, expectedN.x, 1e-8) << r;
    EXPECT_NEAR(n.z, expectedN.z, 1e-8) << r;
}

TEST(SurfaceShape, OddTermsAddToTheSagAndTheNormalAsWritten) {
    EvenAsphereShape s;
    s.curvature = 1.0 / 80.0;
    s.odd[0] = 2e-5;   // r^3
    s.odd[1] = -3e-8;  // r^5
    const SurfaceShape shape = s;
    for (double r : {0.0, 0.5, 3.0, 11.0, 19.5}) {
        const double u = r * r;
        const double expected = (1.0 / 80.0) * u / (1.0 + std::sqrt(1.0 - u / 6400.0)) +
                                2e-5 * r * r * r - 3e-8 * std::pow(r, 5);
        EXPECT_NEAR(sag(shape, u), expected, 1e-14 * (1.0 + std::abs(expected))) << r;
        expectNormalAlongSagGradient(shape, r);
    }
    EXPECT_TRUE(std::holds_alternative<EvenAsphereShape>(makeShape(0.0, 0.0, {}, s.odd)));
}

// Random shapes from `make` against the brute-force root finder: half of them wavy and met
// by shallow rays (several crossings), a quarter shifted to miss; sequential and first hits
// within 1e-9 mm of the oracle's.
template <class MakeShape>
void matchBruteForce(const char* name, uint64_t seed, int cases, MakeShape make, int minSeq,
                     int minFirst) {
    std::mt19937_64 rng(seed);
    const std::string label(name);
    Worst seq{label + " sequential vs brute force"};
    Worst first{label + " first vs brute force"};
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    for (int i = 0; i < cases; ++i) {
        const bool wavy = i % 2 == 1;
        const double rAp = 20.0;
        const SurfaceShape shape =
            make(rng, rAp, wavy ? logUniform(rng, 1.0, 6.0) : logUniform(rng, 0.01, 3.0));
        const RefShape ref = refShape(shape);
        const double rIn = std::min(0.8 * maxRadius(shape), rAp);
        Ray ray = wavy ? rayThroughSurface(rng, shape, rIn, 1.55, logUniform(rng, 0.1, 30.0), 1.22)
                       : rayThroughSurface(rng, shape, rIn, 1.3, logUniform(rng, 0.1, 100.0));
        if (i % 4 == 3) ray.origin += Vec3(uni(rng), uni(rng), 0.0) * 15.0;  // may miss

        const std::optional<LD> expectSeq = oracleSequential(ref, ray, 100, 15000);
        const std::optional<double> tSeq = intersectSequential(shape, ray);
        if (expectSeq) {
            ASSERT_TRUE(tSeq) << shape << " " << ray;
            const LD err = std::abs(*tSeq - *expectSeq);
            seq.tError = std::max(seq.tError, err);
            ASSERT_LT(err, 1e-9) << shape << " " << ray << " oracle " << double(*expectSeq);
            seq.hit(ref, ray.origin + *tSeq * ray.direction);
        }
        const double rMax = std::min(rAp, 0.99 * maxRadius(shape));
        const std::optional<LD> expectFirst = oracleFirst(ref, ray, 400, rMax, 20000);
        const std::optional<ShapeHit> hit = intersectFirst(shape, ray, 0.0, 400.0, rMax, false);
        ASSERT_EQ(bool(expectFirst), bool(hit)) << shape << " " << ray;
        if (!hit) continue;
        const LD err = std::abs(hit->t - *expectFirst);
        first.tError = std::max(first.tError, err);
        ASSERT_LT(err, 1e-9) << shape << " " << ray << " oracle " << double(*expectFirst);
        first.hit(ref, hit->point);
        ASSERT_LT(surfaceDistance(ref, hit->point), 1e-9);
    }
    EXPECT_GT(seq.count, minSeq);
    EXPECT_GT(first.count, minFirst);
}

TEST(SurfaceShape, OddAsphereMatchesBruteForce) {
    matchBruteForce(
        "odd asphere", 13, 200,
        [](std::mt19937_64& rng, double rAp, double amplitude) -> SurfaceShape {
            return randomOddAsphere(rng, rAp, amplitude);
        },
        130, 60);
}

// Terms over w (Forbes's Qbfs departure, geometry/qtype.h): a sphere of radius 30 to 300 mm
// plus e[i] r^(2i+2) / w, each term's scale set so that it departs by about the amplitude at
// the aperture's rim.
TEST(SurfaceShape, TermsOverWMatchBruteForce) {
    matchBruteForce(
        "terms over w", 17, 200,
        [](std::mt19937_64& rng, double rAp, double amplitude) -> SurfaceShape {
            std::uniform_real_distribution<double> uni(-1.0, 1.0);
            EvenAsphereShape s;
            s.curvature = randomSign(rng) / logUniform(rng, 30.0, 300.0);
            const int terms = std::uniform_int_distribution<int>(1, 4)(rng);
            for (int t = 0; t < terms; ++t) {
                const int i = std::uniform_int_distribution<int>(0, 6)(rng);
                s.overW[i] = uni(rng) * amplitude / std::pow(rAp, 2 * i + 2);
            }
            return s;
        },
        130, 60);
}

TEST(SurfaceShape, TermsOverWAddToTheSagAndTheNormalAsWritten) {
    EvenAsphereShape s;
    s.curvature = 1.0 / 80.0;
    s.overW[0] = 1e-3;   // r^2 / w
    s.overW[2] = -2e-9;  // r^6 / w
    const SurfaceShape shape = s;
    for (double r : {0.0, 0.5, 3.0, 11.0, 19.5}) {
        const double u = r * r, w = std::sqrt(1.0 - u / 6400.0);
        const double expected = (1.0 / 80.0) * u / (1.0 + w) + (1e-3 * u - 2e-9 * u * u * u) / w;
        EXPECT_NEAR(sag(shape, u), expected, 1e-14 * (1.0 + std::abs(expected))) << r;
        expectNormalAlongSagGradient(shape, r);
    }
    // Terms over w need the sag's square root to grow less than linearly: not a hyperboloid.
    EXPECT_THROW(makeShape(0.01, -2.0, {}, {}, s.overW), std::invalid_argument);
}

// Hard Cases

TEST(SurfaceShape, ExtremeRadiiKeepResidualsTiny) {
    std::mt19937_64 rng(4);
    Worst huge{"radius +-1e9 mm"};
    Worst tiny{"radius +-1e-3 mm"};
    for (int i = 0; i < 300; ++i) {
        const double s = randomSign(rng);
        // Huge radii: the sag is ~5e-6 mm at r = 100, far above the 1e-9 tolerance, so a
        // plane answer would fail.
        std::array<double, 10> a{};
        if (i % 3 == 2) a[1] = 1e-14 * s;
        const SurfaceShape big = makeShape(s * 1e-9, (i % 3 == 1) ? -5.0 : 0.0, a);
        const RefShape refBig = refShape(big);
        const Ray r1 = rayThroughSurface(rng, big, 100.0, 1.0, logUniform(rng, 1.0, 100.0));
        const std::optional<double> t1 = intersectSequential(big, r1);
        ASSERT_TRUE(t1);
        const std::optional<LD> e1 = oracleSequential(refBig, r1, 200, 20000);
        ASSERT_TRUE(e1);
        ASSERT_LT(std::abs(*t1 - *e1), 1e-9) << big << " " << r1;
        huge.tError = std::max(huge.tError, std::abs(*t1 - *e1));
        huge.hit(refBig, r1.origin + *t1 * r1.direction);
        ASSERT_LT(sagResidual(refBig, r1.origin + *t1 * r1.direction), 1e-9);
        const std::optional<ShapeHit> h1 = intersectFirst(big, r1, 0.0, kInf, kInf, false);
        ASSERT_TRUE(h1);
        ASSERT_LT(std::abs(h1->t - *e1), 1e-9);
        huge.hit(refBig, h1->point);

        // Tiny radii (1 um), rays from up to 100 mm away: the residual must stay far below
        // the surface's own size.
        const SurfaceShape small = makeShape(s * 1e3, (i % 3 == 1) ? 0.5 : (i % 3) * -2.0, {});
        const RefShape refSmall = refShape(small);
        const double rIn = std::min(0.9 * maxRadius(small), 1e-3);
        const Ray r2 = rayThroughSurface(rng, small, rIn, 1.2, logUniform(rng, 1e-3, 100.0));
        const std::optional<ShapeHit> h2 = intersectFirst(small, r2, -kInf, kInf, kInf, false);
        ASSERT_TRUE(h2) << small << " " << r2;
        tiny.hit(refSmall, h2->point);
        ASSERT_LT(surfaceDistance(refSmall, h2->point), 1e-12) << small << " " << r2;
        const std::optional<double> t2 = intersectSequential(small, r2);
        ASSERT_TRUE(t2);
        ASSERT_LT(surfaceDistance(refSmall, r2.origin + *t2 * r2.direction), 1e-9);
    }
}

// A unit tangent of the surface at p, rotated out of the tangent plane by asin(sinAlpha)
// toward -n: the cosine between the ray and the normal is sinAlpha.
Vec3 grazingDirection(const RefShape& ref, const Vec3& p, double phi, double sinAlpha) {
    const LD u = LD(p.x) * p.x + LD(p.y) * p.y;
    const LD sl = refSlope(ref, u);
    LD n[3] = {-2 * p.x * sl, -2 * p.y * sl, 1};
    const LD nl = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (LD& v : n) v /= nl;
    // A tangent: the horizontal direction (cos phi, sin phi, 0) made orthogonal to n.
    LD t[3] = {std::cos(LD(phi)), std::sin(LD(phi)), 0};
    const LD dot = t[0] * n[0] + t[1] * n[1];
    for (int i = 0; i < 3; ++i) t[i] -= dot * n[i];
    const LD tl = std::sqrt(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    const LD ca = std::sqrt(1 - LD(sinAlpha) * sinAlpha);
    return Vec3(double(ca * t[0] / tl - sinAlpha * n[0]), double(ca * t[1] / tl - sinAlpha * n[1]),
                double(ca * t[2] / tl - sinAlpha * n[2]));
}

TEST(SurfaceShape, GrazingRaysHitOnTheSurface) {
    // A ray through a surface point p at an angle alpha to the tangent plane (cosine to the
    // normal sin(alpha)) meets the surface again about 2 alpha / kappa along, kappa the normal
    // curvature, and between the two crossings dips only alpha^2 / (2 kappa) below it. At
    // sin(alpha) = 1e-8 that depth is 1e-15 mm on a 20 mm radius, below the rounding of the
    // ray's own coordinates, so whether such a ray hits is not decided by its double-precision
    // data; on large radii (and at 1e-6 on any radius) it is, and a hit is required.
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    Worst worst{"grazing, cos(ray, normal) = 1e-8 (1e-6 on small radii)"};
    EvenAsphereShape asph{0.02, -1.0, {}};
    asph.coefficients[1] = 2e-6;
    asph.coefficients[2] = -1e-9;
    EvenAsphereShape flatAsph{-1e-7, 0.0, {}};
    flatAsph.coefficients[1] = 1e-14;
    struct Case {
        SurfaceShape shape;
        double sinAlpha;
        bool mustHit;
    };
    std::vector<Case> cases;
    for (double sinAlpha : {1e-8, 1e-6}) {
        const bool mustHit = sinAlpha > 1e-7;
        for (const SurfaceShape& s :
             {SurfaceShape{SphereShape{0.05}}, SurfaceShape{SphereShape{-0.01}},
              SurfaceShape{ConicShape{0.04, 2.0}}, SurfaceShape{ConicShape{-0.03, -1.0}},
              SurfaceShape{ConicShape{0.02, -4.0}}, SurfaceShape{asph}}) {
            cases.push_back({s, sinAlpha, mustHit});
        }
    }
    for (const SurfaceShape& s : {SurfaceShape{SphereShape{1e-9}}, SurfaceShape{SphereShape{-1e-5}},
                                  SurfaceShape{ConicShape{1e-6, -3.0}}, SurfaceShape{flatAsph}}) {
        cases.push_back({s, 1e-8, true});
    }
    int required = 0, optional = 0, optionalHits = 0;
    for (const Case& cs : cases) {
        const RefShape ref = refShape(cs.shape);
        const double rIn = std::min(0.7 * maxRadius(cs.shape), 15.0);
        for (int i = 0; i < 60; ++i) {
            const double r = rIn * (0.2 + 0.8 * uni(rng)), phi = 2 * M_PI * uni(rng);
            const Vec3 p{r * std::cos(phi), r * std::sin(phi), sag(cs.shape, r * r)};
            const double sinAlpha = cs.sinAlpha * randomSign(rng);
            const Vec3 d = grazingDirection(ref, p, 2 * M_PI * uni(rng), sinAlpha);
            const Ray ray{p - 10.0 * d, d};
            // Both crossings lie within about 2 alpha / kappa of p (20 mm at most here).
            const std::optional<ShapeHit> hit =
                intersectFirst(cs.shape, ray, 0.0, kInf, kInf, false);
            const std::optional<double> t = intersectSequential(cs.shape, ray);
            if (cs.mustHit) {
                ASSERT_TRUE(hit) << cs.shape << " " << ray;
                ASSERT_TRUE(t) << cs.shape << " " << ray;
                ++required;
            } else {
                ++optional;
                optionalHits += bool(hit);
            }
            if (hit) {
                worst.hit(ref, hit->point);
                ASSERT_LT(surfaceDistance(ref, hit->point), 1e-9) << cs.shape << " " << ray;
                ASSERT_LT(glm::length(hit->point - p), 1e-4 + 2.5 * cs.sinAlpha / std::abs(ref.c))
                    << cs.shape << " " << ray;
            }
            if (t) {
                const Vec3 q = ray.origin + *t * d;
                worst.hit(ref, q);
                ASSERT_LT(surfaceDistance(ref, q), 1e-9) << cs.shape << " " << ray;
            }
        }
    }
    std::cout << "[ info     ] grazing: " << required << " required hits, " << optionalHits
              << " of " << optional << " undecided rays (1e-8 on small radii) hit\n";
}

// Rays Starting on the Surface

TEST(SurfaceShape, RayStartingOnSphereFindsTheChord) {
    std::mt19937_64 rng(6);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    Worst worst{"sphere chords from the surface"};
    int hits = 0, misses = 0;
    for (int i = 0; i < 1000; ++i) {
        const double radius = randomSign(rng) * logUniform(rng, 0.01, 1e3);
        const SurfaceShape shape = SphereShape{1.0 / radius};
        const double r = 0.99 * std::abs(radius) * std::sqrt(uni(rng)), phi = 2 * M_PI * uni(rng);
        const Vec3 o{r * std::cos(phi), r * std::sin(phi), sag(shape, r * r)};
        const Vec3 d = randomDirection(rng, M_PI / 2);
        // Chord length from o: -2 (o - centre) . d, long double; the far end is a hit only on
        // the vertex hemisphere and ahead of the origin.
        const LD R = radius;
        const LD chord = -2 * (LD(o.x) * d.x + LD(o.y) * d.y + (LD(o.z) - R) * d.z);
        const LD zEnd = LD(o.z) + chord * d.z;
        const bool expectHit = chord > 0 && zEnd / R <= 1 - 1e-9;
        const bool expectMiss = chord < 0 || zEnd / R > 1 + 1e-9;
        const std::optional<ShapeHit> hit = intersectFirst(shape, {o, d}, 0.0, kInf, kInf, true);
        if (expectHit) {
            ASSERT_TRUE(hit) << shape << " from " << text(o) << " along " << text(d);
            ASSERT_LT(std::abs(hit->t - chord), 1e-12 * std::max(1.0, std::abs(radius)));
            worst.hit(refShape(shape), hit->point);
            ++hits;
        } else if (expectMiss) {
            ASSERT_FALSE(hit) << shape << " from " << text(o) << " along " << text(d) << " got "
                              << *hit;
            ++misses;
        }
    }
    EXPECT_GT(hits, 200);
    EXPECT_GT(misses, 200);
    // A plane cannot be met again.
    EXPECT_FALSE(intersectFirst(PlaneShape{}, {{1, 1, 0}, {0, 0, 1}}, 0.0, kInf, kInf, true));
    EXPECT_FALSE(intersectFirst(PlaneShape{}, {{1, 1, 0}, {0, 0.6, -0.8}}, 0.0, kInf, kInf, true));
}

TEST(SurfaceShape, WhisperingGalleryStaysOnTheSurface) {
    // A ray bouncing around the inside of a strongly curved hemisphere (R = 2 mm) in the
    // horizontal plane z = 1.3 (reflected off the horizontal part of the normal, so it stays
    // on the vertex hemisphere): every chord starts on the surface and ends on it again, 2000
    // times, and never collapses to the origin's own root.
    const double radius = 2.0;
    const SurfaceShape shape = SphereShape{1.0 / radius};
    const RefShape ref = refShape(shape);
    const double z0 = 1.3;
    const double r0 = std::sqrt(radius * radius - (radius - z0) * (radius - z0));
    Vec3 o{r0, 0.0, z0};
    Vec3 d = glm::normalize(Vec3(-0.3, 1.0, 0.0));
    Worst worst{"whispering gallery, 2000 bounces"};
    for (int i = 0; i < 2000; ++i) {
        const std::optional<ShapeHit> hit = intersectFirst(shape, {o, d}, 0.0, kInf, 2.0, true);
        ASSERT_TRUE(hit) << "bounce " << i << " from " << text(o) << " along " << text(d);
        const LD chord = -2 * (LD(o.x) * d.x + LD(o.y) * d.y);  // d is horizontal
        ASSERT_NEAR(hit->t, double(chord), 1e-12) << "bounce " << i;
        ASSERT_GT(hit->t, 0.5);
        worst.hit(ref, hit->point);
        ASSERT_LT(surfaceDistance(ref, hit->point), 1e-13);
        ASSERT_EQ(hit->point.z, z0);
        o = hit->point;
        const Vec3 nh = glm::normalize(Vec3(hit->normal.x, hit->normal.y, 0.0));
        d = glm::normalize(d - 2.0 * glm::dot(d, nh) * nh);
    }
}

TEST(SurfaceShape, RayStartingOnConicOrAsphereHitsItAgain) {
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    Worst worst{"conic/asphere chords from the surface"};
    int compared = 0;
    for (int i = 0; i < 300; ++i) {
        SurfaceShape shape;
        if (i % 3 == 0) {
            shape = ConicShape{randomSign(rng) * logUniform(rng, 0.05, 1.0),
                               std::uniform_real_distribution<double>(-4.0, 2.0)(rng)};
        } else {
            EvenAsphereShape a = randomAsphere(rng, 10.0, logUniform(rng, 0.5, 5.0));
            shape = a;
        }
        const RefShape ref = refShape(shape);
        const double rIn = std::min(0.8 * maxRadius(shape), 10.0);
        const double r = rIn * std::sqrt(uni(rng)), phi = 2 * M_PI * uni(rng);
        const Vec3 o{r * std::cos(phi), r * std::sin(phi), sag(shape, r * r)};
        const Vec3 d = randomDirection(rng, 1.4);
        const Ray ray{o, d};
        const double rMax = std::min(rIn / 0.8 * 0.99, 12.0);
        const std::optional<ShapeHit> hit = intersectFirst(shape, ray, 0.0, 100.0, rMax, true);
        // The oracle starts after the origin's own root: its first sample is 1e-6 mm along
        // the ray; rays whose next crossing is closer than 1e-3 mm are not compared.
        const std::optional<LD> expected = oracleFirst(ref, ray, 100, rMax, 20000, 1e-6L);
        if (hit) {
            ASSERT_GT(hit->t, 1e-6) << shape << " " << ray;  // never the origin itself
            worst.hit(ref, hit->point);
            ASSERT_LT(surfaceDistance(ref, hit->point), 1e-9);
        }
        if ((expected && *expected < 1e-3) || (hit && hit->t < 1e-3)) continue;
        ASSERT_EQ(bool(expected), bool(hit)) << shape << " " << ray;
        if (hit) {
            ASSERT_LT(std::abs(hit->t - *expected), 1e-9) << shape << " " << ray;
            worst.tError = std::max(worst.tError, std::abs(hit->t - *expected));
            ++compared;
        }
    }
    EXPECT_GT(compared, 60);
}

// Apertures and Ranges

TEST(SurfaceShape, HitExactlyOnApertureEdgeIsInside) {
    std::array<double, 10> a{};
    a[1] = 1e-5;
    for (const SurfaceShape& shape :
         {SurfaceShape{PlaneShape{}}, SurfaceShape{SphereShape{0.02}},
          SurfaceShape{ConicShape{-0.03, -2.0}}, makeShape(0.01, 0.0, a)}) {
        // Parallel to the axis the hit has r == rMax exactly.
        for (const Vec3& o : {Vec3(10, 0, -5), Vec3(0, -10, -5), Vec3(6, 8, -5)}) {
            const std::optional<ShapeHit> hit =
                intersectFirst(shape, {o, {0, 0, 1}}, 0.0, kInf, 10.0, false);
            ASSERT_TRUE(hit) << shape << " " << text(o);
            EXPECT_EQ(std::hypot(hit->point.x, hit->point.y), 10.0);
        }
        EXPECT_FALSE(intersectFirst(shape, {{10.000001, 0, -5}, {0, 0, 1}}, 0, kInf, 10.0, false))
            << shape;
        // Oblique rays aimed at rim points: the rounding of o + t d does not push them out.
        std::mt19937_64 rng(8);
        for (int i = 0; i < 200; ++i) {
            const double phi = 2 * M_PI * (i / 200.0);
            const Vec3 rim{10 * std::cos(phi), 10 * std::sin(phi), sag(shape, 100.0)};
            const Vec3 d = randomDirection(rng, 1.0);
            const Ray ray{rim - 37.0 * d, d};
            // tMin skips any other crossing well before the rim point.
            const std::optional<ShapeHit> hit = intersectFirst(shape, ray, 36.9, kInf, 10.0, false);
            ASSERT_TRUE(hit) << shape << " " << ray;
            EXPECT_NEAR(glm::length(hit->point - rim), 0.0, 1e-12);
        }
    }
    // tMax is inclusive, tMin exclusive.
    const Ray ray{{0, 0, -5}, {0, 0, 1}};
    EXPECT_TRUE(intersectFirst(PlaneShape{}, ray, 0.0, 5.0, kInf, false));
    EXPECT_FALSE(intersectFirst(PlaneShape{}, ray, 5.0, 10.0, kInf, false));
    EXPECT_FALSE(intersectFirst(PlaneShape{}, ray, 0.0, std::nextafter(5.0, 0.0), kInf, false));
    EXPECT_TRUE(intersectFirst(SphereShape{0.1}, ray, 0.0, 5.0, kInf, false));
    EXPECT_FALSE(intersectFirst(SphereShape{0.1}, ray, 5.0, 100.0, kInf, false));
}

TEST(SurfaceShape, FirstHitSkipsFarSheetAndRespectsRange) {
    // A ray inside a sphere going toward +z meets the far hemisphere (not part of the
    // surface) and nothing else; going -z it meets the vertex hemisphere.
    const SurfaceShape sphere = SphereShape{0.1};
    EXPECT_FALSE(intersectFirst(sphere, {{0, 0, 5}, {0, 0, 1}}, 0.0, kInf, kInf, false));
    const std::optional<ShapeHit> back =
        intersectFirst(sphere, {{0, 0, 5}, {0, 0, -1}}, 0.0, kInf, kInf, false);
    ASSERT_TRUE(back);
    EXPECT_DOUBLE_EQ(back->t, 5.0);
    EXPECT_TRUE(back->normal == Vec3(0, 0, 1));
    // Hyperboloid: the mirror sheet at z = -10 is skipped.
    const std::optional<ShapeHit> hyp =
        intersectFirst(ConicShape{0.1, -3.0}, {{0, 0, -100}, {0, 0, 1}}, 0.0, kInf, kInf, false);
    ASSERT_TRUE(hyp);
    EXPECT_NEAR(hyp->t, 100.0, 1e-13);
    // A wavy asphere, z = 0.02 r^2 - 2e-4 r^4, crossed four times by a ray along x at
    // z = 0.1 (r = 2.2976 and 9.7329 on each side). Each hit restarts from the surface.
    EvenAsphereShape wavy{0.0, 0.0, {}};
    wavy.coefficients[0] = 0.02;
    wavy.coefficients[1] = -2e-4;
    const Ray along{{-12, 0, 0.1}, {1, 0, 0}};
    const std::vector<LD> roots = bruteForceRoots(refShape(wavy), along, 0, 24, 24000);
    ASSERT_EQ(roots.size(), 4u);
    Ray ray = along;
    double tTotal = 0.0;
    bool onSurface = false;
    for (LD expected : roots) {
        const std::optional<ShapeHit> h = intersectFirst(wavy, ray, 0.0, kInf, kInf, onSurface);
        ASSERT_TRUE(h) << "expected " << double(expected);
        tTotal += h->t;
        EXPECT_NEAR(tTotal, double(expected), 1e-12);
        ray.origin = h->point;
        onSurface = true;
    }
    EXPECT_FALSE(intersectFirst(wavy, ray, 0.0, kInf, kInf, true));
    // With rMax = 9 only the two inner crossings count.
    const std::optional<ShapeHit> inner = intersectFirst(wavy, along, 0.0, kInf, 9.0, false);
    ASSERT_TRUE(inner);
    EXPECT_NEAR(inner->t, double(roots[1]), 1e-12);
}

// Work per ray is bounded, so these end (a hang fails the test by its timeout). What each
// costs is measured in bench/kernels_bench.cpp (BM_PathologicalAsphere), not asserted here.
TEST(SurfaceShape, PathologicalAspheresEndWithoutLooping) {
    const Ray ray{{0.3, 0.2, -10}, glm::normalize(Vec3(0.1, 0.05, 1.0))};
    EvenAsphereShape nan{0.01, 0.0, {}};
    nan.coefficients[2] = std::numeric_limits<double>::quiet_NaN();
    EXPECT_FALSE(intersectSequential(nan, ray));
    EXPECT_FALSE(intersectFirst(nan, ray, 0.0, kInf, kInf, false));
    // Huge coefficients and infinite ranges must still end (found or not).
    EvenAsphereShape wild{0.01, -1.0, {}};
    wild.coefficients = {1e3, -1e6, 1e9, -1e12, 1e15, -1e18, 1e21, -1e24, 1e27, -1e30};
    // Whatever they return must be a point of the surface (today both give up: no hit).
    const RefShape wildRef = refShape(SurfaceShape{wild});
    if (const std::optional<double> t = intersectSequential(wild, ray)) {
        EXPECT_LT(surfaceDistance(wildRef, ray.origin + *t * ray.direction), 1e-6) << *t;
    }
    if (const std::optional<ShapeHit> h = intersectFirst(wild, ray, -kInf, kInf, kInf, false)) {
        EXPECT_LT(surfaceDistance(wildRef, h->point), 1e-6) << h->t;
    }
    // A ray touching the quartic bowl z = 1e-3 r^4 at its vertex: a contact of order four,
    // with no sign change to bracket. The vertex is the only common point, so a hit must be
    // there; with f = 1e-3 (t - 5)^4, t is resolved to about 1e-3 mm.
    EvenAsphereShape bowl{0.0, 0.0, {}};
    bowl.coefficients[1] = 1e-3;
    const Ray touching{{-5, 0, 0}, {1, 0, 0}};
    if (const std::optional<double> t = intersectSequential(bowl, touching)) {
        EXPECT_NEAR(*t, 5.0, 1e-3);
    }
    if (const std::optional<ShapeHit> h = intersectFirst(bowl, touching, 0.0, kInf, kInf, false)) {
        EXPECT_NEAR(h->t, 5.0, 1e-3);
    }
}

TEST(SurfaceShape, PrintsItself) {
    std::ostringstream os;
    os << SurfaceShape{PlaneShape{}} << " " << SurfaceShape{SphereShape{0.5}} << " "
       << SurfaceShape{ConicShape{0.25, -1.0}} << " "
       << SurfaceShape{EvenAsphereShape{0.125, 2.0, {1e-3, 2e-6}}} << " "
       << ShapeHit{3.0, {1, 2, 3}, {0, 0, 1}};
    EXPECT_EQ(os.str(),
              "Plane{} Sphere{curvature 0.5 /mm} Conic{curvature 0.25 /mm, conic -1} "
              "EvenAsphere{curvature 0.125 /mm, conic 2, a [0.001, 2e-06, 0, 0, 0, 0, 0, 0, 0, "
              "0]} ShapeHit{t 3 mm, point (1, 2, 3), normal (0, 0, 1)}");
}

}  // namespace
}  // namespace veil
