#include "tracer/runtime/qmc.h"

#include <cstddef>

namespace veil {

namespace {

constexpr int kBits = 32;
using Matrix = std::array<uint32_t, kBits>;  // column k: the direction number v_{k+1}

// Direction numbers of one dimension from its primitive polynomial (degree s, inner
// coefficients a, most significant first) and initial m_1..m_s (Bratley and Fox's
// recurrence, as Joe and Kuo state it).
constexpr Matrix directions(int s, uint32_t a, std::array<uint32_t, 3> m0) {
    std::array<uint32_t, kBits> m{};
    for (int k = 0; k < s; ++k) m[k] = m0[k];
    for (int k = s; k < kBits; ++k) {
        uint32_t v = m[k - s] ^ (m[k - s] << s);
        for (int j = 1; j < s; ++j)
            if ((a >> (s - 1 - j)) & 1u) v ^= m[k - j] << j;
        m[k] = v;
    }
    Matrix out{};
    for (int k = 0; k < kBits; ++k) out[k] = m[k] << (kBits - 1 - k);
    return out;
}

constexpr Matrix vanDerCorput() {
    Matrix out{};
    for (int k = 0; k < kBits; ++k) out[k] = 1u << (kBits - 1 - k);
    return out;
}

constexpr std::array<Matrix, SobolOwen::kDimensions> kMatrices = {
    vanDerCorput(),
    directions(1, 0, {1, 0, 0}),
    directions(2, 1, {1, 3, 0}),
    directions(3, 1, {1, 3, 1}),
    directions(3, 2, {1, 1, 1}),
};

constexpr uint32_t reverse(uint32_t x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
    x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8);
    return (x >> 16) | (x << 16);
}

// A bijection of 32-bit words in which output bit i depends only on input bits 0..i (adding a
// word, and x ^= x * c with c even, carry information upward only), keyed by the seed. On
// the reversed word that is a nested uniform scramble: the permutation applied to each digit
// depends on the digits before it.
constexpr uint32_t upwardHash(uint32_t x, uint32_t seed) {
    x += seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

uint64_t splitMix(uint64_t& state) {
    uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

}  // namespace

SobolOwen::SobolOwen(uint64_t seed) {
    uint64_t state = seed;
    for (uint32_t& s : seeds_) s = static_cast<uint32_t>(splitMix(state) >> 32);
}

uint32_t SobolOwen::sobol32(uint64_t index, int dimension) {
    const Matrix& v = kMatrices[static_cast<size_t>(dimension)];
    uint32_t x = 0;
    for (uint32_t i = static_cast<uint32_t>(index), k = 0; i != 0; i >>= 1, ++k)
        if (i & 1u) x ^= v[k];
    return x;
}

double SobolOwen::sample(uint64_t index, int dimension) const {
    const uint32_t x = sobol32(index, dimension);
    const uint32_t scrambled =
        reverse(upwardHash(reverse(x), seeds_[static_cast<size_t>(dimension)]));
    return static_cast<double>(scrambled) * 0x1.0p-32;
}

}  // namespace veil
