// Philox 4x32-10 against the published known-answer vectors (Random123 kat_vectors), and the
// uniform() stream against a chi-square test of uniformity.

#include "tracer/runtime/rng.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace veil {
namespace {

TEST(CounterRng, PhiloxMatchesKnownAnswers) {
    // philox4x32 10 rounds: counter 0, key 0.
    auto r = CounterRng::philox({0, 0, 0, 0}, {0, 0});
    EXPECT_EQ(r[0], 0x6627e8d5u);
    EXPECT_EQ(r[1], 0xe169c58du);
    EXPECT_EQ(r[2], 0xbc57ac4cu);
    EXPECT_EQ(r[3], 0x9b00dbd8u);
    // counter all ones, key all ones.
    r = CounterRng::philox({0xffffffffu, 0xffffffffu, 0xffffffffu, 0xffffffffu},
                           {0xffffffffu, 0xffffffffu});
    EXPECT_EQ(r[0], 0x408f276du);
    EXPECT_EQ(r[1], 0x41c83b0eu);
    EXPECT_EQ(r[2], 0xa20bc7c6u);
    EXPECT_EQ(r[3], 0x6d5451fdu);
    // The pi digits vector.
    r = CounterRng::philox({0x243f6a88u, 0x85a308d3u, 0x13198a2eu, 0x03707344u},
                           {0xa4093822u, 0x299f31d0u});
    EXPECT_EQ(r[0], 0xd16cfe09u);
    EXPECT_EQ(r[1], 0x94fdccebu);
    EXPECT_EQ(r[2], 0x5001e420u);
    EXPECT_EQ(r[3], 0x24126ea1u);
}

TEST(CounterRng, UniformPassesChiSquare) {
    // 100 bins, 1e6 draws over 1000 streams: chi-square with 99 degrees of freedom has mean 99
    // and standard deviation 14; 99 + 5 sigma = 169.
    std::vector<int> bins(100, 0);
    int n = 0;
    for (uint64_t s = 0; s < 1000; ++s) {
        CounterRng rng(42, s);
        for (int i = 0; i < 1000; ++i, ++n) {
            const double u = rng.uniform();
            ASSERT_GE(u, 0.0);
            ASSERT_LT(u, 1.0);
            ++bins[static_cast<int>(u * 100)];
        }
    }
    double chi2 = 0.0;
    const double expected = n / 100.0;
    for (int b : bins) chi2 += (b - expected) * (b - expected) / expected;
    EXPECT_LT(chi2, 169.0);
    EXPECT_GT(chi2, 40.0);  // not suspiciously flat either (99 - 4 sigma)
}

TEST(CounterRng, StreamsAreReproducibleAndDistinct) {
    CounterRng a(7, 12345), b(7, 12345), c(7, 12346), d(8, 12345);
    for (int i = 0; i < 10; ++i) {
        const double x = a.uniform();
        EXPECT_EQ(x, b.uniform());
        EXPECT_NE(x, c.uniform());
        EXPECT_NE(x, d.uniform());
    }
}

}  // namespace
}  // namespace veil
