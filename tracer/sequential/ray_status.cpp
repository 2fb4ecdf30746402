#include "tracer/sequential/ray_status.h"

namespace veil {

std::string_view toString(RayStatus s) {
    switch (s) {
        case RayStatus::Ok:
            return "ok";
        case RayStatus::Missed:
            return "missed surface";
        case RayStatus::TotalInternalReflection:
            return "TIR";
        case RayStatus::Clipped:
            return "clipped by aperture";
        case RayStatus::Invalid:
            return "invalid";
    }
    return "unknown";
}

std::ostream& operator<<(std::ostream& os, RayStatus s) { return os << toString(s); }

}  // namespace veil
