#pragma once
// Helpers for the scatter model tests: a tilted test surface, chi-square tests of sampled
// directions and brute-force bin probabilities of a lobe over the unit disk of direction
// cosines.
//
// Chi-square thresholds are the 1 - 1e-6 quantile for the degrees of freedom (Wilson-Hilferty);
// with fixed CounterRng seeds the tests are deterministic, and a correct sampler would fail
// one with probability 1e-6 per seed.

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <iostream>
#include <numbers>
#include <vector>

#include "geometry/numerics.h"
#include "tracer/runtime/rng.h"
#include "tracer/surfaces/optical_property.h"

namespace veil::scatter_test {

inline double deg(double d) { return d * kPi / 180.0; }

// A tilted normal so that no test leans on z being special.
inline const Vec3 kNormal = glm::normalize(Vec3(0.3, -0.5, 0.8));

// Any unit vector perpendicular to n.
inline Vec3 perpendicular(const Vec3& n) {
    const Vec3 helper = std::abs(n.x) < 0.6 ? Vec3(1, 0, 0) : Vec3(0, 1, 0);
    return glm::normalize(glm::cross(n, helper));
}

inline SurfaceContext contextAt(double incidenceDeg, double n1 = 1.0, double n2 = 1.0,
                                bool opaque = false) {
    SurfaceContext c;
    c.normal = kNormal;
    const Vec3 e = perpendicular(kNormal);
    c.direction =
        glm::normalize(-std::cos(deg(incidenceDeg)) * kNormal + std::sin(deg(incidenceDeg)) * e);
    c.n1 = n1;
    c.n2 = n2;
    c.opaque = opaque;
    return c;
}

// Chi-Square Helpers

// Upper 1e-6 quantile of chi-square with k degrees of freedom (Wilson-Hilferty).
inline double chi2Limit(int k) {
    const double z = 4.753424;  // standard normal upper 1e-6 point
    const double a = 2.0 / (9.0 * k);
    return k * std::pow(1.0 - a + z * std::sqrt(a), 3);
}

struct Chi2 {
    double value = 0.0;
    int dof = 0;
};

// Bins with fewer than 5 expected counts are pooled into one.
inline Chi2 chiSquare(const std::vector<double>& observed, const std::vector<double>& probability,
                      double n) {
    Chi2 c;
    double pooledObs = 0.0, pooledExp = 0.0;
    int bins = 0;
    for (size_t i = 0; i < observed.size(); ++i) {
        const double e = probability[i] * n;
        if (e < 5.0) {
            pooledObs += observed[i];
            pooledExp += e;
            continue;
        }
        c.value += (observed[i] - e) * (observed[i] - e) / e;
        ++bins;
    }
    if (pooledExp >= 5.0) {
        c.value += (pooledObs - pooledExp) * (pooledObs - pooledExp) / pooledExp;
        ++bins;
    } else {
        EXPECT_LE(pooledObs, 30.0) << "samples in bins that should be (almost) empty";
    }
    c.dof = bins - 1;
    return c;
}

inline void expectChi2(const char* what, const Chi2& c) {
    std::cout << "[ chi2     ] " << what << ": " << c.value << " with " << c.dof << " dof (limit "
              << chi2Limit(c.dof) << ")\n";
    EXPECT_LT(c.value, chi2Limit(c.dof)) << what;
    EXPECT_GT(c.dof, 10) << what;
}

// Angle from `axis` (accurate for small angles) and azimuth in a basis of the test's own.
struct Polar {
    double alpha, phi;
};
inline Polar polarAbout(const Vec3& axis, const Vec3& w) {
    const Vec3 e1 = perpendicular(axis), e2 = glm::cross(axis, e1);
    const double alpha = 2.0 * std::asin(std::min(1.0, glm::length(w - axis) / 2.0));
    double phi = std::atan2(glm::dot(w, e2), glm::dot(w, e1));
    if (phi < 0) phi += 2 * kPi;
    return {alpha, phi};
}

inline int binOf(const std::vector<double>& edges, double x) {
    for (size_t i = 0; i + 1 < edges.size(); ++i)
        if (x < edges[i + 1]) return static_cast<int>(i);
    return static_cast<int>(edges.size()) - 2;
}

// Bin probabilities in (r = |beta - beta0|, phi) of a lobe bsdf(beta, r) on the unit disk
// of beta, by midpoint quadrature (the bsdf over the projected solid angle is an area
// integral in beta).
inline std::vector<double> lobeBinProbabilities(
    const std::function<double(const Vec2&, double)>& bsdf, const Vec2& beta0,
    const std::vector<double>& rEdges, int nphi, double* tis = nullptr) {
    const int nr = static_cast<int>(rEdges.size()) - 1;
    std::vector<double> p(nr * nphi, 0.0);
    double total = 0.0;
    const int subR = 400, subP = 60;
    for (int a = 0; a < nr; ++a) {
        const double dr = (rEdges[a + 1] - rEdges[a]) / subR;
        for (int i = 0; i < subR; ++i) {
            const double r = rEdges[a] + (i + 0.5) * dr;
            const double w = r * dr;
            for (int b = 0; b < nphi; ++b) {
                const double dp = 2 * kPi / nphi / subP;
                for (int j = 0; j < subP; ++j) {
                    const double ph = b * 2 * kPi / nphi + (j + 0.5) * dp;
                    const Vec2 beta = beta0 + r * Vec2(std::cos(ph), std::sin(ph));
                    if (glm::dot(beta, beta) < 1.0) {
                        const double v = bsdf(beta, r) * w * dp;
                        p[a * nphi + b] += v;
                        total += v;
                    }
                }
            }
        }
    }
    for (double& v : p) v /= total;
    if (tis) *tis = total;
    return p;
}

// The same for a lobe that depends on r = |beta - beta0| alone.
inline std::vector<double> lobeBinProbabilities(const std::function<double(double)>& bsdf,
                                                const Vec2& beta0,
                                                const std::vector<double>& rEdges, int nphi,
                                                double* tis = nullptr) {
    return lobeBinProbabilities([&](const Vec2&, double r) { return bsdf(r); }, beta0, rEdges, nphi,
                                tis);
}

// Directions on the test surface's plane (kNormal's), in a basis of the tests' own.
inline Vec2 projectOnSurface(const Vec3& w) {
    const Vec3 t1 = perpendicular(kNormal), t2 = glm::cross(kNormal, t1);
    return Vec2(glm::dot(w, t1), glm::dot(w, t2));
}

// One sampled direction of a channel (normal kNormal), checked: it exists and lies on the
// channel's side, its pdf is scatterPdf's (1e-9) and its weight bsdf |cos| / pdf is the
// channel's fraction (1e-12 relative). Fatal failures end the caller's loop (check
// HasFatalFailure()).
inline void sampleChecked(const char* what, const OpticalProperty& p, const SurfaceContext& c,
                          bool transmit, double fraction, double u1, double u2, ScatterSample& s) {
    s = p.sampleScatter(c, transmit, u1, u2);
    ASSERT_GT(s.pdf, 0.0) << what;
    const double cosO = glm::dot(s.direction, kNormal);
    ASSERT_GT(transmit ? -cosO : cosO, 0.0) << what;
    ASSERT_NEAR(s.pdf, p.scatterPdf(c, s.direction), 1e-9 * s.pdf) << what;
    ASSERT_NEAR(p.bsdf(c, s.direction) * std::abs(cosO) / s.pdf, fraction, 1e-12 * fraction)
        << what;
}

// One scatter channel of `p` at context c (normal kNormal) sampled 200000 times against bin
// probabilities of `model` (the BSDF per unit beta area, written by the test from the model's
// definition; beta0 the specular direction's projection): the channel's fraction against the
// model's integral (2e-4), every sample's pdf against scatterPdf (1e-9) and its weight
// bsdf |cos| / pdf against the fraction (1e-12), and a chi-square of the samples' bins in
// (|beta - beta0|, azimuth).
inline void channelChi2(const char* what, const OpticalProperty& p, const SurfaceContext& c,
                        bool transmit, const Vec2& beta0,
                        const std::function<double(const Vec2&, double)>& model,
                        const std::vector<double>& rEdges, uint64_t seed) {
    const int nphi = 8;
    double tis = 0.0;
    const std::vector<double> prob = lobeBinProbabilities(model, beta0, rEdges, nphi, &tis);
    const Channels ch = p.channels(c);
    const double fraction = transmit ? ch.scatterTransmit : ch.scatterReflect;
    EXPECT_NEAR(fraction, tis, 2e-4 * tis) << what;
    std::vector<double> obs(prob.size(), 0.0);
    const int n = 200000;
    CounterRng rng(seed, 0);
    for (int i = 0; i < n; ++i) {
        const double u1 = rng.uniform(), u2 = rng.uniform();
        ScatterSample s;
        sampleChecked(what, p, c, transmit, fraction, u1, u2, s);
        if (::testing::Test::HasFatalFailure()) return;
        const Vec2 rel = projectOnSurface(s.direction) - beta0;
        double phi = std::atan2(rel.y, rel.x);
        if (phi < 0) phi += 2 * kPi;
        obs[binOf(rEdges, glm::length(rel)) * nphi +
            std::min(nphi - 1, static_cast<int>(phi / (2 * kPi) * nphi))] += 1;
    }
    expectChi2(what, chiSquare(obs, prob, n));
}

}  // namespace veil::scatter_test
