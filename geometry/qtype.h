#pragma once
// Forbes Q-polynomial aspheres (G. W. Forbes, "Shape specification for axially symmetric
// optical surfaces", Opt. Express 15, 5218 (2007)), written as the even asphere terms veil
// traces exactly (geometry/surface_shape.h). With u = r / rNorm and x = u^2:
//
//   Qcon  z = c r^2 / (1 + sqrt(1 - (1 + k) c^2 r^2)) + u^4 sum_m a_m Q_m^con(x)
//   Qbfs  z = c r^2 / (1 + sqrt(1 - c^2 r^2)) + x (1 - x) / sqrt(1 - c^2 r^2) sum_m a_m Q_m^bfs(x)
//
// Q_m^con(x) = P_m^(0,4)(2 x - 1), the Jacobi polynomial: orthogonal on [0, 1] with weight x^4,
// so the terms are independent in the departure's mean square. Q_m^bfs are defined by the
// orthonormality of the departures' slopes, f_m(u) = u^2 (1 - u^2) Q_m(u^2):
//
//   integral_0^1 f_m'(u) f_n'(u) du / sqrt(1 - u^2) = (pi / 2) delta_mn,   Q_m(0) > 0,
//
// built here by Gram-Schmidt on 1, x, x^2, ... in exact rational arithmetic (GMP): every
// integral is pi / 2 times (k - 1)!! / k!! for the even powers u^k that occur, so only the
// final normalisation is rounded. The first few agree with Forbes's closed forms, Q_0 = 1,
// Q_1 = (13 - 16 x) / sqrt(19), Q_2 = sqrt(2 / 95) (29 - 4 x (25 - 19 x)), ...
//
// Both become polynomials in v = r^2 exactly: the Qcon departure adds d_n v^n (n = 2 ..
// M + 2) to the even asphere terms; the Qbfs departure is (sum_n e_n v^n) / w with
// w = sqrt(1 - c^2 v) (n = 1 .. M + 2), the base sphere's own square root
// (EvenAsphereShape::overW). With at most kMaxQTerms terms (M = 8) every power fits the
// asphere arrays, and the monomial coefficients (up to ~1e5 times a_m) cost about 1e-11 of
// the departure to rounding.

#include <vector>

namespace veil {

inline constexpr int kMaxQTerms = 9;  // a_0 .. a_8

// Coefficients of Q_m^con(x) and Q_m^bfs(x) in powers of x (index = power), m < kMaxQTerms.
const std::vector<double>& qconPolynomial(int m);
const std::vector<double>& qbfsPolynomial(int m);

// The departure of a Q-type asphere with normalisation radius rNormMm and terms a_0.. as
// coefficients of v^n, v = r^2 (mm^2), index n (entries 0 and 1 are 0 for Qcon). Qbfs: to
// be divided by w = sqrt(1 - c^2 v).
std::vector<double> qconDeparture(double rNormMm, const std::vector<double>& terms);
std::vector<double> qbfsDeparture(double rNormMm, const std::vector<double>& terms);

}  // namespace veil
