// Tabulated scatter: an ABg model written to a .bsdf file and read back reproduces the
// model within interpolation error (and the error falls at the interpolant's order as the
// grid is refined); the TIS table against direct quadrature; sampled directions against
// chi-square bins integrated by brute force from the tabulated BSDF; TIS scaled to the file;
// energy and property-table errors.

#include "tracer/surfaces/tabulated_bsdf.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <sstream>

#include "lensdata/zemax_bsdf.h"
#include "tests/tracer/surfaces/scatter_test_support.h"
#include "tracer/runtime/rng.h"
#include "tracer/surfaces/optical_property.h"
#include "tracer/surfaces/scatter_tabulation.h"

namespace veil {
namespace {

using namespace scatter_test;

std::vector<double> steps(double from, double to, double step) {
    std::vector<double> v;
    for (double x = from; x <= to + 1e-9; x += step) v.push_back(x);
    return v;
}

// Radial angles: `fine` degrees out to 10, then 4 times coarser.
std::vector<double> radialGrid(double fine) {
    std::vector<double> v = steps(0.0, 10.0, fine);
    for (double r = 10.0 + 4 * fine; r <= 180.0 + 1e-9; r += 4 * fine) v.push_back(r);
    if (v.back() < 180.0) v.push_back(180.0);
    return v;
}

const AbgParams kAbg{0.01, 0.01, 2.0};
const AbgParams kAbgT{0.005, 0.02, 2.0};

OpticalProperty abgProperty() {
    return OpticalProperty("abg", FresnelSpecular{}, AbgScatter(kAbg, kAbgT));
}

// The ABg model through a written and re-read .bsdf file on the given grid.
TabulatedLobe roundTrip(const OpticalProperty& p, bool transmit, double incidenceStep,
                        double azimuthStep, double radialStep, double n2 = 1.0) {
    TabulationGrid g;
    g.incidenceDeg = steps(0.0, 85.0, incidenceStep);
    g.incidenceDeg.push_back(89.0);
    g.azimuthDeg = steps(0.0, 180.0, azimuthStep);
    g.radialDeg = radialGrid(radialStep);
    std::ostringstream os;
    writeZemaxBsdf(os, tabulateScatter(p, transmit, g, 550.0, 1.0, n2));
    return TabulatedLobe(parseZemaxBsdf(os.str(), "abg.bsdf"), false);
}

SurfaceContext contextOnZ(double incidenceDeg, double n2 = 1.0) {
    SurfaceContext c;
    c.normal = Vec3(0, 0, 1);
    const double i = deg(incidenceDeg);
    c.direction = Vec3(std::sin(i), 0.0, -std::cos(i));
    c.n2 = n2;
    c.wavelengthNm = 550.0;
    return c;
}

// Largest relative TIS error of the tabulated lobe against the ABg channel, over incidences
// between and on the blocks.
double worstTisError(const TabulatedLobe& lobe, const OpticalProperty& p) {
    double worst = 0.0;
    for (double i = 1.0; i <= 84.0; i += 2.5) {
        const double abg = p.channels(contextOnZ(i)).scatterReflect;
        worst = std::max(worst, std::abs(lobe.tis(i) - abg) / abg);
    }
    return worst;
}

TEST(TabulatedBsdf, AbgWrittenAndReadBackReproducesTheModel) {
    const OpticalProperty p = abgProperty();
    const TabulatedLobe coarse = roundTrip(p, false, 10.0, 10.0, 1.0);
    const TabulatedLobe fine = roundTrip(p, false, 5.0, 5.0, 0.5);
    const double coarseError = worstTisError(coarse, p), fineError = worstTisError(fine, p);
    std::cout << "[ TIS      ] ABg through .bsdf: worst relative error " << coarseError
              << " (10 deg blocks, 1 deg radial) and " << fineError
              << " (5 deg blocks, 0.5 deg radial)\n";
    EXPECT_LT(fineError, 5e-3);
    EXPECT_GT(coarseError / fineError, 3.0);  // second order: halving the steps quarters it

    // The BSDF itself, at directions off every grid line, against ABg; not within 5 degrees
    // of the horizon, where a table cell straddles it and the interpolant (which sees only
    // the corners above it) falls short.
    const OpticalProperty tab("tab", FresnelSpecular{},
                              TabulatedScatter(std::make_shared<TabulatedLobe>(fine), nullptr));
    CounterRng rng(3, 3);
    double worst = 0.0;
    for (int n = 0; n < 2000; ++n) {
        const double i = 80.0 * rng.uniform();
        const SurfaceContext c = contextOnZ(i);
        const double ct = 0.0872 + (1.0 - 0.0872) * rng.uniform(), st = std::sqrt(1 - ct * ct),
                     ph = 2 * kPi * rng.uniform();
        const Vec3 out(st * std::cos(ph), st * std::sin(ph), ct);
        const double a = p.bsdf(c, out);
        if (a < 0.05 * p.bsdf(c, reflect(c.direction, c.normal))) continue;
        worst = std::max(worst, std::abs(tab.bsdf(c, out) - a) / a);
    }
    std::cout << "[ BSDF     ] worst relative error within the lobe: " << worst << "\n";
    EXPECT_LT(worst, 0.03);
}

TEST(TabulatedBsdf, TransmissionTableFollowsTheRefractedDirection) {
    const OpticalProperty p = abgProperty();
    const TabulatedLobe bt = roundTrip(p, true, 5.0, 5.0, 0.5, 1.5);
    EXPECT_TRUE(bt.transmission());
    const OpticalProperty tab("tab", FresnelSpecular{},
                              TabulatedScatter(nullptr, std::make_shared<TabulatedLobe>(bt)));
    for (double i : {0.0, 25.0, 50.0, 70.0}) {
        const SurfaceContext c = contextOnZ(i, 1.5);
        const double abg = p.channels(c).scatterTransmit, t = tab.channels(c).scatterTransmit;
        EXPECT_NEAR(t, abg, 5e-3 * abg) << i;
        // Sampled directions leave on the far side, about the refracted ray.
        CounterRng rng(4, static_cast<uint64_t>(i));
        for (int n = 0; n < 200; ++n) {
            const ScatterSample s = tab.sampleScatter(c, true, rng.uniform(), rng.uniform());
            ASSERT_GT(s.pdf, 0.0);
            ASSERT_LT(s.direction.z, 0.0);
            ASSERT_NEAR(tab.bsdf(c, s.direction) * -s.direction.z / s.pdf, t, 1e-12);
        }
    }
}

TEST(TabulatedBsdf, TisTableMatchesDirectQuadrature) {
    const TabulatedLobe lobe = roundTrip(abgProperty(), false, 10.0, 10.0, 1.0);
    for (double i = 0.0; i <= 90.0; i += 3.7)
        EXPECT_NEAR(lobe.tis(i), lobe.tisExact(i), 1e-4 * lobe.tisExact(i) + 1e-9) << i;
}

// Chi-square of sampled (radial, azimuth) bins against the tabulated BSDF integrated by
// midpoint quadrature over each bin, and the channel fraction against that integral.
void tableChi2(const char* what, const OpticalProperty& tab, double incidenceDeg, uint64_t seed) {
    const SurfaceContext c = contextOnZ(incidenceDeg);
    const Vec3 s = reflect(c.direction, c.normal);
    Vec3 u = c.normal - glm::dot(c.normal, s) * s;
    u = glm::length(u) > 1e-9 ? glm::normalize(u) : Vec3(1, 0, 0);
    const Vec3 v = glm::cross(s, u);
    const std::vector<double> rEdges = {0, 2, 4, 6, 9, 13, 18, 25, 35, 50, 70, 100, 180};
    const int nphi = 8, nr = static_cast<int>(rEdges.size()) - 1;
    std::vector<double> prob(nr * nphi, 0.0);
    double total = 0.0;
    for (int a = 0; a < nr; ++a) {
        const int sub = 200;
        const double dr = deg(rEdges[a + 1] - rEdges[a]) / sub;
        for (int i = 0; i < sub; ++i) {
            const double r = deg(rEdges[a]) + (i + 0.5) * dr;
            for (int b = 0; b < nphi * 50; ++b) {
                const double dp = 2 * kPi / (nphi * 50);
                const double ph = (b + 0.5) * dp;
                const Vec3 out =
                    std::cos(r) * s + std::sin(r) * (std::cos(ph) * u + std::sin(ph) * v);
                const double cosO = out.z;
                if (cosO <= 0.0) continue;
                const double w = tab.bsdf(c, out) * cosO * std::sin(r) * dr * dp;
                prob[a * nphi + b / 50] += w;
                total += w;
            }
        }
    }
    EXPECT_NEAR(tab.channels(c).scatterReflect, total, 1e-3 * total) << what;
    for (double& x : prob) x /= total;
    std::vector<double> obs(prob.size(), 0.0);
    const int n = 100000;
    CounterRng rng(seed, 0);
    for (int k = 0; k < n; ++k) {
        const ScatterSample smp = tab.sampleScatter(c, false, rng.uniform(), rng.uniform());
        ASSERT_GT(smp.pdf, 0.0) << what;
        const double r = std::acos(std::clamp(glm::dot(smp.direction, s), -1.0, 1.0)) * 180.0 / kPi;
        double ph = std::atan2(glm::dot(smp.direction, v), glm::dot(smp.direction, u));
        if (ph < 0) ph += 2 * kPi;
        obs[binOf(rEdges, r) * nphi +
            std::min(nphi - 1, static_cast<int>(ph / (2 * kPi) * nphi))] += 1;
    }
    expectChi2(what, chiSquare(obs, prob, n));
}

TEST(TabulatedBsdf, SamplerPassesChiSquareAgainstTheTable) {
    const OpticalProperty tab("tab", FresnelSpecular{},
                              TabulatedScatter(std::make_shared<TabulatedLobe>(roundTrip(
                                                   abgProperty(), false, 10.0, 10.0, 1.0)),
                                               nullptr));
    tableChi2("table at a block, 0 deg", tab, 0.0, 801);
    tableChi2("table between blocks, 37 deg", tab, 37.0, 802);
    tableChi2("table near grazing, 82 deg", tab, 82.0, 803);
}

// A small plane-symmetric table built by hand.
ZemaxBsdf handTable(double value, double fileTis) {
    ZemaxBsdf d;
    d.source = "hand.bsdf";
    d.azimuthDeg = {0, 90, 180};
    d.radialDeg = {0, 30, 60};
    for (double i : {0.0, 45.0}) {
        ZemaxBsdfBlock b;
        b.incidenceDeg = i;
        b.fileTis = fileTis;
        b.values.assign(9, value);
        d.blocks.push_back(b);
    }
    return d;
}

TEST(TabulatedBsdf, ScalingToTheFileTisAndEnergyLimits) {
    // A constant BSDF out to 60 degrees from specular at normal incidence: TIS =
    // value * pi sin^2(60 deg).
    const TabulatedLobe plain(handTable(0.1, 0.5), false);
    EXPECT_NEAR(plain.tis(0.0), 0.1 * kPi * 0.75, 1e-6);
    const TabulatedLobe scaled(handTable(0.1, 0.5), true);
    EXPECT_TRUE(scaled.scaledToFileTis());
    EXPECT_NEAR(scaled.tis(0.0), 0.5, 1e-6);
    EXPECT_NEAR(scaled.tis(45.0), 0.5, 1e-6);
    EXPECT_NEAR(scaled.bsdf(0.0, 0.1, 1.0), 0.5 / (kPi * 0.75), 1e-6);
    try {
        TabulatedLobe tooBright(handTable(1.0, 0.5), false);
        FAIL() << "expected a ModelError";
    } catch (const ModelError& e) {
        EXPECT_EQ(e.object(), "hand.bsdf");
        EXPECT_THAT(e.what(), ::testing::HasSubstr("more than all of it"));
    }
    try {
        TabulatedLobe empty(handTable(0.0, 0.5), true);
        FAIL() << "expected a ModelError";
    } catch (const ModelError& e) {
        EXPECT_THAT(e.what(), ::testing::HasSubstr("cannot be scaled"));
    }
}

}  // namespace
}  // namespace veil
