// K-correlation roughness scatter against independent truth: the PSD's RMS roughness by
// quadrature, the Rayleigh-Rice BRDF written from angles, its smooth-surface TIS
// (4 pi sigma cos(i) / lambda)^2 and the scalar transmitted TIS, the TIS table against direct
// quadrature, brute-force TIS over the hemisphere, chi-square of sampled directions, and
// reciprocity.

#include "tracer/surfaces/k_correlation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "tests/tracer/surfaces/scatter_test_support.h"
#include "tracer/runtime/rng.h"
#include "tracer/sequential/sequential_trace.h"
#include "tracer/surfaces/optical_property.h"

namespace veil {
namespace {

using namespace scatter_test;

KCorrelationParams roughness(double sigmaNm, double bUm, double c, double reflectance,
                             bool transmission) {
    KCorrelationParams p;
    p.aNm2Um2 = kCorrelationA(sigmaNm, bUm, c);
    p.bUm = bUm;
    p.c = c;
    p.reflectance = reflectance;
    p.transmission = transmission;
    return p;
}

OpticalProperty rough(const KCorrelationParams& p) {
    return OpticalProperty("rough", AbsorberSpecular{}, KCorrelationScatter(p));
}

// The PSD as its authors write it.
double abcPsd(double a, double b, double c, double f) {
    return a / std::pow(1.0 + (b * f) * (b * f), c / 2.0);
}

TEST(KCorrelationScatter, RoughnessIsTheIntegralOfThePsd) {
    for (const auto& [sigma, b, c] :
         {std::tuple{1.0, 10.0, 3.0}, std::tuple{5.0, 2.0, 2.5}, std::tuple{0.3, 100.0, 4.0}}) {
        const KCorrelationScatter k(roughness(sigma, b, c, 1.0, false));
        const double a = k.params().aNm2Um2;
        EXPECT_NEAR(k.psd(0.7), abcPsd(a, b, c, 0.7), 1e-12 * a);
        EXPECT_NEAR(k.bandSigmaNm(0.0, INFINITY), sigma, 1e-12 * sigma);
        // 2 pi integral f PSD df over [f0, f1] by the trapezoid rule in ln f.
        const double f0 = 0.01 / b, f1 = 2.0;
        const int n = 200000;
        double sum = 0.0;
        for (int i = 0; i <= n; ++i) {
            const double f = f0 * std::pow(f1 / f0, double(i) / n);
            const double w = (i == 0 || i == n) ? 0.5 : 1.0;
            sum += w * 2.0 * kPi * f * f * abcPsd(a, b, c, f);  // f df = f^2 d(ln f)
        }
        sum *= std::log(f1 / f0) / n;
        EXPECT_NEAR(k.bandSigmaNm(f0, f1), std::sqrt(sum), 1e-6 * std::sqrt(sum))
            << sigma << " " << b << " " << c;
    }
    EXPECT_THROW(kCorrelationA(1.0, 10.0, 2.0), std::invalid_argument);
    EXPECT_THROW(KCorrelationScatter(roughness(1.0, 10.0, 3.0, 0.0, false)), std::invalid_argument);
}

TEST(KCorrelationScatter, BrdfIsRayleighRiceWrittenFromAngles) {
    // BRDF = 16 pi^2 / lambda^4 cos(i) cos(s) R PSD(f), f = |sin(s) (cos phi, sin phi) -
    // sin(i) (1, 0)| / lambda, phi the scatter azimuth from the plane of incidence.
    const KCorrelationParams p = roughness(2.0, 5.0, 3.0, 0.9, false);
    const OpticalProperty prop = rough(p);
    const double lambdaNm = 633.0, lambda = lambdaNm * 1e-3;
    for (double incidence : {0.0, 30.0, 70.0}) {
        SurfaceContext c = contextAt(incidence);
        c.wavelengthNm = lambdaNm;
        const Vec3 e1 = perpendicular(kNormal), e2 = glm::cross(kNormal, e1);
        // contextAt tilts the ray toward +e1: the mirror direction leans to +e1.
        for (double s : {0.0, 10.0, 45.0, 80.0})
            for (double phi : {0.0, 60.0, 180.0}) {
                const double ts = deg(s), ph = deg(phi), ti = deg(incidence);
                const Vec3 out =
                    std::cos(ts) * kNormal + std::sin(ts) * (std::cos(ph) * e1 + std::sin(ph) * e2);
                const double fx = std::sin(ts) * std::cos(ph) - std::sin(ti);
                const double fy = std::sin(ts) * std::sin(ph);
                const double f = std::hypot(fx, fy) / lambda;
                const double expected = 16.0 * kPi * kPi / std::pow(lambda, 4) * std::cos(ti) *
                                        std::cos(ts) * 0.9 * abcPsd(p.aNm2Um2 * 1e-6, 5.0, 3.0, f);
                EXPECT_NEAR(prop.bsdf(c, out), expected, 1e-9 * expected)
                    << incidence << " " << s << " " << phi;
            }
    }
}

TEST(KCorrelationScatter, SmoothSurfaceTisIsTheRayleighRiceTotal) {
    // B >> lambda and C = 4: the PSD sits at frequencies far below 1 / lambda, and the
    // reflected TIS is R (4 pi sigma cos(i) / lambda)^2, the transmitted one
    // (2 pi sigma (n1 cos(i) - n2 cos(t)) / lambda)^2, to O(lambda / B).
    const double sigma = 1.5, lambdaNm = 550.0, lambda = 0.55;
    const KCorrelationParams p = roughness(sigma * 1e-3 * 1e3, 200.0, 4.0, 1.0, true);
    const OpticalProperty prop = rough(p);
    for (double incidence : {0.0, 20.0, 45.0, 70.0}) {
        SurfaceContext c = contextAt(incidence, 1.0, 1.5);
        c.wavelengthNm = lambdaNm;
        const Channels ch = prop.channels(c);
        const double ci = std::cos(deg(incidence));
        const double rr = std::pow(4.0 * kPi * sigma * 1e-3 * ci / lambda, 2);
        EXPECT_NEAR(ch.scatterReflect, rr, 5e-3 * rr) << incidence;
        const double ct = std::sqrt(1.0 - std::pow(std::sin(deg(incidence)) / 1.5, 2));
        const double tt = std::pow(2.0 * kPi * sigma * 1e-3 * (ci - 1.5 * ct) / lambda, 2);
        EXPECT_NEAR(ch.scatterTransmit, tt, 5e-3 * tt) << incidence;
        std::cout << "[ TIS      ] " << incidence << " deg: R " << ch.scatterReflect
                  << " (Rayleigh-Rice " << rr << "), T " << ch.scatterTransmit << " (" << tt
                  << ")\n";
    }
    // A short correlation length puts much of the roughness beyond 1 / lambda, where it
    // scatters nothing: the TIS falls below the formula with the whole sigma, toward the
    // formula with the band-limited sigma at normal incidence.
    const KCorrelationParams wide = roughness(1.5, 0.5, 3.0, 1.0, false);
    const OpticalProperty wideProp = rough(wide);
    SurfaceContext c = contextAt(0.0);
    c.wavelengthNm = lambdaNm;
    const double whole = std::pow(4.0 * kPi * 1.5e-3 / lambda, 2);
    const double band = std::pow(
        4.0 * kPi * KCorrelationScatter(wide).bandSigmaNm(0.0, 1.0 / lambda) * 1e-3 / lambda, 2);
    const double tis = wideProp.channels(c).scatterReflect;
    EXPECT_LT(tis, 0.8 * whole);
    EXPECT_LT(tis, band);  // cos(s) < 1 away from the specular direction
    EXPECT_GT(tis, 0.3 * band);
}

TEST(KCorrelationScatter, TisTableMatchesDirectQuadrature) {
    for (const KCorrelationParams& p :
         {roughness(1.0, 20.0, 3.0, 0.04, true), roughness(3.0, 1.0, 2.4, 0.9, true),
          roughness(0.5, 300.0, 5.0, 1.0, true)}) {
        const KCorrelationScatter k(p);
        for (double nm : {355.0, 550.0, 1064.0, 10600.0})
            for (double theta : {0.0, 5.0, 33.0, 60.0, 80.0, 88.0, 89.7, 89.99}) {
                const double ci = std::cos(deg(theta));
                for (double n1 : {1.0, 1.7}) {
                    const KcLobe r = k.reflectLobe(nm, n1, ci);
                    EXPECT_NEAR(k.tis(r), k.tisExact(r), 1e-4 * k.tisExact(r))
                        << p << " " << nm << " nm " << theta << " deg n1 " << n1;
                }
                const double ct = std::sqrt(1.0 - std::pow(std::sin(deg(theta)) / 1.5, 2));
                const KcLobe t = k.transmitLobe(nm, 1.0, 1.5, ci, ct);
                EXPECT_NEAR(k.tis(t), k.tisExact(t), 1e-4 * k.tisExact(t))
                    << p << " " << nm << " nm " << theta << " deg BTDF";
            }
    }
}

// Sampled directions of one channel against bin probabilities of the model's formula
// written here (BSDF per unit beta area), and the channel fraction against their total.
void kcChi2(const char* what, const KCorrelationParams& p, double incidenceDeg, double n2,
            bool transmit, const std::vector<double>& rEdges, uint64_t seed) {
    const OpticalProperty prop = rough(p);
    SurfaceContext c = contextAt(incidenceDeg, 1.0, n2);
    c.wavelengthNm = 500.0;
    const double lambda = 0.5;
    const double ci = c.cosIncidence();
    const Vec2 beta0 = projectOnSurface(c.direction) * (transmit ? 1.0 / n2 : 1.0);
    const double ct = std::sqrt(1.0 - glm::dot(beta0, beta0));
    const double a = p.aNm2Um2 * 1e-6;
    auto model = [&](const Vec2& beta, double r) {
        const double cs = std::sqrt(std::max(0.0, 1.0 - glm::dot(beta, beta)));
        if (!transmit)
            return 16.0 * kPi * kPi / std::pow(lambda, 4) * ci * cs * p.reflectance *
                   abcPsd(a, p.bUm, p.c, r / lambda);
        const double d = ci - n2 * ct;
        return 4.0 * kPi * kPi * n2 * n2 * d * d / std::pow(lambda, 4) *
               abcPsd(a, p.bUm, p.c, n2 * r / lambda);
    };
    channelChi2(what, prop, c, transmit, beta0, model, rEdges, seed);
}

TEST(KCorrelationScatter, SamplerPassesChiSquareAgainstTheModel) {
    const std::vector<double> edges = {0,    0.005, 0.01, 0.02, 0.04, 0.08,
                                       0.16, 0.32,  0.64, 1.0,  2.0};
    const KCorrelationParams polished = roughness(1.0, 20.0, 3.0, 0.9, true);
    kcChi2("K-correlation BRDF normal incidence", polished, 0.0, 1.5, false, edges, 701);
    kcChi2("K-correlation BRDF 60 deg", polished, 60.0, 1.5, false, edges, 702);
    kcChi2("K-correlation BRDF 80 deg", polished, 80.0, 1.5, false, edges, 703);
    kcChi2("K-correlation BTDF 30 deg", polished, 30.0, 1.5, true, edges, 704);
    // A wide lobe (B near lambda), where cos(s) shapes the BRDF across the hemisphere.
    const KCorrelationParams machined = roughness(20.0, 0.8, 2.5, 0.6, false);
    kcChi2("K-correlation wide BRDF 45 deg", machined, 45.0, 1.0, false,
           {0, 0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0, 1.3, 2.0}, 705);
}

TEST(KCorrelationScatter, BrdfIsReciprocal) {
    const OpticalProperty p = rough(roughness(4.0, 3.0, 2.8, 0.8, false));
    CounterRng rng(9, 9);
    const Vec3 e1 = perpendicular(kNormal), e2 = glm::cross(kNormal, e1);
    auto hemisphere = [&](double u1, double u2) {
        const double ct = std::max(1e-3, u1), st = std::sqrt(1 - ct * ct);
        return ct * kNormal + st * (std::cos(2 * kPi * u2) * e1 + std::sin(2 * kPi * u2) * e2);
    };
    for (int i = 0; i < 100; ++i) {
        const Vec3 in = -hemisphere(rng.uniform(), rng.uniform());
        const Vec3 out = hemisphere(rng.uniform(), rng.uniform());
        SurfaceContext a;
        a.normal = kNormal;
        a.direction = in;
        a.wavelengthNm = 800.0;
        SurfaceContext b = a;
        b.direction = -out;
        EXPECT_NEAR(p.bsdf(a, out), p.bsdf(b, -in), 1e-12 * p.bsdf(a, out));
    }
}

TEST(KCorrelationScatter, OpaqueAndTotalInternalReflectionTransmitNothing) {
    const OpticalProperty p = rough(roughness(2.0, 10.0, 3.0, 0.04, true));
    SurfaceContext opaque = contextAt(20.0, 1.0, 1.0, true);
    EXPECT_EQ(p.channels(opaque).scatterTransmit, 0.0);
    EXPECT_GT(p.channels(opaque).scatterReflect, 0.0);
    EXPECT_EQ(p.channels(contextAt(50.0, 1.6, 1.0)).scatterTransmit, 0.0);
    EXPECT_EQ(p.sampleScatter(contextAt(50.0, 1.6, 1.0), true, 0.3, 0.4).pdf, 0.0);
}

}  // namespace
}  // namespace veil
