#pragma once
// Counter-based random numbers: Philox 4x32-10 (Salmon et al., "Parallel random numbers: as
// easy as 1, 2, 3", SC 2011). A stream is keyed by (run seed, ray index), so every ray draws
// the same numbers whichever thread traces it, in whatever order: images are bitwise the same
// for any thread count.

#include <array>
#include <cstdint>

namespace veil {

class CounterRng {
  public:
    CounterRng(uint64_t seed, uint64_t stream) : key_{uint32_t(seed), uint32_t(seed >> 32)} {
        counter_ = {0u, 0u, uint32_t(stream), uint32_t(stream >> 32)};
    }

    // Uniform in [0, 1) with 53 random bits.
    double uniform() {
        const uint64_t hi = next32(), lo = next32();
        return static_cast<double>(((hi << 32) | lo) >> 11) * 0x1.0p-53;
    }
    uint32_t next32() {
        if (index_ == 4) {
            block_ = philox(counter_, key_);
            if (++counter_[0] == 0) ++counter_[1];
            index_ = 0;
        }
        return block_[index_++];
    }

    // A stream of its own, keyed by this one's next 64 bits (this one advances by those alone,
    // whatever the fork then draws): work that may be skipped (a photon's lobe splats in a later
    // tile of a render pass) leaves the draws after it unchanged.
    CounterRng fork() {
        const uint64_t hi = next32(), lo = next32();
        return CounterRng((hi << 32) | lo, 0x666f726bull /* "fork" */);
    }

    // One Philox 4x32 block: 10 rounds of the bijection on the counter under the key.
    static std::array<uint32_t, 4> philox(std::array<uint32_t, 4> c, std::array<uint32_t, 2> k) {
        constexpr uint32_t kM0 = 0xD2511F53u, kM1 = 0xCD9E8D57u;
        constexpr uint32_t kW0 = 0x9E3779B9u, kW1 = 0xBB67AE85u;
        for (int round = 0; round < 10; ++round) {
            const uint64_t p0 = uint64_t(kM0) * c[0];
            const uint64_t p1 = uint64_t(kM1) * c[2];
            c = {uint32_t(p1 >> 32) ^ c[1] ^ k[0], uint32_t(p1), uint32_t(p0 >> 32) ^ c[3] ^ k[1],
                 uint32_t(p0)};
            k[0] += kW0;
            k[1] += kW1;
        }
        return c;
    }

  private:
    std::array<uint32_t, 2> key_;
    std::array<uint32_t, 4> counter_;
    std::array<uint32_t, 4> block_{};
    int index_ = 4;
};

}  // namespace veil
