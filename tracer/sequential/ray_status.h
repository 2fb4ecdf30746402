#pragma once
// Per-ray outcomes of a trace: data, not exceptions.

#include <ostream>
#include <string_view>

namespace veil {

enum class RayStatus {
    Ok,      // reached the last requested surface
    Missed,  // the ray does not meet the surface (or leaves the conic's domain)
    TotalInternalReflection,
    Clipped,  // met the surface outside its clear aperture
    Invalid,  // not a ray: zero direction, NaN input, or ray aiming failed
};
std::string_view toString(RayStatus s);
std::ostream& operator<<(std::ostream& os, RayStatus s);

}  // namespace veil
