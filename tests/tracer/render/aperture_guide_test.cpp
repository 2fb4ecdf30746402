// The aperture guide (tracer/render/aperture_guide.h) against its definition: the warp draws each
// cell with the mixture's probability (chi-square), its density is that of the points it
// makes, weighting by 1 / density keeps any integral unbiased, and nothing learned (or a
// fraction of 0) leaves the uniforms as they are.

#include "tracer/render/aperture_guide.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "tracer/runtime/rng.h"

namespace veil {
namespace {

constexpr int kCells = ApertureGuide::kCellCount;
constexpr int kSide = ApertureGuide::kCells;
constexpr int kBlock = ApertureGuide::kBlockPixels;

// A guide for a detector of 2 x 1 blocks that learned light in block 0 only: most in cell
// 9, some in cell 62.
ApertureGuide learnedGuide(double g) {
    ApertureGuide guide(2 * kBlock, kBlock);
    std::vector<double> learned(guide.bins(), 0.0);
    learned[guide.bin(0, 9)] = 3.0;
    learned[guide.bin(0, 62)] = 1.0;
    guide.prepare(learned, g);
    return guide;
}

TEST(ApertureGuide, BinsByPixelBlockAndCell) {
    const ApertureGuide guide(2 * kBlock, kBlock + 1);  // 2 x 2 blocks, the last row partial
    EXPECT_EQ(guide.bins(), size_t{4} * kCells);
    EXPECT_EQ(guide.bin(kBlock - 1, 5), size_t{5});       // pixel (kBlock - 1, 0): block 0
    EXPECT_EQ(guide.bin(kBlock, 5), size_t{kCells + 5});  // pixel (kBlock, 0): block 1
    EXPECT_EQ(guide.bin(2 * kBlock * kBlock + kBlock, 0),
              size_t{3 * kCells});  // pixel (kBlock, kBlock): block 3
    EXPECT_EQ(ApertureGuide::cellOf(0.0, 0.0), 0);
    EXPECT_EQ(ApertureGuide::cellOf(0.999, 0.0), kSide - 1);
    EXPECT_EQ(ApertureGuide::cellOf(0.0, 0.999), kCells - kSide);
    EXPECT_EQ(ApertureGuide::cellOf(1.0, 1.0), kCells - 1);  // clamped
}

TEST(ApertureGuide, NothingLearnedOrNoFractionIsTheIdentity) {
    for (const double g : {0.0, 0.5}) {
        ApertureGuide guide(2 * kBlock, kBlock);
        std::vector<double> learned(guide.bins(), 0.0);
        if (g == 0.0) learned[3] = 1.0;  // learned, but not used
        guide.prepare(learned, g);
        CounterRng rng(7, 0);
        for (int i = 0; i < 1000; ++i) {
            const double u = rng.uniform(), v = rng.uniform();
            const ApertureGuide::Warped w = guide.warp(i % (2 * kBlock * kBlock), u, v);
            EXPECT_EQ(w.u, u);
            EXPECT_EQ(w.v, v);
            EXPECT_EQ(w.density, 1.0);
            EXPECT_EQ(w.cell, ApertureGuide::cellOf(u, v));
        }
    }
    // Block 1 of the learned guide learned nothing: the identity there too.
    const ApertureGuide guide = learnedGuide(0.5);
    const ApertureGuide::Warped w = guide.warp(kBlock, 0.3, 0.7);
    EXPECT_EQ(w.u, 0.3);
    EXPECT_EQ(w.density, 1.0);
}

TEST(ApertureGuide, DrawsEachCellWithTheMixturesProbability) {
    const double g = 0.6;
    const ApertureGuide guide = learnedGuide(g);
    const int n = 200000;
    std::vector<double> counts(kCells, 0.0);
    double uIn9 = 0.0, vIn9 = 0.0;
    CounterRng rng(11, 0);
    for (int i = 0; i < n; ++i) {
        const ApertureGuide::Warped w = guide.warp(0, rng.uniform(), rng.uniform());
        ASSERT_GE(w.u, 0.0);
        ASSERT_LT(w.u, 1.0);
        ASSERT_GE(w.v, 0.0);
        ASSERT_LT(w.v, 1.0);
        ASSERT_EQ(w.cell, ApertureGuide::cellOf(w.u, w.v));
        ASSERT_EQ(w.density, guide.density(0, w.u, w.v));
        counts[static_cast<size_t>(w.cell)] += 1.0;
        if (w.cell == 9) {
            uIn9 += w.u;
            vIn9 += w.v;
        }
    }
    double chi2 = 0.0, total = 0.0;
    for (int c = 0; c < kCells; ++c) {
        const double learned = c == 9 ? 3.0 : c == 62 ? 1.0 : 0.0;
        const double p = (1.0 - g) / kCells + g * learned / 4.0;
        EXPECT_NEAR(guide.density(0, (c % kSide + 0.5) / kSide, (c / kSide + 0.5) / kSide),
                    p * kCells, 1e-12);
        total += p;
        chi2 += (counts[c] - n * p) * (counts[c] - n * p) / (n * p);
    }
    EXPECT_NEAR(total, 1.0, 1e-12);
    // kCells - 1 degrees of freedom: mean k, standard deviation sqrt(2 k); 5 of them above
    // the mean is beyond the 1e-4 upper quantile.
    const double dof = kCells - 1;
    EXPECT_LT(chi2, dof + 5.0 * std::sqrt(2.0 * dof)) << "chi-square " << chi2;
    // Within a cell the points stay uniform: their mean in cell 9 is the cell's centre,
    // within 4 standard errors (side 1/kSide: sigma = 1 / (kSide sqrt(12 count))).
    const double se = 1.0 / (kSide * std::sqrt(12.0 * counts[9]));
    EXPECT_NEAR(uIn9 / counts[9], (9 % kSide + 0.5) / kSide, 4.0 * se);
    EXPECT_NEAR(vIn9 / counts[9], (9 / kSide + 0.5) / kSide, 4.0 * se);
}

TEST(ApertureGuide, WeightingByTheDensityKeepsIntegralsUnbiased) {
    // f(u, v) = 1 on a small square that straddles learned and unlearned cells, 0 elsewhere;
    // its integral is the square's area. The estimate mean f / density over stratified
    // points, with its standard error, must find it.
    const ApertureGuide guide = learnedGuide(0.8);
    const double u0 = 9.0 / kSide - 0.1, u1 = 10.0 / kSide + 0.07, v0 = 0.0, v1 = 0.2;
    auto f = [&](double u, double v) { return u >= u0 && u < u1 && v >= v0 && v < v1 ? 1.0 : 0.0; };
    const int m = 400;  // m x m strata
    CounterRng rng(3, 0);
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < m * m; ++i) {
        const double u = (i % m + rng.uniform()) / m, v = (i / m + rng.uniform()) / m;
        const ApertureGuide::Warped w = guide.warp(0, u, v);
        const double x = f(w.u, w.v) / w.density;
        sum += x;
        sum2 += x * x;
    }
    const double n = m * m;
    const double mean = sum / n;
    const double sigma = std::sqrt((sum2 / n - mean * mean) / n);  // >= the stratified one
    const double exact = (u1 - u0) * (v1 - v0);
    EXPECT_NEAR(mean, exact, 4.0 * sigma) << "sigma " << sigma;
    EXPECT_LT(sigma, 0.03 * exact);  // a test that can miss
}

TEST(ApertureGuide, RejectsBadInput) {
    ApertureGuide guide(2 * kBlock, kBlock);
    EXPECT_THROW(guide.prepare(std::vector<double>(guide.bins(), 0.0), 1.0), std::invalid_argument);
    EXPECT_THROW(guide.prepare(std::vector<double>(guide.bins(), 0.0), -0.1),
                 std::invalid_argument);
    EXPECT_THROW(guide.prepare(std::vector<double>(3, 0.0), 0.5), std::invalid_argument);
    EXPECT_THROW(ApertureGuide(0, 8), std::invalid_argument);
}

}  // namespace
}  // namespace veil
