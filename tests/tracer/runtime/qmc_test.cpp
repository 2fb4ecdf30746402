// Owen-scrambled Sobol points (tracer/runtime/qmc.h) against what Sobol's construction guarantees
// and what the scrambling must keep: the (t, m, s)-net property of every projection with t = sum of
// (degree - 1) of its primitive polynomials, each point uniform over the scrambles, and randomized
// quasi-Monte Carlo estimates that are unbiased with far less variance than independent points
// give.

#include "tracer/runtime/qmc.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <vector>

#include "tracer/runtime/rng.h"

namespace veil {
namespace {

// Degrees of the primitive polynomials of dimensions 0..4 (x, x+1, x^2+x+1, x^3+x+1,
// x^3+x^2+1).
constexpr int kDegree[SobolOwen::kDimensions] = {1, 1, 2, 3, 3};

using Coordinate = std::function<uint32_t(uint64_t index, int dimension)>;

// Whether the first 2^m points, in the given dimensions, put exactly 2^t points in every
// elementary box of volume 2^(t-m) (the (t, m, s)-net property): every split of m - t bits
// among the dimensions.
bool isNet(const Coordinate& x, const std::vector<int>& dims, int m, int t) {
    const int s = static_cast<int>(dims.size());
    const uint64_t n = uint64_t{1} << m;
    std::vector<int> bits(static_cast<size_t>(s), 0);
    bool ok = true;
    std::function<void(int, int)> each = [&](int d, int left) {
        if (!ok) return;
        if (d == s - 1) {
            bits[static_cast<size_t>(d)] = left;
            std::vector<uint32_t> count(uint64_t{1} << (m - t), 0);
            for (uint64_t i = 0; i < n; ++i) {
                uint64_t box = 0;
                for (int a = 0; a < s; ++a) {
                    const int b = bits[static_cast<size_t>(a)];
                    box =
                        (box << b) | (b == 0 ? 0 : x(i, dims[static_cast<size_t>(a)]) >> (32 - b));
                }
                ++count[box];
            }
            for (uint32_t c : count) ok = ok && c == (1u << t);
            return;
        }
        for (int b = 0; b <= left; ++b) {
            bits[static_cast<size_t>(d)] = b;
            each(d + 1, left - b);
        }
    };
    each(0, m - t);
    return ok;
}

uint32_t scrambledBits(const SobolOwen& q, uint64_t i, int d) {
    return static_cast<uint32_t>(q.sample(i, d) * 0x1.0p32);
}

TEST(SobolOwen, EveryProjectionIsANetWithSobolsT) {
    const Coordinate plain = [](uint64_t i, int d) { return SobolOwen::sobol32(i, d); };
    const SobolOwen a(7), b(123456789);
    const Coordinate scrambledA = [&](uint64_t i, int d) { return scrambledBits(a, i, d); };
    const Coordinate scrambledB = [&](uint64_t i, int d) { return scrambledBits(b, i, d); };
    for (const Coordinate* x : {&plain, &scrambledA, &scrambledB}) {
        for (int d = 0; d < SobolOwen::kDimensions; ++d)
            EXPECT_TRUE(isNet(*x, {d}, 12, 0)) << "dimension " << d;
        for (int d = 0; d < SobolOwen::kDimensions; ++d)
            for (int e = d + 1; e < SobolOwen::kDimensions; ++e) {
                const int t = kDegree[d] - 1 + kDegree[e] - 1;
                EXPECT_TRUE(isNet(*x, {d, e}, 12, t)) << "dimensions " << d << ", " << e;
            }
        EXPECT_TRUE(isNet(*x, {0, 1, 2, 3, 4}, 12, 5));
    }
    // The smallest t of each pair and of all five at m = 12: Joe and Kuo chose their direction
    // numbers for small two-dimensional t, below the general bound (a wrong direction number
    // changes these).
    const int pairT[] = {0, 1, 1, 2, 1, 2, 2, 2, 2, 2};
    int k = 0;
    auto smallestT = [&](const std::vector<int>& dims) {
        int t = 0;
        while (!isNet(plain, dims, 12, t)) ++t;
        return t;
    };
    for (int d = 0; d < SobolOwen::kDimensions; ++d)
        for (int e = d + 1; e < SobolOwen::kDimensions; ++e)
            EXPECT_EQ(smallestT({d, e}), pairT[k++]) << "dimensions " << d << ", " << e;
    EXPECT_EQ(smallestT({0, 1, 2, 3, 4}), 4);
}

TEST(SobolOwen, EachPointIsUniformOverTheScrambles) {
    // Chi-square over 32 bins of one point's coordinate under 8192 scrambles: 31 degrees of
    // freedom, 99.99 % quantile 67.
    const int bins = 32, seeds = 8192;
    for (uint64_t index : {0ull, 1ull, 5ull, 1000ull})
        for (int d = 0; d < SobolOwen::kDimensions; ++d) {
            std::vector<int> count(bins, 0);
            for (int s = 0; s < seeds; ++s) {
                const double u =
                    SobolOwen(static_cast<uint64_t>(s) * 2654435761ull + 17).sample(index, d);
                ASSERT_GE(u, 0.0);
                ASSERT_LT(u, 1.0);
                ++count[static_cast<size_t>(u * bins)];
            }
            double chi2 = 0.0;
            const double expected = double(seeds) / bins;
            for (int c : count) chi2 += (c - expected) * (c - expected) / expected;
            EXPECT_LT(chi2, 67.0) << "index " << index << " dimension " << d;
        }
}

// Mean and variance of an estimate of the integral of f over [0,1)^5 with n points, over
// `runs` independent scrambles (quasi-random) or independent random streams.
std::pair<double, double> estimates(const std::function<double(const double*)>& f, int n, int runs,
                                    bool quasi) {
    double s1 = 0.0, s2 = 0.0;
    for (int r = 0; r < runs; ++r) {
        const SobolOwen q(1000 + static_cast<uint64_t>(r));
        double sum = 0.0;
        for (int i = 0; i < n; ++i) {
            double u[SobolOwen::kDimensions];
            CounterRng rng(99, static_cast<uint64_t>(r) * 1000003ull + static_cast<uint64_t>(i));
            for (int d = 0; d < SobolOwen::kDimensions; ++d)
                u[d] = quasi ? q.sample(static_cast<uint64_t>(i), d) : rng.uniform();
            sum += f(u);
        }
        const double e = sum / n;
        s1 += e;
        s2 += e * e;
    }
    const double mean = s1 / runs;
    return {mean, (s2 - runs * mean * mean) / (runs - 1)};
}

TEST(SobolOwen, ScrambledEstimatesAreUnbiasedAndFarLessNoisy) {
    const int n = 4096, runs = 64;
    // A disk of radius 0.3 in dimensions 0 and 1 (an edge, like a ghost image's rim), and a
    // smooth product over all five.
    const double disk = std::numbers::pi * 0.09;
    auto inDisk = [](const double* u) {
        const double x = u[0] - 0.5, y = u[1] - 0.5;
        return x * x + y * y < 0.09 ? 1.0 : 0.0;
    };
    auto product = [](const double* u) {
        double p = 1.0;
        for (int d = 0; d < SobolOwen::kDimensions; ++d) p *= 1.0 + std::sin(6.0 * u[d]);
        return p;
    };
    double exact = 1.0;
    for (int d = 0; d < SobolOwen::kDimensions; ++d) exact *= 1.0 + (1.0 - std::cos(6.0)) / 6.0;
    for (auto [f, truth] : {std::pair<std::function<double(const double*)>, double>{inDisk, disk},
                            {product, exact}}) {
        const auto [qMean, qVar] = estimates(f, n, runs, true);
        const auto [rMean, rVar] = estimates(f, n, runs, false);
        EXPECT_LT(std::abs(qMean - truth), 4.0 * std::sqrt(qVar / runs) + 1e-12);
        EXPECT_LT(std::abs(rMean - truth), 4.0 * std::sqrt(rVar / runs));
        // Independent points: variance sigma^2 / n; the scrambled net's is far below it.
        EXPECT_LT(qVar, 0.05 * rVar) << "truth " << truth;
    }
}

}  // namespace
}  // namespace veil
