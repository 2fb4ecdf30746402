#pragma once
// Apertures of exact surfaces, in the surface's local (x, y), mm. Points exactly on an edge
// are inside. Apertures are centred on the surface axis; sizes are expected to be >= 0 with
// innerRadiusMm <= outerRadiusMm (checked by whoever builds the model, not here).

#include <ostream>
#include <variant>

namespace veil {

struct CircularAperture {
    double radiusMm = 0.0;
};
struct AnnularAperture {
    double innerRadiusMm = 0.0;  // central obscuration
    double outerRadiusMm = 0.0;
};
struct RectangularAperture {
    double halfWidthMm = 0.0;   // x
    double halfHeightMm = 0.0;  // y
};
using Aperture = std::variant<CircularAperture, AnnularAperture, RectangularAperture>;
std::ostream& operator<<(std::ostream& os, const CircularAperture& a);
std::ostream& operator<<(std::ostream& os, const AnnularAperture& a);
std::ostream& operator<<(std::ostream& os, const RectangularAperture& a);
std::ostream& operator<<(std::ostream& os, const Aperture& a);

bool apertureContains(const Aperture& aperture, double x, double y);
// Radius of the smallest circle about the axis that holds the aperture.
double apertureBoundingRadius(const Aperture& aperture);

}  // namespace veil
