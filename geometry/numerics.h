#pragma once
// Small numeric helpers and constants every module shares (one home: no file defines its own).

#include <cmath>
#include <numbers>

namespace veil {

inline constexpr double kPi = std::numbers::pi;

// a * b - c * d with a single rounding error (Kahan's algorithm): keeps B^2 - AC accurate for
// grazing rays, where the two products nearly cancel.
inline double differenceOfProducts(double a, double b, double c, double d) {
    const double cd = c * d;
    const double err = std::fma(-c, d, cd);
    const double dop = std::fma(a, b, -cd);
    return dop + err;
}

}  // namespace veil
