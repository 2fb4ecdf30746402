// Optical properties: channel fractions against Fresnel and the documented mixing rule,
// energy conservation, samplers against chi-square tests of their angular distributions
// (expected bin probabilities integrated here, by brute force, from the documented
// definitions), bsdf quadratures against the channel fractions, and reciprocity.
//
// Chi-square thresholds are the 1 - 1e-6 quantile for the degrees of freedom (Wilson-Hilferty);
// with fixed CounterRng seeds the tests are deterministic, and a correct sampler would fail
// one with probability 1e-6 per seed.

#include "tracer/surfaces/optical_property.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <iostream>
#include <numbers>
#include <sstream>
#include <tuple>
#include <vector>

#include "lensdata/errors.h"
#include "tests/tracer/surfaces/scatter_test_support.h"
#include "tracer/runtime/rng.h"
#include "tracer/sequential/sequential_trace.h"
#include "tracer/surfaces/fresnel.h"

namespace veil {
namespace {

using namespace scatter_test;

// Specular Channels

TEST(OpticalProperty, UncoatedFollowsFresnelAndConservesEnergy) {
    const OpticalProperty p = OpticalProperty::uncoated();
    for (double a : {0.0, 30.0, 56.0, 80.0}) {
        const Channels ch = p.channels(contextAt(a, 1.0, 1.5168));
        EXPECT_NEAR(ch.specularReflect, fresnelReflectance(1.0, 1.5168, std::cos(deg(a))), 1e-15);
        EXPECT_NEAR(ch.sum(), 1.0, 1e-15);
        EXPECT_FALSE(ch.tir);
        EXPECT_EQ(ch.scatterReflect + ch.scatterTransmit, 0.0);
    }
    const Channels tir = p.channels(contextAt(45.0, 1.5168, 1.0));  // critical 41.2 deg
    EXPECT_TRUE(tir.tir);
    EXPECT_EQ(tir.specularReflect, 1.0);
    EXPECT_EQ(tir.specularTransmit, 0.0);
}

TEST(OpticalProperty, SpecularModels) {
    const SurfaceContext in = contextAt(20.0, 1.0, 1.5);
    const SurfaceContext tirCtx = contextAt(60.0, 1.5, 1.0);

    const OpticalProperty ar = OpticalProperty::idealAr();
    EXPECT_EQ(ar.channels(in).specularReflect, 0.0);
    EXPECT_EQ(ar.channels(in).specularTransmit, 1.0);
    EXPECT_EQ(ar.channels(tirCtx).specularReflect, 1.0);
    EXPECT_TRUE(ar.channels(tirCtx).tir);

    // The seed's "1% specular reflectance".
    const OpticalProperty fixed("lens_1pct", FixedSpecular{0.01, 0.99});
    EXPECT_EQ(fixed.channels(in).specularReflect, 0.01);
    EXPECT_EQ(fixed.channels(in).specularTransmit, 0.99);
    EXPECT_EQ(fixed.channels(tirCtx).specularReflect, 1.0);
    EXPECT_EQ(fixed.channels(tirCtx).specularTransmit, 0.0);
    // With absorption the absorbed share stays under TIR.
    const OpticalProperty lossy("lossy", FixedSpecular{0.02, 0.9});
    EXPECT_NEAR(lossy.channels(tirCtx).specularReflect, 0.92, 1e-15);
    EXPECT_NEAR(lossy.channels(in).absorbed(), 0.08, 1e-15);

    const OpticalProperty qw("mgf2", QuarterWaveSpecular{1.38, 550.0});
    SurfaceContext normal = contextAt(0.0, 1.0, 1.52);
    normal.wavelengthNm = 550.0;
    EXPECT_NEAR(qw.channels(normal).specularReflect,
                std::pow((1.52 - 1.38 * 1.38) / (1.52 + 1.38 * 1.38), 2), 1e-15);
    EXPECT_NEAR(qw.channels(normal).sum(), 1.0, 1e-15);
    EXPECT_EQ(qw.channels(tirCtx).specularReflect, 1.0);

    const OpticalProperty mirror = OpticalProperty::mirror(0.95);
    EXPECT_EQ(mirror.channels(in).specularReflect, 0.95);
    EXPECT_EQ(mirror.channels(in).specularTransmit, 0.0);
    EXPECT_NEAR(mirror.channels(in).absorbed(), 0.05, 1e-15);
    EXPECT_FALSE(mirror.channels(tirCtx).tir);

    const OpticalProperty black = OpticalProperty::absorber();
    EXPECT_EQ(black.channels(in).sum(), 0.0);
    EXPECT_EQ(black.channels(in).absorbed(), 1.0);
}

TEST(OpticalProperty, OpaquePartsTransmitNothing) {
    const OpticalProperty ground("ground", AbsorberSpecular{}, LambertianScatter{0.5, 0.5});
    const Channels ch = ground.channels(contextAt(30.0, 1.0, 1.0, true));
    EXPECT_EQ(ch.scatterReflect, 0.5);
    EXPECT_EQ(ch.scatterTransmit, 0.0);
    EXPECT_EQ(ch.absorbed(), 0.5);
    SurfaceContext opaque = contextAt(30.0, 1.0, 1.0, true);
    EXPECT_EQ(ground.sampleScatter(opaque, true, 0.3, 0.4).pdf, 0.0);
    EXPECT_EQ(ground.bsdf(opaque, -kNormal), 0.0);
    EXPECT_EQ(OpticalProperty::idealAr().channels(opaque).specularTransmit, 0.0);
}

TEST(OpticalProperty, ScatterTakesItsShareFirst) {
    // The seed's lens surfaces with 1% specular reflectance plus 2% Lambertian reflectance.
    const OpticalProperty p("mixed", FixedSpecular{0.01, 0.99}, LambertianScatter{0.02, 0.0});
    const Channels ch = p.channels(contextAt(10.0, 1.0, 1.5));
    EXPECT_EQ(ch.scatterReflect, 0.02);
    EXPECT_NEAR(ch.specularReflect, 0.98 * 0.01, 1e-17);
    EXPECT_NEAR(ch.specularTransmit, 0.98 * 0.99, 1e-15);
    EXPECT_NEAR(ch.sum(), 1.0, 1e-15);

    // Gaussian transmission under TIR: its share joins the total reflection.
    const OpticalProperty g("g", FresnelSpecular{}, GaussianScatter(0.05, 0.1, 5.0));
    const Channels t = g.channels(contextAt(60.0, 1.5, 1.0));
    EXPECT_TRUE(t.tir);
    EXPECT_EQ(t.scatterTransmit, 0.0);
    EXPECT_NEAR(t.specularReflect, 0.95, 1e-15);
    EXPECT_EQ(g.sampleScatter(contextAt(60.0, 1.5, 1.0), true, 0.5, 0.5).pdf, 0.0);
}

TEST(OpticalProperty, ChannelsNeverExceedOneAndSumToOneWithoutAbsorption) {
    struct Case {
        OpticalProperty p;
        bool lossless;
    };
    const std::vector<Case> cases = {
        {OpticalProperty::uncoated(), true},
        {OpticalProperty::idealAr(), true},
        {OpticalProperty("fixed", FixedSpecular{0.01, 0.99}), true},
        {OpticalProperty("qw", QuarterWaveSpecular{1.38, 550.0}), true},
        {OpticalProperty("ground", AbsorberSpecular{}, LambertianScatter{0.5, 0.5}), true},
        {OpticalProperty("gauss", FresnelSpecular{}, GaussianScatter(0.05, 0.05, 5.0)), true},
        {OpticalProperty("abg", FresnelSpecular{},
                         AbgScatter(AbgParams{0.01, 1e-3, 2.0}, AbgParams{0.005, 1e-3, 2.0})),
         true},
        {OpticalProperty::mirror(0.9), false},
        {OpticalProperty("paint", AbsorberSpecular{}, LambertianScatter{0.05, 0.0}), false},
    };
    CounterRng rng(11, 0);
    for (const Case& k : cases) {
        for (int i = 0; i < 2000; ++i) {
            const double a = 90.0 * rng.uniform();
            const double n1 = 1.0 + rng.uniform(), n2 = 1.0 + rng.uniform();
            SurfaceContext c = contextAt(a, n1, n2);
            c.wavelengthNm = 400.0 + 300.0 * rng.uniform();
            const Channels ch = k.p.channels(c);
            for (double v :
                 {ch.specularReflect, ch.specularTransmit, ch.scatterReflect, ch.scatterTransmit}) {
                EXPECT_GE(v, 0.0) << k.p << " " << c;
                EXPECT_LE(v, 1.0) << k.p << " " << c;
            }
            EXPECT_LE(ch.sum(), 1.0 + 1e-15) << k.p << " " << c;
            if (k.lossless) {
                EXPECT_NEAR(ch.sum(), 1.0, 1e-14) << k.p << " " << c;
            }
            const bool dielectric = !std::holds_alternative<AbsorberSpecular>(k.p.specular()) &&
                                    !std::holds_alternative<MirrorSpecular>(k.p.specular());
            EXPECT_EQ(ch.tir, dielectric && totalInternalReflection(n1, n2, c.cosIncidence()));
        }
    }
}

TEST(OpticalProperty, BadParametersAreModelErrors) {
    EXPECT_THROW(OpticalProperty("x", FixedSpecular{0.5, 0.6}), ModelError);
    EXPECT_THROW(OpticalProperty("x", MirrorSpecular{1.2}), ModelError);
    EXPECT_THROW(OpticalProperty("x", QuarterWaveSpecular{0.0, 550.0}), ModelError);
    EXPECT_THROW(OpticalProperty("x", AbsorberSpecular{}, LambertianScatter{0.7, 0.4}), ModelError);
    EXPECT_THROW(GaussianScatter(0.1, 0.0, 0.0), std::invalid_argument);
    EXPECT_THROW(GaussianScatter(0.1, 0.0, 91.0), std::invalid_argument);
    EXPECT_THROW(AbgScatter(AbgParams{1.0, 1e-3, 2.0}, std::nullopt), std::invalid_argument);
    EXPECT_THROW(AbgScatter(AbgParams{0.01, 0.0, 2.0}, std::nullopt), std::invalid_argument);
    EXPECT_THROW(AbgScatter(std::nullopt, std::nullopt), std::invalid_argument);
}

// Lambertian Sampler

TEST(LambertianScatter, SamplerPassesChiSquareOnBothSides) {
    const OpticalProperty p("ground", AbsorberSpecular{}, LambertianScatter{0.5, 0.5});
    for (bool transmit : {false, true}) {
        const SurfaceContext c = contextAt(35.0, 1.0, 1.5);
        const Vec3 side = transmit ? -kNormal : kNormal;
        // cos^2(theta) is uniform under cosine weighting: 10 bins in it times 8 in azimuth.
        const int nc = 10, nphi = 8;
        std::vector<double> obs(nc * nphi, 0.0), prob(nc * nphi, 1.0 / (nc * nphi));
        const int n = 200000;
        CounterRng rng(1234, transmit);
        for (int i = 0; i < n; ++i) {
            const double u1 = rng.uniform(), u2 = rng.uniform();
            const ScatterSample s = p.sampleScatter(c, transmit, u1, u2);
            const double cosT = glm::dot(s.direction, side);
            ASSERT_GT(cosT, 0.0);
            ASSERT_NEAR(glm::length(s.direction), 1.0, 1e-12);
            ASSERT_NEAR(s.pdf, cosT / kPi, 1e-12);
            // Weight = fraction: bsdf cos / pdf is the channel fraction for every sample.
            ASSERT_NEAR(p.bsdf(c, s.direction) * cosT / s.pdf, 0.5, 1e-12);
            const Polar pol = polarAbout(side, s.direction);
            const int b = std::min(nc - 1, static_cast<int>(cosT * cosT * nc)) * nphi +
                          std::min(nphi - 1, static_cast<int>(pol.phi / (2 * kPi) * nphi));
            obs[b] += 1;
        }
        expectChi2(transmit ? "Lambertian transmit (cos^2 x azimuth)"
                            : "Lambertian reflect (cos^2 x azimuth)",
                   chiSquare(obs, prob, n));
    }
}

TEST(LambertianScatter, BsdfIsReciprocalAndIntegratesToItsFraction) {
    const OpticalProperty p("paint", AbsorberSpecular{}, LambertianScatter{0.3, 0.0});
    // Midpoint quadrature over the hemisphere.
    double sum = 0.0;
    const int nt = 400, np = 64;
    const SurfaceContext c = contextAt(50.0);
    const Vec3 e1 = perpendicular(kNormal), e2 = glm::cross(kNormal, e1);
    for (int i = 0; i < nt; ++i) {
        const double t = (i + 0.5) * 0.5 * kPi / nt;
        for (int j = 0; j < np; ++j) {
            const double ph = (j + 0.5) * 2 * kPi / np;
            const Vec3 w =
                std::cos(t) * kNormal + std::sin(t) * (std::cos(ph) * e1 + std::sin(ph) * e2);
            sum += p.bsdf(c, w) * std::cos(t) * std::sin(t) * (0.5 * kPi / nt) * (2 * kPi / np);
        }
    }
    EXPECT_NEAR(sum, 0.3, 1e-5);
    const SurfaceContext back = contextAt(10.0);
    SurfaceContext reversed = back;
    const Vec3 out = glm::normalize(Vec3(0.1, 0.2, 0.0) + kNormal);
    reversed.direction = -out;
    EXPECT_DOUBLE_EQ(p.bsdf(back, out), p.bsdf(reversed, -back.direction));
}

// Gaussian Lobe

// Probabilities of (alpha, phi) bins about `axis` for the documented lobe
// (intensity ~ exp(-kappa (1 - cos alpha)), kappa = ln 2 / (1 - cos hwhm)), cut off at the
// horizon of `side`, by midpoint quadrature.
std::vector<double> gaussianBinProbabilities(double hwhmDeg, const Vec3& axis, const Vec3& side,
                                             const std::vector<double>& alphaEdges, int nphi,
                                             double* massAbove = nullptr) {
    const double kappa = std::log(2.0) / (1.0 - std::cos(deg(hwhmDeg)));
    const Vec3 e1 = perpendicular(axis), e2 = glm::cross(axis, e1);
    const int na = static_cast<int>(alphaEdges.size()) - 1;
    std::vector<double> p(na * nphi, 0.0);
    double total = 0.0, unclipped = 0.0;
    const int subA = 300, subP = 90;
    for (int a = 0; a < na; ++a) {
        const double da = (alphaEdges[a + 1] - alphaEdges[a]) / subA;
        for (int i = 0; i < subA; ++i) {
            const double al = alphaEdges[a] + (i + 0.5) * da;
            const double w = std::exp(-kappa * (1.0 - std::cos(al))) * std::sin(al) * da;
            unclipped += w * 2 * kPi;
            for (int b = 0; b < nphi; ++b) {
                const double dp = 2 * kPi / nphi / subP;
                for (int j = 0; j < subP; ++j) {
                    const double ph = b * 2 * kPi / nphi + (j + 0.5) * dp;
                    const Vec3 dir = std::cos(al) * axis +
                                     std::sin(al) * (std::cos(ph) * e1 + std::sin(ph) * e2);
                    if (glm::dot(dir, side) > 0.0) {
                        p[a * nphi + b] += w * dp;
                        total += w * dp;
                    }
                }
            }
        }
    }
    for (double& v : p) v /= total;
    if (massAbove) *massAbove = total / unclipped;
    return p;
}

void gaussianChi2(const char* what, const OpticalProperty& p, const SurfaceContext& c,
                  bool transmit, double hwhmDeg, const Vec3& axis,
                  const std::vector<double>& alphaEdgesDeg, uint64_t seed) {
    std::vector<double> edges;
    for (double e : alphaEdgesDeg) edges.push_back(deg(e));
    const int nphi = 8;
    const Vec3 side = transmit ? -c.normal : c.normal;
    double mass = 0.0;
    const std::vector<double> prob =
        gaussianBinProbabilities(hwhmDeg, axis, side, edges, nphi, &mass);
    const auto* g = std::get_if<GaussianScatter>(&p.scatter());
    ASSERT_NE(g, nullptr);
    EXPECT_NEAR(g->hemisphereMass(glm::dot(axis, side)), mass, 2e-5) << what;
    const double fraction = transmit ? p.channels(c).scatterTransmit : p.channels(c).scatterReflect;
    std::vector<double> obs(prob.size(), 0.0);
    const int n = 200000;
    CounterRng rng(seed, 0);
    for (int i = 0; i < n; ++i) {
        const double u1 = rng.uniform(), u2 = rng.uniform();
        const ScatterSample s = p.sampleScatter(c, transmit, u1, u2);
        const double cosO = glm::dot(s.direction, side);
        ASSERT_GT(cosO, 0.0) << what;
        if (i % 97 == 0) {  // pdf and weight consistency on a subset (each costs a quadrature)
            ASSERT_NEAR(s.pdf, p.scatterPdf(c, s.direction), 1e-9 * s.pdf) << what;
            ASSERT_NEAR(p.bsdf(c, s.direction) * cosO / s.pdf, fraction, 1e-12) << what;
        }
        const Polar pol = polarAbout(axis, s.direction);
        obs[binOf(edges, pol.alpha) * nphi +
            std::min(nphi - 1, static_cast<int>(pol.phi / (2 * kPi) * nphi))] += 1;
    }
    expectChi2(what, chiSquare(obs, prob, n));
}

TEST(GaussianScatter, HalfWidthIsTheHalfMaximumOfTheIntensity) {
    const OpticalProperty p("g", AbsorberSpecular{}, GaussianScatter(0.05, 0.0, 5.0));
    const SurfaceContext c = contextAt(0.0);
    const Vec3 axis = kNormal;  // specular direction at normal incidence
    const Vec3 e = perpendicular(axis);
    auto intensity = [&](double aDeg) {
        const Vec3 w = std::cos(deg(aDeg)) * axis + std::sin(deg(aDeg)) * e;
        return p.bsdf(c, w) * glm::dot(w, c.normal);
    };
    EXPECT_NEAR(intensity(5.0) / intensity(0.0), 0.5, 1e-12);
    EXPECT_NEAR(intensity(10.0) / intensity(0.0),
                std::exp(-std::log(2.0) * (1 - std::cos(deg(10))) / (1 - std::cos(deg(5)))), 1e-12);
    // Small angles: the Gaussian exp(-ln 2 (a / w)^2) to 0.1 %.
    EXPECT_NEAR(intensity(7.0) / intensity(0.0), std::exp(-std::log(2.0) * 49.0 / 25.0), 1e-3);
}

TEST(GaussianScatter, SamplerPassesChiSquareAtNormalAndObliqueIncidence) {
    const OpticalProperty p("g", AbsorberSpecular{}, GaussianScatter(0.05, 0.0, 5.0));
    const std::vector<double> edges = {0, 1, 2, 3, 4, 5, 6, 7, 8, 10, 12, 15, 180};
    for (double a : {0.0, 60.0}) {
        const SurfaceContext c = contextAt(a);
        const Vec3 axis = c.direction - 2.0 * glm::dot(c.direction, c.normal) * c.normal;
        gaussianChi2(
            a == 0.0 ? "Gaussian 5 deg, normal incidence" : "Gaussian 5 deg, 60 deg incidence", p,
            c, false, 5.0, axis, edges, 77 + static_cast<uint64_t>(a));
    }
}

TEST(GaussianScatter, LobeClippedAtGrazingIsRenormalised) {
    const OpticalProperty p("g", AbsorberSpecular{}, GaussianScatter(0.05, 0.0, 5.0));
    const SurfaceContext c = contextAt(87.0);
    const Vec3 axis = c.direction - 2.0 * glm::dot(c.direction, c.normal) * c.normal;
    gaussianChi2("Gaussian 5 deg, 87 deg incidence (clipped)", p, c, false, 5.0, axis,
                 {0, 1, 2, 3, 4, 5, 6, 8, 10, 14, 180}, 91);
    // A wide lobe at exactly grazing incidence: half of it is cut away.
    const GaussianScatter wide(0.1, 0.0, 40.0);
    EXPECT_NEAR(wide.hemisphereMass(0.0), 0.5, 1e-12);
    const OpticalProperty w("wide", AbsorberSpecular{}, wide);
    const SurfaceContext g = contextAt(80.0);
    const Vec3 gAxis = g.direction - 2.0 * glm::dot(g.direction, g.normal) * g.normal;
    gaussianChi2("Gaussian 40 deg, 80 deg incidence (clipped)", w, g, false, 40.0, gAxis,
                 {0, 5, 10, 15, 20, 25, 30, 40, 50, 60, 80, 180}, 92);
}

TEST(GaussianScatter, TransmissionLobeFollowsTheRefractedDirection) {
    const OpticalProperty p("g", FresnelSpecular{}, GaussianScatter(0.0, 0.3, 10.0));
    const SurfaceContext c = contextAt(40.0, 1.0, 1.5);
    // Snell's law written out here: sin t = sin i / 1.5 in the plane of incidence.
    const Vec3 tangent = glm::normalize(c.direction - glm::dot(c.direction, kNormal) * kNormal);
    const double st = std::sin(deg(40.0)) / 1.5;
    const Vec3 axis = -std::sqrt(1 - st * st) * kNormal + st * tangent;
    EXPECT_NEAR(p.channels(c).scatterTransmit, 0.3, 1e-15);
    gaussianChi2("Gaussian 10 deg transmission, 40 deg incidence", p, c, true, 10.0, axis,
                 {0, 2, 4, 6, 8, 10, 12, 14, 17, 20, 25, 30, 180}, 93);
}

// Quadrature of bsdf cos over the hemisphere of `side` in (alpha, phi) about `axis`, fine
// near the axis.
double gaussianBsdfIntegral(const OpticalProperty& p, const SurfaceContext& c, const Vec3& axis,
                            const Vec3& side, double hwhmDeg) {
    const Vec3 e1 = perpendicular(axis), e2 = glm::cross(axis, e1);
    double sum = 0.0;
    auto band = [&](double a0, double a1, int na, int nphi) {
        const double da = (a1 - a0) / na, dp = 2 * kPi / nphi;
        for (int i = 0; i < na; ++i) {
            const double al = a0 + (i + 0.5) * da;
            for (int j = 0; j < nphi; ++j) {
                const double ph = (j + 0.5) * dp;
                const Vec3 w =
                    std::cos(al) * axis + std::sin(al) * (std::cos(ph) * e1 + std::sin(ph) * e2);
                const double cosO = glm::dot(w, side);
                if (cosO > 0.0) sum += p.bsdf(c, w) * cosO * std::sin(al) * da * dp;
            }
        }
    };
    const double h = deg(hwhmDeg);
    band(0.0, 6 * h, 300, 180);
    band(6 * h, kPi, 100, 90);
    return sum;
}

TEST(GaussianScatter, BsdfIntegratesToTheChannelFraction) {
    const OpticalProperty p("g", FresnelSpecular{}, GaussianScatter(0.05, 0.02, 5.0));
    for (double a : {0.0, 45.0, 87.0}) {
        const SurfaceContext c = contextAt(a, 1.0, 1.5);
        const Channels ch = p.channels(c);
        const Vec3 r = c.direction - 2.0 * glm::dot(c.direction, c.normal) * c.normal;
        EXPECT_NEAR(gaussianBsdfIntegral(p, c, r, c.normal, 5.0), ch.scatterReflect, 2e-5) << a;
        const Vec3 t = *refract(c.direction, c.normal, 1.0, 1.5);
        EXPECT_NEAR(gaussianBsdfIntegral(p, c, t, -c.normal, 5.0), ch.scatterTransmit, 2e-5) << a;
    }
}

// ABg Lobe

std::vector<double> abgBinProbabilities(const AbgParams& q, const Vec2& beta0,
                                        const std::vector<double>& rEdges, int nphi,
                                        double* tis = nullptr) {
    return lobeBinProbabilities([&](double r) { return q.a / (q.b + std::pow(r, q.g)); }, beta0,
                                rEdges, nphi, tis);
}

// The lobe's sampled directions against bin probabilities of `bsdf` (the model's own formula,
// not the lobe's): chi-square, and the TIS the property reports against their quadrature.
void lobeChi2(const char* what, const AbgScatter& scatter,
              const std::function<double(double)>& bsdf, double incidenceDeg,
              const std::vector<double>& rEdges, uint64_t seed) {
    const SurfaceContext c = contextAt(incidenceDeg);
    // The mirror direction has the incident one's projection.
    channelChi2(
        what, OpticalProperty("abg", AbsorberSpecular{}, scatter), c, false,
        projectOnSurface(c.direction), [&](const Vec2&, double r) { return bsdf(r); }, rEdges,
        seed);
}

void abgChi2(const char* what, const AbgParams& q, double incidenceDeg,
             const std::vector<double>& rEdges, uint64_t seed) {
    lobeChi2(
        what, AbgScatter(q, std::nullopt), [&](double r) { return q.a / (q.b + std::pow(r, q.g)); },
        incidenceDeg, rEdges, seed);
}

TEST(AbgScatter, TisAtNormalIncidenceMatchesTheClosedForm) {
    // g = 2: TIS = 2 pi A integral_0^1 r / (B + r^2) dr = pi A ln(1 + 1/B).
    for (double b : {1e-6, 1e-3, 0.1, 3.0}) {
        const AbgLobe lobe({0.01, b, 2.0});
        EXPECT_NEAR(lobe.tis(0.0), kPi * 0.01 * std::log1p(1.0 / b), 1e-12) << b;
        EXPECT_NEAR(lobe.tisExact(0.0), kPi * 0.01 * std::log1p(1.0 / b), 1e-12) << b;
    }
    // g = 0 is Lambertian: TIS = pi A / (B + 1) at every angle.
    const AbgLobe flat({0.1, 0.5, 0.0});
    for (double b0 : {0.0, 0.5, 0.9, 1.0}) EXPECT_NEAR(flat.tis(b0), kPi * 0.1 / 1.5, 1e-10);
}

TEST(AbgScatter, TisTableMatchesDirectQuadrature) {
    for (const AbgParams q :
         {AbgParams{0.01, 1e-3, 2.0}, AbgParams{0.005, 1e-4, 1.5}, AbgParams{1e-4, 1e-6, 2.5}}) {
        const AbgLobe lobe(q);
        for (double b0 : {0.05, 0.3, 0.7, 0.95, 0.995, 0.9999}) {
            EXPECT_NEAR(lobe.tis(b0), lobe.tisExact(b0), 1e-6 * lobe.tisExact(b0))
                << q << " b0 " << b0;
        }
    }
}

TEST(AbgScatter, SamplerPassesChiSquare) {
    // Normal incidence, g = 2: equal-probability radial bins from the closed-form CDF
    // ln(1 + r^2 / B) / ln(1 + 1 / B).
    const AbgParams q{0.01, 1e-3, 2.0};
    std::vector<double> edges;
    for (int k = 0; k <= 20; ++k)
        edges.push_back(k == 20 ? 1.0
                                : std::sqrt(q.b * std::expm1(k / 20.0 * std::log1p(1.0 / q.b))));
    abgChi2("ABg g=2 normal incidence", q, 0.0, edges, 501);
    // Oblique and grazing, where the unit disk clips the lobe.
    abgChi2("ABg g=1.5 60 deg incidence", {0.005, 1e-3, 1.5}, 60.0,
            {0, 0.005, 0.01, 0.02, 0.04, 0.08, 0.15, 0.3, 0.6, 1.0, 2.0}, 502);
    abgChi2("ABg g=2 85 deg incidence", {0.002, 1e-2, 2.0}, 85.0,
            {0, 0.01, 0.02, 0.04, 0.06, 0.1, 0.15, 0.25, 0.4, 0.7, 2.0}, 503);
}

TEST(AbgScatter, BsdfIsReciprocal) {
    const OpticalProperty p("abg", FresnelSpecular{},
                            AbgScatter(AbgParams{0.01, 1e-3, 1.8}, std::nullopt));
    CounterRng rng(5, 5);
    const Vec3 e1 = perpendicular(kNormal), e2 = glm::cross(kNormal, e1);
    auto hemisphere = [&](double u1, double u2) {
        const double ct = std::max(1e-3, u1), st = std::sqrt(1 - ct * ct);
        return ct * kNormal + st * (std::cos(2 * kPi * u2) * e1 + std::sin(2 * kPi * u2) * e2);
    };
    for (int i = 0; i < 100; ++i) {
        const Vec3 in = -hemisphere(rng.uniform(), rng.uniform());  // travelling toward the surface
        const Vec3 out = hemisphere(rng.uniform(), rng.uniform());
        SurfaceContext a;
        a.normal = kNormal;
        a.direction = in;
        SurfaceContext b = a;
        b.direction = -out;
        EXPECT_NEAR(p.bsdf(a, out), p.bsdf(b, -in), 1e-12 * p.bsdf(a, out));
    }
}

TEST(AbgScatter, TransmissionLobeIntegratesToItsFraction) {
    // BTDF about the refracted direction: beta0 = (n1 / n2) sin(i). The fraction equals the
    // area integral of the BSDF over the unit disk about that beta0.
    const AbgParams bt{0.004, 1e-3, 2.0};
    const OpticalProperty p("abg", FresnelSpecular{}, AbgScatter(std::nullopt, bt));
    const SurfaceContext c = contextAt(50.0, 1.0, 1.6);
    double tis = 0.0;
    abgBinProbabilities(bt, Vec2(std::sin(deg(50.0)) / 1.6, 0.0), {0, 0.01, 0.1, 0.5, 2.0}, 4,
                        &tis);
    EXPECT_NEAR(p.channels(c).scatterTransmit, tis, 2e-4 * tis);
    CounterRng rng(8, 8);
    for (int i = 0; i < 1000; ++i) {
        const double u1 = rng.uniform(), u2 = rng.uniform();
        const ScatterSample s = p.sampleScatter(c, true, u1, u2);
        ASSERT_LT(glm::dot(s.direction, kNormal), 0.0);
        ASSERT_GT(s.pdf, 0.0);
    }
    // Under TIR the transmission lobe is off.
    EXPECT_EQ(p.channels(contextAt(50.0, 1.6, 1.0)).scatterTransmit, 0.0);
}

TEST(OpticalProperty, PrintsItself) {
    std::ostringstream os;
    os << OpticalProperty("g", FixedSpecular{0.01, 0.99}, GaussianScatter(0.05, 0.0, 5.0)) << " "
       << contextAt(10.0) << " " << Channels{};
    EXPECT_NE(os.str().find("HWHM 5"), std::string::npos) << os.str();
    EXPECT_NE(os.str().find("fixed{R 0.01"), std::string::npos) << os.str();
}

// Harvey-Shack Lobe

// The model as its authors write it, from its own parameters.
double harveyShackBsdf(double b0, double l, double s, double r) {
    return b0 * std::pow(1.0 + (r / l) * (r / l), 0.5 * s);
}

TEST(HarveyShackScatter, IsTheLobeItsParametersDescribe) {
    for (const auto& [b0, l, s] : {std::tuple{50.0, 0.01, -2.5}, std::tuple{2.0, 0.05, -1.5},
                                   std::tuple{0.3, 0.2, -2.0}, std::tuple{0.02, 0.5, 0.0}}) {
        const AbgLobe lobe(harveyShack(b0, l, s));
        for (double r : {0.0, 0.3 * l, l, 3.0 * l, 0.5, 1.7})
            EXPECT_NEAR(lobe.bsdf(r), harveyShackBsdf(b0, l, s, r),
                        1e-12 * harveyShackBsdf(b0, l, s, r))
                << b0 << " " << l << " " << s << " r " << r;
    }
    EXPECT_THROW(harveyShack(1.0, 0.0, -2.0), std::invalid_argument);
    EXPECT_THROW(harveyShack(1.0, 0.01, 0.5), std::invalid_argument);
    EXPECT_THROW(harveyShack(-1.0, 0.01, -2.0), std::invalid_argument);
}

TEST(HarveyShackScatter, TisAtNormalIncidenceMatchesTheClosedForm) {
    // TIS = 2 pi b0 integral_0^1 (1 + r^2 / l^2)^(s/2) r dr
    //     = 2 pi b0 l^2 ((1 + 1/l^2)^((s+2)/2) - 1) / (s + 2), and pi b0 l^2 ln(1 + 1/l^2) at
    //       s = -2.
    for (const auto& [b0, l, s] : {std::tuple{50.0, 0.01, -2.5}, std::tuple{2.0, 0.05, -1.5},
                                   std::tuple{0.3, 0.2, -2.0}, std::tuple{1.0, 0.1, -1.999999},
                                   std::tuple{0.02, 0.5, 0.0}, std::tuple{1e3, 1e-3, -3.0}}) {
        const double x = 1.0 + 1.0 / (l * l);
        const double expected =
            s == -2.0 ? kPi * b0 * l * l * std::log(x)
                      : 2.0 * kPi * b0 * l * l * (std::pow(x, 0.5 * (s + 2.0)) - 1.0) / (s + 2.0);
        const AbgLobe lobe(harveyShack(b0, l, s));
        EXPECT_NEAR(lobe.tis(0.0), expected, 1e-9 * expected) << b0 << " " << l << " " << s;
        EXPECT_NEAR(lobe.tisExact(0.0), expected, 1e-9 * expected) << b0 << " " << l << " " << s;
    }
}

TEST(HarveyShackScatter, TisTableMatchesDirectQuadratureAtEveryAngle) {
    for (const AbgParams q : {harveyShack(50.0, 0.01, -2.5), harveyShack(2.0, 0.05, -1.5),
                              harveyShack(1e3, 1e-3, -3.0)}) {
        const AbgLobe lobe(q);
        for (double b0 : {0.05, 0.3, 0.7, 0.95, 0.995, 0.9999}) {
            EXPECT_NEAR(lobe.tis(b0), lobe.tisExact(b0), 1e-6 * lobe.tisExact(b0))
                << q << " b0 " << b0;
        }
        // The radial CDF inverts itself to rounding.
        for (double r : {1e-5, 1e-3, 0.01, 0.1, 0.5, 1.0, 1.9}) {
            EXPECT_NEAR(lobe.inverseRadialCdf(lobe.radialCdf(r)), r, 1e-9 * r) << q << " r " << r;
        }
    }
}

TEST(HarveyShackScatter, SamplerPassesChiSquareAgainstTheModel) {
    const double b0 = 50.0, l = 0.01, s = -2.5;
    const auto hs = [&](double r) { return harveyShackBsdf(b0, l, s, r); };
    lobeChi2("Harvey-Shack normal incidence", AbgScatter(harveyShack(b0, l, s), std::nullopt), hs,
             0.0, {0, 0.002, 0.005, 0.01, 0.02, 0.04, 0.08, 0.16, 0.32, 0.64, 1.0}, 601);
    lobeChi2("Harvey-Shack 60 deg incidence", AbgScatter(harveyShack(b0, l, s), std::nullopt), hs,
             60.0, {0, 0.002, 0.005, 0.01, 0.02, 0.04, 0.08, 0.16, 0.32, 0.64, 2.0}, 602);
    const auto wide = [&](double r) { return harveyShackBsdf(0.05, 0.3, -1.2, r); };
    lobeChi2("Harvey-Shack wide, 80 deg incidence",
             AbgScatter(harveyShack(0.05, 0.3, -1.2), std::nullopt), wide, 80.0,
             {0, 0.05, 0.1, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0, 1.3, 2.0}, 603);
}

// A fit of two Harvey-Shack terms (a narrow core and a wide skirt, as contamination fits
// are written) is the sum of its lobes: its TIS the sum of theirs, its samples distributed as
// the summed BSDF.
TEST(HarveyShackScatter, TwoTermFitIsTheSumOfItsLobes) {
    const AbgParams core = harveyShack(3.93, 0.00411, -2.35),
                    skirt = harveyShack(0.00429, 0.0431513, -1.11);
    const AbgScatter both(std::vector<AbgParams>{core, skirt}, {});
    const AbgLobe a(core), b(skirt);
    for (double b0 : {0.0, 0.5, 0.9})
        EXPECT_NEAR(both.tis(false, b0), a.tis(b0) + b.tis(b0), 1e-15);
    const auto sum = [&](double r) {
        return harveyShackBsdf(3.93, 0.00411, -2.35, r) +
               harveyShackBsdf(0.00429, 0.0431513, -1.11, r);
    };
    const std::vector<double> edges = {0,    0.002, 0.004, 0.008, 0.016, 0.03,
                                       0.06, 0.12,  0.25,  0.5,   1.0,   2.0};
    lobeChi2("two Harvey-Shack terms, normal incidence", both, sum, 0.0, edges, 611);
    lobeChi2("two Harvey-Shack terms, 50 deg", both, sum, 50.0, edges, 612);
}

}  // namespace
}  // namespace veil
