// Forbes Q-polynomial aspheres against their definitions: the Qbfs polynomials against
// Forbes's published closed forms and their defining slope orthonormality, the Qcon ones
// against the Jacobi polynomials' orthogonality, and the sag veil traces against the
// defining formula of each surface, evaluated directly in long double.

#include "geometry/qtype.h"

#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>
#include <vector>

#include "geometry/surface_frames.h"

namespace veil {
namespace {

using LD = long double;
const LD kPi = 3.141592653589793238462643383279502884L;

LD horner(const std::vector<double>& c, LD x) {
    LD acc = 0;
    for (size_t i = c.size(); i-- > 0;) acc = acc * x + c[i];
    return acc;
}

// Forbes (2007), Opt. Express 15, 5218, the first four Q^bfs.
LD forbesQbfs(int m, LD x) {
    switch (m) {
        case 0:
            return 1;
        case 1:
            return (13 - 16 * x) / std::sqrt(LD(19));
        case 2:
            return std::sqrt(LD(2) / 95) * (29 - 4 * x * (25 - 19 * x));
        default:
            return std::sqrt(LD(2) / 2545) * (207 - 4 * x * (315 - x * (577 - 320 * x)));
    }
}

TEST(QType, QbfsAreForbesPolynomials) {
    for (int m = 0; m < 4; ++m)
        for (LD x = 0; x <= 1.0L; x += 0.0625L)
            EXPECT_NEAR(double(horner(qbfsPolynomial(m), x)), double(forbesQbfs(m, x)), 1e-13)
                << "m " << m << " x " << double(x);
}

// f_m(u) = u^2 (1 - u^2) Q_m(u^2): integral_0^1 f_m' f_n' du / sqrt(1 - u^2) = pi/2 delta_mn.
// With u = sin(t) the integrand is an even trigonometric polynomial in t over [0, pi/2],
// where the trapezoid rule is exact up to rounding.
TEST(QType, QbfsSlopesAreOrthonormal) {
    auto slope = [](int m, LD u) {
        const std::vector<double>& q = qbfsPolynomial(m);
        const LD x = u * u;
        LD dq = 0;  // Q'(x)
        for (size_t i = q.size(); i-- > 1;) dq = dq * x + i * LD(q[i]);
        // d/du [x (1 - x) Q(x)] = 2u [(1 - 2x) Q + x (1 - x) Q'].
        return 2 * u * ((1 - 2 * x) * horner(q, x) + x * (1 - x) * dq);
    };
    const int n = 400;
    for (int a = 0; a < kMaxQTerms; ++a)
        for (int b = 0; b <= a; ++b) {
            LD sum = 0;
            for (int i = 0; i <= n; ++i) {
                const LD t = kPi / 2 * i / n;
                const LD w = (i == 0 || i == n) ? 0.5L : 1.0L;
                sum += w * slope(a, std::sin(t)) * slope(b, std::sin(t));
            }
            const LD integral = sum * (kPi / 2) / n;
            // The double coefficients (up to ~1e4 for m = 8, summing to ~1) round at 1e-16
            // relative each: 1e-10 holds what rounding leaves.
            EXPECT_NEAR(double(integral), a == b ? double(kPi / 2) : 0.0, 1e-10)
                << "m " << a << " n " << b;
        }
}

// Q_m^con(x) = P_m^(0,4)(2x - 1): integral_0^1 Q_m Q_n x^4 dx = delta_mn / (2m + 5), and
// Q_m(1) = P_m(1) = 1 (Jacobi with alpha = 0).
TEST(QType, QconAreTheJacobiPolynomials) {
    EXPECT_EQ(qconPolynomial(0), (std::vector<double>{1.0}));
    EXPECT_EQ(qconPolynomial(1), (std::vector<double>{-5.0, 6.0}));
    for (int a = 0; a < kMaxQTerms; ++a) {
        EXPECT_NEAR(double(horner(qconPolynomial(a), 1.0L)), 1.0, 1e-12) << a;
        for (int b = 0; b <= a; ++b) {
            const std::vector<double>&p = qconPolynomial(a), &q = qconPolynomial(b);
            // The monomial sum cancels (coefficients up to ~1e5 for m = 8): the tolerance is
            // the rounding of the double coefficients, 1e-16 of the terms' magnitude.
            LD integral = 0, magnitude = 0;
            for (size_t i = 0; i < p.size(); ++i)
                for (size_t j = 0; j < q.size(); ++j) {
                    integral += LD(p[i]) * q[j] / (i + j + 5);
                    magnitude += std::abs(LD(p[i]) * q[j]) / (i + j + 5);
                }
            EXPECT_NEAR(double(integral), a == b ? 1.0 / (2 * a + 5) : 0.0,
                        1e-12 + 4e-16 * double(magnitude))
                << "m " << a << " n " << b;
        }
    }
}

// The sag veil traces (the departure turned into v^n terms) is the defining formula, on
// random surfaces of every term count, to 1e-12 of the departure's scale.
// M + 1 terms give powers v^0 .. v^(M + 2): M + 3 coefficients, the last one the asphere
// arrays hold (surfaceShape wrote one entry past them, a stack overflow AddressSanitizer
// found, while the departure had one trailing zero too many).
TEST(QType, DepartureHasExactlyItsDegreesCoefficients) {
    for (int count = 1; count <= kMaxQTerms; ++count) {
        const std::vector<double> terms(static_cast<size_t>(count), 0.01);
        EXPECT_EQ(qconDeparture(10.0, terms).size(), static_cast<size_t>(count + 2));
        EXPECT_EQ(qbfsDeparture(10.0, terms).size(), static_cast<size_t>(count + 2));
        EXPECT_NE(qconDeparture(10.0, terms).back(), 0.0);
        EXPECT_NE(qbfsDeparture(10.0, terms).back(), 0.0);
    }
}

TEST(QType, SagIsTheDefiningFormula) {
    std::mt19937_64 rng(29);
    std::uniform_real_distribution<double> uni(-1.0, 1.0);
    LD worst = 0;
    for (int trial = 0; trial < 200; ++trial) {
        const bool bfs = trial % 2 == 0;
        const int count = 1 + trial % kMaxQTerms;
        Surface s;
        s.curvature = uni(rng) / 40.0;
        s.conic = bfs ? 0.0 : 2.0 * uni(rng);
        QAsphere q;
        q.kind = bfs ? QAsphere::Kind::Bfs : QAsphere::Kind::Con;
        q.normRadiusMm = 5.0 + 20.0 * std::abs(uni(rng));
        for (int m = 0; m < count; ++m) q.terms.push_back(0.05 * uni(rng) / (m + 1));
        s.qAsphere = q;
        const SurfaceShape shape = surfaceShape(s);
        const LD c = s.curvature, k = s.conic;
        for (int i = 0; i <= 40; ++i) {
            const LD r = LD(q.normRadiusMm) * i / 40;
            const LD v = r * r, x = v / (LD(q.normRadiusMm) * q.normRadiusMm);
            const LD w2 = 1 - (bfs ? 1 : 1 + k) * c * c * v;
            if (w2 <= 0.05L) continue;  // stay off an ellipsoid's rim
            const LD base = c * v / (1 + std::sqrt(w2));
            LD sum = 0;
            for (int m = 0; m < count; ++m) {
                const LD qm = bfs && m < 4 ? forbesQbfs(m, x)
                              : bfs       ? horner(qbfsPolynomial(m), x)
                                          : horner(qconPolynomial(m), x);
                sum += LD(q.terms[m]) * qm;
            }
            const LD departure = bfs ? x * (1 - x) / std::sqrt(1 - c * c * v) * sum : x * x * sum;
            const LD err = std::abs(LD(sag(shape, double(v))) - (base + departure));
            worst = std::max(worst, err);
            ASSERT_LT(err, 1e-12L * (1 + std::abs(base))) << q << " r " << double(r);
        }
    }
    std::cout << "[ measured ] worst |sag - formula| " << double(worst) << " mm\n";
}

// A Qbfs surface is an even asphere with terms over w; a Qcon one has only even terms.
TEST(QType, ShapesTakeTheRightTerms) {
    Surface s;
    s.curvature = 1.0 / 50.0;
    s.qAsphere = QAsphere{QAsphere::Kind::Bfs, 10.0, {0.01, -0.002}};
    const SurfaceShape bfsShape = surfaceShape(s);
    const auto* bfs = std::get_if<EvenAsphereShape>(&bfsShape);
    ASSERT_NE(bfs, nullptr);
    EXPECT_NE(bfs->overW[0], 0.0);
    for (double a : bfs->coefficients) EXPECT_EQ(a, 0.0);
    s.qAsphere->kind = QAsphere::Kind::Con;
    const auto con = std::get<EvenAsphereShape>(surfaceShape(s));
    for (double e : con.overW) EXPECT_EQ(e, 0.0);
    EXPECT_EQ(con.coefficients[0], 0.0);  // Qcon starts at u^4: no r^2 term
    EXPECT_NE(con.coefficients[1], 0.0);
}

}  // namespace
}  // namespace veil
