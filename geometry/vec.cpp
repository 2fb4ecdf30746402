#include "geometry/vec.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const Ray& r) {
    return os << "Ray{origin " << r.origin << ", direction " << r.direction << "}";
}

}  // namespace veil
