// Fresnel coefficients against the textbook angle forms (Born & Wolf 1.5), Brewster's angle,
// total internal reflection, and the thin-film layer against an independent
// characteristic-matrix computation (Macleod, Thin-Film Optical Filters, ch. 2).

#include "tracer/surfaces/fresnel.h"

#include <gtest/gtest.h>

#include <cmath>
#include <complex>
#include <numbers>
#include <sstream>
#include <tuple>

#include "geometry/numerics.h"

namespace veil {
namespace {

double deg(double d) { return d * kPi / 180.0; }

// The angle forms: Rs = sin^2(i - t) / sin^2(i + t), Rp = tan^2(i - t) / tan^2(i + t),
// Ts = sin 2i sin 2t / sin^2(i + t), Tp = Ts / cos^2(i - t).
struct AngleForms {
    double rs, rp, ts, tp;
};
AngleForms angleForms(double n1, double n2, double i) {
    const double t = std::asin(n1 / n2 * std::sin(i));
    const double sp = std::sin(i + t), sm = std::sin(i - t);
    AngleForms f;
    f.rs = sm * sm / (sp * sp);
    f.rp = std::pow(std::tan(i - t) / std::tan(i + t), 2);
    f.ts = std::sin(2 * i) * std::sin(2 * t) / (sp * sp);
    f.tp = f.ts / std::pow(std::cos(i - t), 2);
    return f;
}

// Fresnel Bare Interface

TEST(Fresnel, NormalIncidenceIsExact) {
    for (auto [n1, n2] : {std::pair{1.0, 1.5}, {1.5, 1.0}, {1.0, 4.0}, {1.7, 1.52}}) {
        const FresnelTerms f = fresnelDielectric(n1, n2, 1.0);
        const double r = std::pow((n1 - n2) / (n1 + n2), 2);
        EXPECT_NEAR(f.rs, r, 1e-16);
        EXPECT_NEAR(f.rp, r, 1e-16);
        EXPECT_NEAR(f.reflectance(), r, 1e-16);
        EXPECT_NEAR(f.transmittance(), 4 * n1 * n2 / std::pow(n1 + n2, 2), 1e-15);
        EXPECT_FALSE(f.tir);
    }
}

TEST(Fresnel, MatchesAngleFormsAtSeveralAngles) {
    for (auto [n1, n2] : {std::pair{1.0, 1.5168}, {1.5168, 1.0}, {1.0, 2.4}, {1.62, 1.52}}) {
        for (double a : {5.0, 20.0, 33.0, 45.0, 60.0, 75.0, 85.0, 89.0}) {
            if (n1 * std::sin(deg(a)) >= n2) continue;
            const AngleForms e = angleForms(n1, n2, deg(a));
            const FresnelTerms f = fresnelDielectric(n1, n2, std::cos(deg(a)));
            SCOPED_TRACE(testing::Message() << n1 << " -> " << n2 << " at " << a << " deg");
            EXPECT_NEAR(f.rs, e.rs, 1e-13);
            EXPECT_NEAR(f.rp, e.rp, 1e-13);
            EXPECT_NEAR(f.ts, e.ts, 1e-13);
            EXPECT_NEAR(f.tp, e.tp, 1e-13);
            EXPECT_NEAR(fresnelReflectance(n1, n2, std::cos(deg(a))), 0.5 * (e.rs + e.rp), 1e-13);
        }
    }
}

TEST(Fresnel, ReflectancePlusTransmittanceIsOne) {
    for (auto [n1, n2] : {std::pair{1.0, 1.5}, {1.5, 1.0}, {1.0, 3.5}, {1.33, 1.0}}) {
        for (int k = 0; k <= 1000; ++k) {
            const double c = k / 1000.0;
            const FresnelTerms f = fresnelDielectric(n1, n2, c);
            EXPECT_NEAR(f.rs + f.ts, 1.0, 2e-15) << n1 << " " << n2 << " cos " << c;
            EXPECT_NEAR(f.rp + f.tp, 1.0, 2e-15) << n1 << " " << n2 << " cos " << c;
        }
    }
}

TEST(Fresnel, BrewsterAngleHasNoPReflection) {
    for (auto [n1, n2] : {std::pair{1.0, 1.5}, {1.5, 1.0}, {1.0, 1.8}}) {
        const double brewster = std::atan(n2 / n1);
        const FresnelTerms f = fresnelDielectric(n1, n2, std::cos(brewster));
        EXPECT_LT(f.rp, 1e-30) << n1 << " -> " << n2;
        EXPECT_NEAR(f.reflectance(), 0.5 * f.rs, 1e-16);
        EXPECT_NEAR(f.rs, angleForms(n1, n2, brewster).rs, 1e-14);
        // Rp is a minimum there: larger on both sides.
        EXPECT_GT(fresnelDielectric(n1, n2, std::cos(brewster - 0.01)).rp, 1e-6);
        EXPECT_GT(fresnelDielectric(n1, n2, std::cos(brewster + 0.01)).rp, 1e-6);
    }
}

TEST(Fresnel, TotalInternalReflectionBeyondTheCriticalAngle) {
    const double n1 = 1.5168, n2 = 1.0;
    const double critical = std::asin(n2 / n1);
    for (double extra : {1e-9, 1e-4, 0.1, 0.5, 0.8}) {
        const double c = std::cos(critical + extra);
        const FresnelTerms f = fresnelDielectric(n1, n2, c);
        EXPECT_TRUE(f.tir);
        EXPECT_TRUE(totalInternalReflection(n1, n2, c));
        EXPECT_EQ(f.rs, 1.0);
        EXPECT_EQ(f.rp, 1.0);
        EXPECT_EQ(f.transmittance(), 0.0);
    }
    // Continuity: 1 - R vanishes like the square root of the distance to the critical angle.
    double previous = 1.0;
    for (double delta : {1e-2, 1e-4, 1e-6, 1e-8, 1e-10}) {
        const FresnelTerms f = fresnelDielectric(n1, n2, std::cos(critical - delta));
        EXPECT_FALSE(f.tir);
        const double gap = 1.0 - f.reflectance();
        EXPECT_LT(gap, 10.0 * std::sqrt(delta)) << delta;
        EXPECT_LT(gap, previous);
        previous = gap;
    }
    // From the other side no TIR.
    EXPECT_FALSE(fresnelDielectric(n2, n1, 0.0).tir);
    EXPECT_EQ(fresnelDielectric(n2, n1, 0.0).reflectance(), 1.0);  // grazing
}

TEST(Fresnel, StokesReciprocityBetweenTheTwoSides) {
    // R from medium 1 at angle i equals R from medium 2 at the refraction angle t.
    const double n1 = 1.0, n2 = 1.6;
    for (double a : {10.0, 40.0, 70.0}) {
        const double t = std::asin(n1 / n2 * std::sin(deg(a)));
        const FresnelTerms f12 = fresnelDielectric(n1, n2, std::cos(deg(a)));
        const FresnelTerms f21 = fresnelDielectric(n2, n1, std::cos(t));
        EXPECT_NEAR(f12.rs, f21.rs, 1e-14);
        EXPECT_NEAR(f12.rp, f21.rp, 1e-14);
    }
}

// Fresnel Thin Film

// Macleod's characteristic matrix of one layer on a substrate, for one polarisation: tilted
// admittances eta = n cos (s) or n / cos (p), phase delta = 2 pi n d cos / lambda,
// [B C] = [[cos d, i sin d / eta], [i eta sin d, cos d]] [1 eta_sub],
// r = (eta0 B - C) / (eta0 B + C), T = 4 eta0 Re(eta_sub) / |eta0 B + C|^2.
// Cosines are the complex roots with Im <= 0 (Macleod's convention, the other one from the
// implementation's).
struct MatrixResult {
    double r, t;
};
MatrixResult characteristicMatrix(double n0, double n1, double d, double n2, double cos0,
                                  double lambda, bool p) {
    using C = std::complex<double>;
    const double s0 = std::sqrt(1 - cos0 * cos0);
    auto cosIn = [&](double n) {
        C c = std::sqrt(C(1.0 - std::pow(n0 * s0 / n, 2), 0.0));
        return c.imag() > 0 ? std::conj(c) : c;
    };
    const C c1 = cosIn(n1), c2 = cosIn(n2);
    auto eta = [&](double n, C c) { return p ? C(n) / c : C(n) * c; };
    const C eta0 = eta(n0, C(cos0)), eta1 = eta(n1, c1), eta2 = eta(n2, c2);
    const C delta = 2 * kPi * n1 * d * c1 / lambda;
    const C i(0, 1);
    const C b = std::cos(delta) + i * std::sin(delta) / eta1 * eta2;
    const C cc = i * eta1 * std::sin(delta) + std::cos(delta) * eta2;
    const C den = eta0 * b + cc;
    return {std::norm((eta0 * b - cc) / den), 4.0 * eta0.real() * eta2.real() / std::norm(den)};
}

TEST(ThinFilm, QuarterWaveAtDesignAndNormalIncidenceMatchesClosedForm) {
    for (auto [n1, nc, n2] :
         {std::tuple{1.0, 1.38, 1.52}, {1.52, 1.38, 1.0}, {1.0, 1.38, 1.9}, {1.0, 2.1, 1.5}}) {
        const FresnelTerms f = quarterWaveCoating(n1, nc, 550.0, n2, 1.0, 550.0);
        const double r = std::pow((n1 * n2 - nc * nc) / (n1 * n2 + nc * nc), 2);
        EXPECT_NEAR(f.rs, r, 1e-15);
        EXPECT_NEAR(f.rp, r, 1e-15);
        EXPECT_NEAR(f.reflectance() + f.transmittance(), 1.0, 1e-15);
    }
    // The ideal index sqrt(n1 n2) cancels the reflection.
    EXPECT_LT(quarterWaveCoating(1.0, std::sqrt(1.52), 550.0, 1.52, 1.0, 550.0).reflectance(),
              1e-30);
}

TEST(ThinFilm, HalfWaveLayerIsAbsentee) {
    // At half the design wavelength the layer is a half wave: at normal incidence the
    // interface reflects as if bare.
    const FresnelTerms f = quarterWaveCoating(1.0, 1.38, 600.0, 1.52, 1.0, 300.0);
    EXPECT_NEAR(f.reflectance(), fresnelReflectance(1.0, 1.52, 1.0), 1e-15);
    // A layer of zero thickness is no layer at any angle.
    for (double c : {1.0, 0.7, 0.2}) {
        const FresnelTerms g = thinFilm(1.0, 1.38, 0.0, 1.52, c, 550.0);
        const FresnelTerms b = fresnelDielectric(1.0, 1.52, c);
        EXPECT_NEAR(g.rs, b.rs, 1e-15);
        EXPECT_NEAR(g.rp, b.rp, 1e-15);
    }
}

TEST(ThinFilm, MatchesCharacteristicMatrixAtAnyAngleAndWavelength) {
    struct Case {
        double n0, nc, n2;
    };
    // Air to glass, glass to air (with TIR), and glass to denser glass through a layer that
    // is evanescent beyond 59.6 degrees (frustrated total reflection).
    for (const Case k : {Case{1.0, 1.38, 1.52}, Case{1.52, 1.38, 1.0}, Case{1.6, 1.38, 1.7}}) {
        const double d = 550.0 / (4.0 * k.nc);
        for (double a = 0.0; a < 90.0; a += 2.5) {
            for (double lambda : {400.0, 486.1, 550.0, 656.3, 1064.0}) {
                const double c = std::cos(deg(a));
                const FresnelTerms f = quarterWaveCoating(k.n0, k.nc, 550.0, k.n2, c, lambda);
                const MatrixResult s = characteristicMatrix(k.n0, k.nc, d, k.n2, c, lambda, false);
                const MatrixResult p = characteristicMatrix(k.n0, k.nc, d, k.n2, c, lambda, true);
                SCOPED_TRACE(testing::Message() << k.n0 << "|" << k.nc << "|" << k.n2 << " at " << a
                                                << " deg, " << lambda << " nm");
                EXPECT_NEAR(f.rs, s.r, 1e-12);
                EXPECT_NEAR(f.rp, p.r, 1e-12);
                EXPECT_NEAR(f.ts, s.t, 1e-12);
                EXPECT_NEAR(f.tp, p.t, 1e-12);
                EXPECT_NEAR(f.rs + f.ts, 1.0, 1e-13);
                EXPECT_NEAR(f.rp + f.tp, 1.0, 1e-13);
            }
        }
    }
}

TEST(ThinFilm, TotalInternalReflectionStillReflectsEverything) {
    const double critical = std::asin(1.0 / 1.52);
    const FresnelTerms f =
        quarterWaveCoating(1.52, 1.38, 550.0, 1.0, std::cos(critical + 0.05), 550.0);
    EXPECT_TRUE(f.tir);
    EXPECT_EQ(f.reflectance(), 1.0);
    // Just inside the critical angle the coating transmits, continuously approaching R = 1.
    const FresnelTerms g =
        quarterWaveCoating(1.52, 1.38, 550.0, 1.0, std::cos(critical - 1e-8), 550.0);
    EXPECT_FALSE(g.tir);
    EXPECT_GT(g.reflectance(), 0.99);
}

TEST(ThinFilm, PrintsItself) {
    std::ostringstream os;
    os << fresnelDielectric(1.5, 1.0, 0.1);
    EXPECT_NE(os.str().find("TIR"), std::string::npos);
}

}  // namespace
}  // namespace veil
