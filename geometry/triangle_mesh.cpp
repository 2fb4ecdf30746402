#include "geometry/triangle_mesh.h"

#include <cmath>

namespace veil {

Bounds3 TriangleMesh::bounds() const {
    Bounds3 b;
    for (const Vec3& v : vertices) b.extend(v);
    return b;
}

void TriangleMesh::append(const TriangleMesh& other) {
    const auto base = static_cast<uint32_t>(vertices.size());
    vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
    for (const auto& t : other.triangles) triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
}

void TriangleMesh::transform(const Frame& f) {
    for (Vec3& v : vertices) v = f.toGlobalPoint(v);
}

Vec3 TriangleMesh::triangleNormal(size_t tri) const {
    const auto& t = triangles[tri];
    const Vec3 n = glm::cross(vertices[t[1]] - vertices[t[0]], vertices[t[2]] - vertices[t[0]]);
    return glm::normalize(n);
}

std::ostream& operator<<(std::ostream& os, const TriangleMesh& m) {
    return os << "TriangleMesh{" << m.vertices.size() << " vertices, " << m.triangles.size()
              << " triangles}";
}

std::optional<double> intersectTriangle(const Vec3& a, const Vec3& b, const Vec3& c, const Ray& r,
                                        double tMin, double tMax) {
    const Vec3 e1 = b - a, e2 = c - a;
    const Vec3 p = glm::cross(r.direction, e2);
    const double det = glm::dot(e1, p);
    if (det == 0.0 || !std::isfinite(det)) return std::nullopt;
    const double inv = 1.0 / det;
    const Vec3 s = r.origin - a;
    const double u = glm::dot(s, p) * inv;
    if (u < 0.0 || u > 1.0) return std::nullopt;
    const Vec3 q = glm::cross(s, e1);
    const double v = glm::dot(r.direction, q) * inv;
    if (v < 0.0 || u + v > 1.0) return std::nullopt;
    const double t = glm::dot(e2, q) * inv;
    if (!(t > tMin && t <= tMax)) return std::nullopt;
    return t;
}

}  // namespace veil
