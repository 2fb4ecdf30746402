// Mie scattering against independent truth: Bohren and Huffman's published example, the
// Rayleigh limit, extinction = scattering for real indices, the extinction paradox (Q_ext -> 2),
// and the amplitude functions integrated over the sphere against Q_sca and g.

#include "tracer/surfaces/mie.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "geometry/numerics.h"

namespace veil {
namespace {

// Integral over the sphere of (|S1|^2 + |S2|^2) / 2 (times mu^power) by Gauss-Legendre
// panels in theta (fine where large spheres diffract).
double sphereIntegral(double x, std::complex<double> m, int power) {
    std::vector<double> mu, w;
    const int panels = 4000;
    const double g[2] = {-0.5773502691896257, 0.5773502691896257};
    for (int k = 0; k < panels; ++k) {
        // theta = pi t^2: panels crowd toward the forward direction.
        for (double q : g) {
            const double t = (k + 0.5 + 0.5 * q) / panels;
            const double theta = kPi * t * t;
            mu.push_back(std::cos(theta));
            // dOmega = 2 pi sin(theta) dtheta, dtheta = 2 pi t dt, dt = 1 / panels / 2 per node
            w.push_back(2.0 * kPi * std::sin(theta) * 2.0 * kPi * t * 0.5 / panels);
        }
    }
    std::vector<double> intensity;
    mieScatter(x, m, mu, &intensity);
    double sum = 0.0;
    for (size_t k = 0; k < mu.size(); ++k) sum += w[k] * intensity[k] * std::pow(mu[k], power);
    return sum;
}

TEST(Mie, MatchesBohrenAndHuffmansExample) {
    // Bohren and Huffman, appendix A: a sphere of radius 0.525 um, index 1.55, in light of
    // 0.6328 um: Q_sca = Q_ext = 3.10543, Q_back = 2.92534.
    const MieEfficiencies e = mieScatter(2.0 * kPi * 0.525 / 0.6328, {1.55, 0.0});
    EXPECT_NEAR(e.qsca, 3.10543, 1e-5);
    EXPECT_NEAR(e.qext, 3.10543, 1e-5);
    EXPECT_NEAR(e.qback, 2.92534, 1e-5);
}

TEST(Mie, SmallSpheresScatterAsRayleigh) {
    for (const std::complex<double> m :
         {std::complex<double>(1.5, 0.0), {1.33, 0.01}, {2.0, 1.0}}) {
        const double x = 0.005;
        const MieEfficiencies e = mieScatter(x, m);
        const std::complex<double> a = (m * m - 1.0) / (m * m + 2.0);
        EXPECT_NEAR(e.qsca, 8.0 / 3.0 * std::pow(x, 4) * std::norm(a), 1e-3 * e.qsca) << m;
        EXPECT_NEAR(e.qabs(), 4.0 * x * a.imag(), 1e-3 * e.qabs() + 1e-15) << m;
        EXPECT_NEAR(e.asymmetry, 0.0, 1e-4) << m;
        // The dipole's angular pattern: (|S1|^2 + |S2|^2) / 2 proportional to 1 + mu^2.
        std::vector<double> intensity;
        mieScatter(x, m, {1.0, 0.5, 0.0, -0.7}, &intensity);
        for (size_t k = 1; k < 4; ++k) {
            const double mu = std::vector<double>{1.0, 0.5, 0.0, -0.7}[k];
            EXPECT_NEAR(intensity[k] / intensity[0], (1.0 + mu * mu) / 2.0, 1e-3) << m;
        }
    }
}

TEST(Mie, RealIndicesAbsorbNothing) {
    for (const double x : {0.3, 3.0, 30.0, 300.0, 3000.0}) {
        const MieEfficiencies e = mieScatter(x, {1.5, 0.0});
        EXPECT_NEAR(e.qext, e.qsca, 1e-9 * e.qext) << x;
    }
}

TEST(Mie, LargeSpheresRemoveTwiceTheirArea) {
    // The extinction paradox: Q_ext -> 2 as x grows, the excess falling as x^(-2/3).
    double previous = 1.0;
    for (const double x : {500.0, 4000.0, 32000.0}) {
        const MieEfficiencies e = mieScatter(x, {1.5, 0.01});
        const double excess = std::abs(e.qext - 2.0);
        EXPECT_LT(excess, 0.05) << x;
        EXPECT_LT(excess, previous) << x;
        previous = excess;
        // An absorbing sphere this large absorbs what enters it: about half of Q_ext.
        EXPECT_NEAR(e.qabs(), 1.0, 0.2) << x;
    }
}

TEST(Mie, AmplitudesIntegrateToTheCrossSections) {
    for (const double x : {0.5, 5.0, 50.0, 500.0}) {
        const std::complex<double> m(1.53, 0.008);
        const MieEfficiencies e = mieScatter(x, m);
        // sigma_sca = (1 / k^2) integral (|S1|^2 + |S2|^2) / 2 dOmega: pi x^2 Q_sca.
        const double total = sphereIntegral(x, m, 0);
        EXPECT_NEAR(total, kPi * x * x * e.qsca, 2e-4 * total) << x;
        const double first = sphereIntegral(x, m, 1);
        EXPECT_NEAR(first / total, e.asymmetry, 2e-4) << x;
    }
}

TEST(Mie, RefusesWhatItCannotCompute) {
    EXPECT_THROW(mieScatter(0.0, {1.5, 0.0}), std::invalid_argument);
    EXPECT_THROW(mieScatter(1.0, {-1.5, 0.0}), std::invalid_argument);
    EXPECT_THROW(mieScatter(1.0, {1.5, -0.1}), std::invalid_argument);
    EXPECT_THROW(mieScatter(1e6, {1.5, 0.0}), std::invalid_argument);
}

}  // namespace
}  // namespace veil
