#pragma once
// Rigid placement of an object: global = rotation * local + translation (mm).

#include <glm/mat3x3.hpp>
#include <ostream>

#include "geometry/vec.h"

namespace veil {

struct Frame {
    glm::dmat3 rotation{1.0};  // columns: local x, y, z axes in global coordinates
    Vec3 translation{0.0};

    static Frame alongAxis(double zMm) { return {glm::dmat3(1.0), Vec3(0.0, 0.0, zMm)}; }

    Vec3 toGlobalPoint(const Vec3& p) const { return rotation * p + translation; }
    Vec3 toGlobalDirection(const Vec3& d) const { return rotation * d; }
    // The rotation is orthonormal: its inverse is its transpose.
    Vec3 toLocalPoint(const Vec3& p) const { return glm::transpose(rotation) * (p - translation); }
    Vec3 toLocalDirection(const Vec3& d) const { return glm::transpose(rotation) * d; }
    Ray toLocal(const Ray& r) const {
        return {toLocalPoint(r.origin), toLocalDirection(r.direction)};
    }
};
std::ostream& operator<<(std::ostream& os, const Frame& f);

// An axis-aligned box (mm); empty when lo > hi.
struct Bounds3 {
    Vec3 lo{1e300};
    Vec3 hi{-1e300};
    void extend(const Vec3& p);
    void extend(const Bounds3& b);
    bool empty() const { return lo.x > hi.x; }
    // Slab test: narrows [tMin, tMax] to the part of the ray inside the box; false when the
    // ray does not meet the box there (tMin, tMax are then left in an unspecified state).
    bool clip(const Ray& r, double& tMin, double& tMax) const;
};
std::ostream& operator<<(std::ostream& os, const Bounds3& b);
// Bounds of a local box after placement.
Bounds3 transformBounds(const Frame& f, const Bounds3& local);

}  // namespace veil
