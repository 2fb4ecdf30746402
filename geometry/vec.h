#pragma once
// Vector types for geometry in double precision (mm).

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <ostream>

// Printing lives in namespace glm so argument-dependent lookup finds it everywhere
// (GoogleTest failure messages included).
namespace glm {
inline std::ostream& operator<<(std::ostream& os, const dvec3& v) {
    return os << "(" << v.x << ", " << v.y << ", " << v.z << ")";
}
inline std::ostream& operator<<(std::ostream& os, const dvec2& v) {
    return os << "(" << v.x << ", " << v.y << ")";
}
}  // namespace glm

namespace veil {

using Vec2 = glm::dvec2;
using Vec3 = glm::dvec3;

// A ray: origin (mm) and unit direction, in whatever frame the caller states.
struct Ray {
    Vec3 origin{0.0};
    Vec3 direction{0.0, 0.0, 1.0};
};
std::ostream& operator<<(std::ostream& os, const Ray& r);

}  // namespace veil
