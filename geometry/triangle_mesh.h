#pragma once
// An indexed triangle mesh in double precision (mm). Triangles are counter-clockwise seen
// from outside a closed solid, so their normals (v1 - v0) x (v2 - v0) point outward.

#include <array>
#include <cstdint>
#include <optional>
#include <ostream>
#include <vector>

#include "geometry/frame.h"

namespace veil {

struct TriangleMesh {
    std::vector<Vec3> vertices;
    std::vector<std::array<uint32_t, 3>> triangles;

    Bounds3 bounds() const;
    void append(const TriangleMesh& other);  // indices shifted
    void transform(const Frame& f);          // in place, to global
    Vec3 triangleNormal(size_t tri) const;   // unit
};
std::ostream& operator<<(std::ostream& os, const TriangleMesh& m);

// Double-precision ray-triangle intersection (Moller-Trumbore with the determinant test
// scaled to the triangle): t along the ray in (tMin, tMax], or nothing.
std::optional<double> intersectTriangle(const Vec3& a, const Vec3& b, const Vec3& c, const Ray& r,
                                        double tMin, double tMax);

}  // namespace veil
