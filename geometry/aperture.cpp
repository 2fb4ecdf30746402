#include "geometry/aperture.h"

#include <cmath>
#include <limits>
#include <type_traits>

namespace veil {

// Printing

std::ostream& operator<<(std::ostream& os, const CircularAperture& a) {
    return os << "CircularAperture{radius " << a.radiusMm << " mm}";
}
std::ostream& operator<<(std::ostream& os, const AnnularAperture& a) {
    return os << "AnnularAperture{inner " << a.innerRadiusMm << " mm, outer " << a.outerRadiusMm
              << " mm}";
}
std::ostream& operator<<(std::ostream& os, const RectangularAperture& a) {
    return os << "RectangularAperture{half width " << a.halfWidthMm << " mm, half height "
              << a.halfHeightMm << " mm}";
}
std::ostream& operator<<(std::ostream& os, const Aperture& a) {
    std::visit([&os](const auto& ap) { os << ap; }, a);
    return os;
}

// Aperture Functions

// Radial tests compare squares: x^2 + y^2 and R^2 are rounded the same way for a point
// written as (R, 0) or (0, R), so such edge points stay inside, and no square root is taken.
bool apertureContains(const Aperture& aperture, double x, double y) {
    return std::visit(
        [x, y](const auto& a) -> bool {
            using A = std::decay_t<decltype(a)>;
            const double rSq = x * x + y * y;
            if constexpr (std::is_same_v<A, CircularAperture>) {
                return rSq <= a.radiusMm * a.radiusMm;
            } else if constexpr (std::is_same_v<A, AnnularAperture>) {
                return rSq >= a.innerRadiusMm * a.innerRadiusMm &&
                       rSq <= a.outerRadiusMm * a.outerRadiusMm;
            } else {
                return std::abs(x) <= a.halfWidthMm && std::abs(y) <= a.halfHeightMm;
            }
        },
        aperture);
}

double apertureBoundingRadius(const Aperture& aperture) {
    return std::visit(
        [](const auto& a) -> double {
            using A = std::decay_t<decltype(a)>;
            if constexpr (std::is_same_v<A, CircularAperture>) {
                return a.radiusMm;
            } else if constexpr (std::is_same_v<A, AnnularAperture>) {
                return a.outerRadiusMm;
            } else {
                // Rounded up by one ulp so that the corners, however their radius is
                // rounded by the caller, lie within it.
                const double r = std::hypot(a.halfWidthMm, a.halfHeightMm);
                return std::nextafter(r, std::numeric_limits<double>::infinity());
            }
        },
        aperture);
}

}  // namespace veil
