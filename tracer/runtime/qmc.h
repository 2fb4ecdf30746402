#pragma once
// Randomized quasi-Monte Carlo points: the first five dimensions of Sobol's sequence with
// Owen's nested uniform scrambling.
//
// A Monte Carlo estimate over N independent points has error ~ N^-1/2. Sobol's points fill
// the unit cube evenly (every dimension's first 2^m points put one point in each of 2^m equal
// intervals; dimensions 0 and 1 together form a (0, m, 2)-net: one point in every
// dyadic box of area 2^-m), so an integrand of bounded variation gets error ~ (log N)^d / N,
// and one with edges (a ghost image's rim, a vignetting mount) about N^-3/4 in two
// dimensions. Scrambling makes the points random again, each one uniform on [0, 1)^5, so an
// estimate stays unbiased and independent scrambles (one per pass) give independent
// estimates whose spread measures the error, while keeping the even filling.
//
// Direction numbers: Joe and Kuo's primitive polynomials and initial m_i for dimensions
// 2..5 (S. Joe, F. Y. Kuo, "Constructing Sobol sequences with better two-dimensional
// projections", SIAM J. Sci. Comput. 30, 2008); dimension 1 is van der Corput's. Scrambling:
// Owen (1995) nested uniform scrambling, done per point with the hash-based permutation of
// Burley ("Practical hash-based Owen scrambling", JCGT 9(4), 2020): reverse the bits, apply
// a hash in which each bit depends only on the bits below it, reverse back.

#include <array>
#include <cstdint>

namespace veil {

class SobolOwen {
  public:
    static constexpr int kDimensions = 5;

    // Point `index` of the sequence, scrambled with one independent seed per dimension
    // (seeds from `seed`): coordinate `dimension` in [0, 1).
    SobolOwen(uint64_t seed);
    double sample(uint64_t index, int dimension) const;
    // The unscrambled coordinate, 32 bits (tests).
    static uint32_t sobol32(uint64_t index, int dimension);

  private:
    std::array<uint32_t, kDimensions> seeds_{};
};

}  // namespace veil
