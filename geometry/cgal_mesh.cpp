#include "geometry/cgal_mesh.h"

#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>

#include <stdexcept>

namespace veil {

namespace PMP = CGAL::Polygon_mesh_processing;

bool isCgalPolygonMesh(const TriangleMesh& m) {
    for (const auto& t : m.triangles)
        for (uint32_t v : t)
            if (v >= m.vertices.size()) return false;
    return PMP::is_polygon_soup_a_polygon_mesh(m.triangles);
}

CgalMesh toCgalMesh(const TriangleMesh& m) {
    if (!isCgalPolygonMesh(m))
        throw std::invalid_argument(
            "toCgalMesh: the triangles do not form a polygon mesh (an edge used more than twice "
            "or twice in the same direction, or a vertex whose triangles form several fans)");
    std::vector<CgalPoint> points;
    points.reserve(m.vertices.size());
    for (const Vec3& v : m.vertices) points.emplace_back(v.x, v.y, v.z);
    CgalMesh out;
    PMP::polygon_soup_to_polygon_mesh(points, m.triangles, out);
    return out;
}

TriangleMesh fromCgalMesh(const CgalMesh& m) {
    TriangleMesh out;
    std::vector<uint32_t> index(m.num_vertices() + m.number_of_removed_vertices(), 0);
    for (CgalMesh::Vertex_index v : m.vertices()) {
        index[v] = static_cast<uint32_t>(out.vertices.size());
        const CgalPoint& p = m.point(v);
        out.vertices.emplace_back(p.x(), p.y(), p.z());
    }
    for (CgalMesh::Face_index f : m.faces()) {
        std::array<uint32_t, 3> tri{};
        int k = 0;
        for (CgalMesh::Vertex_index v : CGAL::vertices_around_face(m.halfedge(f), m)) {
            if (k == 3) throw std::invalid_argument("fromCgalMesh: a face is not a triangle");
            tri[k++] = index[v];
        }
        if (k != 3) throw std::invalid_argument("fromCgalMesh: a face is not a triangle");
        out.triangles.push_back(tri);
    }
    return out;
}

}  // namespace veil
