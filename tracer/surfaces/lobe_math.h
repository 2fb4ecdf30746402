#pragma once
// Numerical pieces the scatter lobes share (tracer-internal): Gauss-Legendre rules, an
// integral with square-root behaviour at its ends, the closed-form radial distribution of
// the power lobe 1 / (B + r^2)^p and the fraction of a circle that lies in the unit disk.
//
// Lobes live in direction-cosine space: beta, the projection of a direction on the surface
// plane, fills the unit disk; beta0 is the specular direction's projection and
// r = |beta - beta0|.

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>

#include "geometry/numerics.h"

namespace veil::lobe {

// Gauss-Legendre nodes and weights on [-1, 1] (Newton on the Legendre polynomial).
template <int N>
struct GaussLegendre {
    std::array<double, N> x{}, w{};
    GaussLegendre() {
        for (int i = 0; i < (N + 1) / 2; ++i) {
            double z = std::cos(std::numbers::pi * (i + 0.75) / (N + 0.5));
            double dp = 1.0;
            for (int it = 0; it < 100; ++it) {
                double p0 = 1.0, p1 = z;
                for (int k = 2; k <= N; ++k) {
                    const double p2 = ((2.0 * k - 1.0) * z * p1 - (k - 1.0) * p0) / k;
                    p0 = p1;
                    p1 = p2;
                }
                dp = N * (z * p1 - p0) / (z * z - 1.0);
                const double dz = p1 / dp;
                z -= dz;
                if (std::abs(dz) < 1e-16) break;
            }
            x[i] = -z;
            x[N - 1 - i] = z;
            w[i] = w[N - 1 - i] = 2.0 / ((1.0 - z * z) * dp * dp);
        }
    }
};

template <int N>
const GaussLegendre<N>& gauss() {
    static const GaussLegendre<N> g;
    return g;
}

// Integral over [a, b] of a function with square-root behaviour at both ends (a lobe's part
// inside the unit disk): the substitution x = a + (b - a)(1 - cos t) / 2 makes it smooth.
template <int N = 64, class F>
double integrateEndpointSqrt(double a, double b, F&& f) {
    if (!(b > a)) return 0.0;
    const auto& g = gauss<N>();
    double sum = 0.0;
    for (int i = 0; i < N; ++i) {
        const double t = 0.5 * kPi * (g.x[i] + 1.0);
        sum += g.w[i] * f(a + 0.5 * (b - a) * (1.0 - std::cos(t))) * std::sin(t);
    }
    return sum * 0.5 * kPi * 0.5 * (b - a);
}

// Integral of r / (B + r^2)^p from 0 to r (B > 0, p >= 0), in closed form, written to keep
// its precision near p = 1 and for r^2 << B.
inline double powerLobeRadialCdf(double r, double b, double p) {
    const double l = std::log1p(r * r / b);
    if (p == 1.0) return 0.5 * l;
    // ((B + r^2)^q - B^q) / (2 q), q = 1 - p.
    const double q = 1.0 - p;
    return std::pow(b, q) * (q * l == 0.0 ? l : std::expm1(q * l) / q) * 0.5;
}

// The r at which powerLobeRadialCdf reaches c (c >= 0, below the lobe's total if p > 1).
inline double inversePowerLobeRadialCdf(double c, double b, double p) {
    if (p == 1.0) return std::sqrt(b * std::expm1(2.0 * c));
    const double q = 1.0 - p;
    const double x = 2.0 * q * c / std::pow(b, q);
    const double l = x == 0.0 ? 2.0 * c / std::pow(b, q) : std::log1p(x) / q;
    return std::sqrt(b * std::expm1(l));
}

// Fraction of a circle of radius r about a point at distance b0 from the centre of the unit
// disk that lies inside the disk.
inline double circleFractionInDisk(double r, double b0) {
    if (r <= 1.0 - b0) return 1.0;
    if (r >= 1.0 + b0) return 0.0;
    const double c = (r * r + b0 * b0 - 1.0) / (2.0 * r * b0);
    return std::acos(std::clamp(c, -1.0, 1.0)) / std::numbers::pi;
}

}  // namespace veil::lobe
