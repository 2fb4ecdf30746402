// Ranks (tracer/runtime/ranks.h) in one process: the byte messages ranks exchange read back exactly
// and refuse to read past their end, a group of one needs no MPI, and the ordered blocks on
// a group of one are forBlocksInOrder's. (Several ranks: tests/cli/mpi_test.cpp under mpirun.)

#include "tracer/runtime/ranks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "tracer/runtime/ordered_blocks.h"

namespace veil {
namespace {

struct Pod {
    int a;
    double b;
    bool c;
};

TEST(Ranks, BytesReadBackExactly) {
    ByteWriter w;
    w.put(uint64_t{0xfedcba9876543210ull});
    w.put(std::numeric_limits<double>::denorm_min());
    w.putVector(std::vector<double>{1.0 / 3.0, -0.0, std::nan(""), 1e308});
    w.putVector(std::vector<Pod>{{1, 2.5, true}, {-7, -1e-300, false}});
    w.putVector(std::vector<uint8_t>{});
    w.putString("rank 0 \xce\xbb");
    const Bytes bytes = w.take();
    ByteReader r(bytes);
    EXPECT_EQ(r.get<uint64_t>(), 0xfedcba9876543210ull);
    EXPECT_EQ(r.get<double>(), std::numeric_limits<double>::denorm_min());
    const auto d = r.getVector<double>();
    ASSERT_EQ(d.size(), 4u);
    EXPECT_EQ(d[0], 1.0 / 3.0);
    EXPECT_TRUE(std::signbit(d[1]));
    EXPECT_TRUE(std::isnan(d[2]));
    EXPECT_EQ(d[3], 1e308);
    const auto p = r.getVector<Pod>();
    ASSERT_EQ(p.size(), 2u);
    EXPECT_EQ(p[1].a, -7);
    EXPECT_EQ(p[1].b, -1e-300);
    EXPECT_FALSE(p[1].c);
    EXPECT_TRUE(r.getVector<uint8_t>().empty());
    EXPECT_EQ(r.getString(), "rank 0 \xce\xbb");
    EXPECT_TRUE(r.done());
    EXPECT_THROW(r.get<int>(), std::runtime_error);
}

TEST(Ranks, ATruncatedMessageIsRefused) {
    ByteWriter w;
    w.putVector(std::vector<double>(10, 1.0));
    Bytes bytes = w.take();
    bytes.resize(bytes.size() - 1);
    ByteReader r(bytes);
    EXPECT_THROW(r.getVector<double>(), std::runtime_error);
    // A length that claims more than the message holds.
    ByteWriter big;
    big.put(uint64_t{1} << 60);
    const Bytes lie = big.take();
    ByteReader l(lie);
    EXPECT_THROW(l.getVector<double>(), std::runtime_error);
}

TEST(Ranks, AloneIsOneRankThatOwnsEverything) {
    const Ranks a = Ranks::alone();
    EXPECT_EQ(a.rank(), 0);
    EXPECT_EQ(a.size(), 1);
    EXPECT_TRUE(a.root());
    for (uint64_t i : {0ull, 1ull, 12345ull}) EXPECT_TRUE(a.owns(i));
    Bytes b{std::byte{1}, std::byte{2}};
    a.broadcast(b);
    EXPECT_EQ(b.size(), 2u);
    EXPECT_EQ(a.gatherAll(b).size(), 1u);
    EXPECT_TRUE(a.broadcastFlag(true));
    // This test program was not started by mpirun.
    EXPECT_TRUE(Ranks::world().single());
    EXPECT_EQ(rankTraffic().sent + rankTraffic().received, 0u);
}

TEST(Ranks, OrderedBlocksAloneAreForBlocksInOrder) {
    // Sums of terms whose order matters in floating point: the same bits either way.
    auto term = [](uint64_t i) { return 1.0 / (1.0 + static_cast<double>(i * i % 977)); };
    double plain = 0.0, ranked = 0.0;
    auto produce = [&](uint64_t first, uint64_t last) {
        std::vector<double> v;
        for (uint64_t i = first; i < last; ++i) v.push_back(term(i));
        return v;
    };
    forBlocksInOrder(10007, 37, produce, [&](const std::vector<double>& v) {
        for (double x : v) plain += x;
    });
    forBlocksInOrderOnRanks(
        Ranks::alone(), 10007, 37, produce,
        [&](const std::vector<double>& v) {
            for (double x : v) ranked += x;
        },
        [](const std::vector<double>&) -> Bytes { throw std::logic_error("packed alone"); },
        [](const Bytes&) -> std::vector<double> { throw std::logic_error("unpacked alone"); });
    EXPECT_EQ(plain, ranked);
    double reference = 0.0;
    for (uint64_t i = 0; i < 10007; ++i) reference += term(i);
    EXPECT_EQ(plain, reference);
}

}  // namespace
}  // namespace veil
