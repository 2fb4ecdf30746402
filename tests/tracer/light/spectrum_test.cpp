// Photopic V(lambda) against the CIE table, and spectral sampling over the system wavelengths
// (chi-square on the drawn lines, fixed seeds, mean + 5 sigma thresholds).

#include "tracer/light/spectrum.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tracer/runtime/rng.h"

namespace veil {
namespace {

// CIE 1924 photopic V(lambda) at 5 nm steps as published (CIE 018:2019 Table 1; the same
// numbers as the y-bar column of the CIE 1931 observer in CIE 15:2004).
struct TableValue {
    double nm, v;
};
constexpr TableValue kCie1924[] = {
    {360, 0.000003917}, {380, 0.000039},   {400, 0.000396},     {420, 0.004},
    {440, 0.023},       {450, 0.038},      {460, 0.06},         {470, 0.09098},
    {480, 0.13902},     {490, 0.20802},    {500, 0.323},        {505, 0.4073},
    {510, 0.503},       {520, 0.71},       {530, 0.862},        {535, 0.9148501},
    {540, 0.954},       {545, 0.9803},     {550, 0.9949501},    {555, 1.0},
    {560, 0.995},       {570, 0.952},      {580, 0.87},         {590, 0.757},
    {600, 0.631},       {610, 0.503},      {620, 0.381},        {630, 0.265},
    {640, 0.175},       {650, 0.107},      {660, 0.061},        {670, 0.032},
    {680, 0.017},       {690, 0.00821},    {700, 0.004102},     {720, 0.001047},
    {750, 0.00012},     {780, 0.00001499}, {800, 0.0000037029}, {830, 0.00000045181},
};

TEST(PhotopicEfficiency, EqualsOneAt555Nm) { EXPECT_EQ(photopicEfficiency(555.0), 1.0); }

TEST(PhotopicEfficiency, MatchesThePublishedCieTable) {
    for (const TableValue& t : kCie1924)
        EXPECT_NEAR(photopicEfficiency(t.nm), t.v, 1e-12 * std::max(1.0, t.v)) << t.nm << " nm";
    // 1 nm entries of the CIE table between the 5 nm values (CIE 15:2004 Table T.4).
    EXPECT_NEAR(photopicEfficiency(507.0), 0.4443096, 1e-12);
    EXPECT_NEAR(photopicEfficiency(547.0), 0.9874182, 1e-12);
    EXPECT_NEAR(photopicEfficiency(556.0), 0.9998567, 1e-12);
    EXPECT_NEAR(photopicEfficiency(587.0), 0.793082, 1e-12);
}

TEST(PhotopicEfficiency, InterpolatesLinearlyAndIsZeroOutsideTheTable) {
    EXPECT_DOUBLE_EQ(photopicEfficiency(555.5), 0.5 * (1.0 + 0.9998567));
    EXPECT_DOUBLE_EQ(photopicEfficiency(500.25), 0.75 * 0.323 + 0.25 * 0.3384021);
    EXPECT_EQ(photopicEfficiency(359.999), 0.0);
    EXPECT_EQ(photopicEfficiency(830.001), 0.0);
    EXPECT_EQ(photopicEfficiency(1064.0), 0.0);
    EXPECT_EQ(photopicEfficiency(std::nan("")), 0.0);
    EXPECT_NEAR(photopicEfficiency(830.0), 0.00000045181, 1e-18);
    // The d line: between 587 and 588 nm.
    EXPECT_NEAR(photopicEfficiency(587.5618), 0.793082 + 0.5618 * (0.781192 - 0.793082), 1e-12);
}

// A checksum of the whole table against a transcription error anywhere: the sum of the 1 nm
// values, 360-830 nm, is the normalisation integral of the CIE 1931 Y function,
// 106.856895 nm (one digit swapped at 547 nm would move it by 6e-5).
TEST(PhotopicEfficiency, OneNanometreSumIsTheCieIntegral) {
    double sum = 0.0;
    for (int nm = 360; nm <= 830; ++nm) sum += photopicEfficiency(nm);
    EXPECT_NEAR(sum, 106.856895, 5e-5);
}

TEST(PhotopicEfficiency, PeaksAt555AndIsUnimodal) {
    double best = 0.0, bestNm = 0.0;
    for (double nm = 360.0; nm <= 830.0; nm += 0.1) {
        const double v = photopicEfficiency(nm);
        if (v > best) best = v, bestNm = nm;
    }
    EXPECT_NEAR(bestNm, 555.0, 0.05);
    for (int nm = 360; nm < 555; ++nm)
        EXPECT_LT(photopicEfficiency(nm), photopicEfficiency(nm + 1));
    for (int nm = 555; nm < 830; ++nm)
        EXPECT_GT(photopicEfficiency(nm), photopicEfficiency(nm + 1));
}

TEST(PhotopicEfficiency, LuminousEfficacyIsKmTimesV) {
    EXPECT_DOUBLE_EQ(luminousEfficacyLmPerW(555.0), 683.0);
    EXPECT_DOUBLE_EQ(luminousEfficacyLmPerW(650.0), 683.0 * 0.107);
}

// Spectral Sampler

// Draws n lines with one counter-based stream and tests their frequencies against p with
// Pearson's chi-square at mean + 5 sigma.
struct Draws {
    std::vector<int64_t> counts;
    std::vector<double> weightSum;  // per line
    int64_t n = 0;
};
Draws draw(const SpectralSampler& s, int64_t n, uint64_t seed = 7) {
    Draws d{std::vector<int64_t>(s.size(), 0), std::vector<double>(s.size(), 0.0), n};
    CounterRng rng(seed, 0);
    for (int64_t i = 0; i < n; ++i) {
        const SpectralSampler::Sample x = s.sample(rng.uniform());
        ++d.counts[x.index];
        d.weightSum[x.index] += x.weight;
        EXPECT_EQ(x.wavelengthNm, s.lines()[x.index].nm);
    }
    return d;
}
double chiSquare(const Draws& d, const std::vector<double>& p, int* dof) {
    double chi = 0.0;
    *dof = -1;
    for (size_t i = 0; i < p.size(); ++i) {
        const double e = p[i] * d.n;
        if (e == 0.0) {
            EXPECT_EQ(d.counts[i], 0) << "line " << i << " has probability 0";
            continue;
        }
        chi += (d.counts[i] - e) * (d.counts[i] - e) / e;
        ++*dof;
    }
    return chi;
}
void expectFrequencies(const Draws& d, const std::vector<double>& p) {
    int dof = 0;
    const double chi = chiSquare(d, p, &dof);
    EXPECT_LT(chi, dof + 5.0 * std::sqrt(2.0 * dof)) << "dof " << dof;
}

const std::vector<Wavelength> kLines = {
    {486.1327, 1.0}, {587.5618, 2.0}, {656.2725, 0.5}, {900.0, 1.0}, {435.8343, 0.25}};

std::vector<double> normalized(std::vector<double> x) {
    double s = 0.0;
    for (double v : x) s += v;
    for (double& v : x) v /= s;
    return x;
}

TEST(SpectralSampler, RadiometricFrequenciesFollowTheWeights) {
    const SpectralSampler s(kLines, FluxUnit::Watt);
    EXPECT_EQ(s.sampling(), SpectralSampling::Radiometric);
    const std::vector<double> p = normalized({1.0, 2.0, 0.5, 1.0, 0.25});
    for (int i = 0; i < s.size(); ++i) {
        EXPECT_NEAR(s.probability(i), p[i], 1e-15);
        EXPECT_DOUBLE_EQ(s.weight(i), 1.0);
    }
    const Draws d = draw(s, 200000);
    expectFrequencies(d, p);
}

TEST(SpectralSampler, PhotometricFrequenciesFollowWeightTimesV) {
    const SpectralSampler s(kLines, FluxUnit::Lumen);
    EXPECT_EQ(s.sampling(), SpectralSampling::Photometric);
    std::vector<double> wv;
    for (const Wavelength& w : kLines) wv.push_back(w.weight * photopicEfficiency(w.nm));
    const std::vector<double> p = normalized(wv);
    EXPECT_EQ(s.probability(3), 0.0);  // 900 nm: the eye does not see it, no lumen is spent
    for (int i = 0; i < s.size(); ++i) {
        EXPECT_NEAR(s.probability(i), p[i], 1e-15);
        if (p[i] > 0.0) {
            EXPECT_NEAR(s.weight(i), 1.0, 1e-15);
        }
    }
    const Draws d = draw(s, 200000);
    expectFrequencies(d, p);
}

// The chi-square test has the power to reject: radiometric draws are not photometric.
TEST(SpectralSampler, ChiSquareRejectsTheOtherDistribution) {
    const SpectralSampler s(kLines, FluxUnit::Watt);
    std::vector<double> wv;
    for (const Wavelength& w : kLines) wv.push_back(w.weight * photopicEfficiency(w.nm));
    std::vector<double> p = normalized(wv);
    const Draws d = draw(s, 200000);
    int dof = 0;
    // Restrict to the visible lines, where both hypotheses give probabilities.
    Draws visible = d;
    visible.counts[3] = 0;
    visible.n -= d.counts[3];
    EXPECT_GT(chiSquare(visible, p, &dof), 100.0 * (dof + 5.0 * std::sqrt(2.0 * dof)));
}

// Mixed: a lumen budget drawn radiometrically. Weights share / p keep the lumen estimate
// unbiased: the mean weight of rays on line i, times its frequency, is its lumen share.
TEST(SpectralSampler, MixedSamplingIsUnbiased) {
    const SpectralSampler s(kLines, FluxUnit::Lumen, SpectralSampling::Radiometric);
    EXPECT_EQ(s.probability(3), 0.0);  // no lumen at 900 nm: not drawn
    const int64_t n = 400000;
    const Draws d = draw(s, n, 11);
    double total = 0.0;
    for (int i = 0; i < s.size(); ++i) {
        total += d.weightSum[i];
        // Per line: the estimate weightSum / n of share_i is binomial, with sigma
        // weight sqrt(p (1 - p) / n).
        const double p = s.probability(i);
        const double sigma = s.weight(i) * std::sqrt(p * (1.0 - p) / n);
        EXPECT_NEAR(d.weightSum[i] / n, s.share(i), 5.0 * sigma + 1e-15) << "line " << i;
    }
    // Summed over lines the weights have mean 1 with variance sum p w^2 - 1.
    double var = -1.0;
    for (int i = 0; i < s.size(); ++i) var += s.probability(i) * s.weight(i) * s.weight(i);
    EXPECT_NEAR(total / n, 1.0, 5.0 * std::sqrt(var / n));
    EXPECT_GT(var, 0.01);  // the weights really differ from 1 here
}

TEST(SpectralSampler, ZeroWeightLinesAreNeverDrawn) {
    const SpectralSampler s({{500.0, 0.0}, {550.0, 1.0}, {600.0, 0.0}}, FluxUnit::Watt);
    EXPECT_EQ(s.sample(0.0).index, 1);
    EXPECT_EQ(s.sample(0.999999999).index, 1);
    EXPECT_EQ(s.sample(std::nextafter(1.0, 0.0)).index, 1);
    const SpectralSampler t({{500.0, 1.0}, {550.0, 1.0}, {600.0, 0.0}}, FluxUnit::Watt);
    EXPECT_EQ(t.sample(0.0).index, 0);
    EXPECT_EQ(t.sample(0.4999).index, 0);
    EXPECT_EQ(t.sample(0.5).index, 1);
    EXPECT_EQ(t.sample(std::nextafter(1.0, 0.0)).index, 1);
}

TEST(SpectralSampler, LuminousEfficacyOfTheSpectrum) {
    EXPECT_DOUBLE_EQ(SpectralSampler({{555.0, 3.0}}, FluxUnit::Watt).luminousEfficacyLmPerW(),
                     683.0);
    const SpectralSampler s({{555.0, 1.0}, {650.0, 1.0}, {1000.0, 2.0}}, FluxUnit::Watt);
    EXPECT_DOUBLE_EQ(s.luminousEfficacyLmPerW(), 683.0 * (1.0 + 0.107) / 4.0);
}

TEST(SpectralSampler, RefusesSpectraThatCannotBeSampled) {
    EXPECT_THROW(SpectralSampler({}, FluxUnit::Watt), ModelError);
    EXPECT_THROW(SpectralSampler({{550.0, -1.0}}, FluxUnit::Watt), ModelError);
    EXPECT_THROW(SpectralSampler({{550.0, 0.0}, {600.0, 0.0}}, FluxUnit::Watt), ModelError);
    // Lumens from infrared lines only.
    EXPECT_THROW(SpectralSampler({{900.0, 1.0}, {1064.0, 1.0}}, FluxUnit::Lumen), ModelError);
    // Photometric sampling of watts would never draw 900 nm, which carries watts: biased.
    EXPECT_THROW(SpectralSampler(kLines, FluxUnit::Watt, SpectralSampling::Photometric),
                 ModelError);
    try {
        SpectralSampler({{900.0, 1.0}}, FluxUnit::Lumen, "source 'lamp'");
        FAIL();
    } catch (const ModelError& e) {
        EXPECT_EQ(e.object(), "source 'lamp'");
    }
}

}  // namespace
}  // namespace veil
