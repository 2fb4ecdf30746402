#include "geometry/mesh_check.h"

#include <CGAL/Polygon_mesh_processing/intersection.h>
#include <CGAL/Polygon_mesh_processing/measure.h>
#include <CGAL/Polygon_mesh_processing/orientation.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>

#include <boost/function_output_iterator.hpp>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_map>

#include "geometry/cgal_mesh.h"

namespace veil {

namespace PMP = CGAL::Polygon_mesh_processing;

namespace {

// Edge Counting

struct EdgeUse {
    uint32_t forward = 0;   // traversals from the smaller to the larger vertex index
    uint32_t backward = 0;  // the other way
};

void countEdges(const TriangleMesh& m, MeshCheck& c) {
    std::unordered_map<uint64_t, EdgeUse> edges;
    edges.reserve(m.triangles.size() * 2);
    for (const auto& t : m.triangles) {
        for (int e = 0; e < 3; ++e) {
            const uint32_t a = t[e], b = t[(e + 1) % 3];
            if (a == b) continue;  // a degenerate triangle, counted below
            const uint64_t key = (uint64_t{std::min(a, b)} << 32) | std::max(a, b);
            EdgeUse& use = edges[key];
            (a < b ? use.forward : use.backward)++;
        }
    }
    for (const auto& [key, use] : edges) {
        const uint32_t n = use.forward + use.backward;
        if (n == 1)
            ++c.borderEdges;
        else if (n > 2)
            ++c.nonManifoldEdges;
        else if (use.forward != 1)
            ++c.misorientedEdges;
    }
}

size_t countDegenerate(const TriangleMesh& m) {
    size_t n = 0;
    for (const auto& t : m.triangles) {
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
            ++n;
            continue;
        }
        const Vec3 &a = m.vertices[t[0]], &b = m.vertices[t[1]], &d = m.vertices[t[2]];
        if (CGAL::collinear(CgalPoint(a.x, a.y, a.z), CgalPoint(b.x, b.y, b.z),
                            CgalPoint(d.x, d.y, d.z)))
            ++n;
    }
    return n;
}

}  // namespace

// MeshCheck Methods

std::string MeshCheck::problems() const {
    std::ostringstream os;
    const char* sep = "";
    auto item = [&](size_t n, const char* what) {
        if (n == 0) return;
        os << sep << n << " " << what;
        sep = "; ";
    };
    item(borderEdges, "border edges (not closed)");
    item(nonManifoldEdges, "non-manifold edges (shared by more than two triangles)");
    item(misorientedEdges, "inconsistently oriented edges");
    item(degenerateTriangles, "degenerate triangles");
    if (!polygonMesh) {
        os << sep << "not a polygon mesh (self-intersection and orientation not checked)";
        sep = "; ";
    }
    if (selfIntersections > 0) {
        os << sep << (selfIntersectionsCapped ? "at least " : "") << selfIntersections
           << " self-intersecting triangle pairs";
        sep = "; ";
    }
    if (closed() && !outward) os << sep << "oriented inward (normals point into the solid)";
    return os.str();
}

std::ostream& operator<<(std::ostream& os, const MeshCheck& c) {
    os << "MeshCheck{" << c.vertices << " vertices, " << c.triangles << " triangles, ";
    if (c.valid()) return os << "valid, volume " << c.volumeMm3 << " mm^3}";
    return os << c.problems() << "}";
}

// Checks

MeshCheck checkMesh(const TriangleMesh& mesh, size_t maxSelfIntersections) {
    MeshCheck c;
    c.vertices = mesh.vertices.size();
    c.triangles = mesh.triangles.size();
    c.volumeMm3 = std::numeric_limits<double>::quiet_NaN();
    for (const auto& t : mesh.triangles)
        for (uint32_t v : t)
            if (v >= mesh.vertices.size())
                throw std::invalid_argument("checkMesh: a triangle refers to vertex " +
                                            std::to_string(v) + " of " +
                                            std::to_string(mesh.vertices.size()));
    countEdges(mesh, c);
    c.degenerateTriangles = countDegenerate(mesh);
    c.polygonMesh = isCgalPolygonMesh(mesh);
    if (!c.polygonMesh) return c;

    const CgalMesh cm = toCgalMesh(mesh);
    size_t pairs = 0;
    auto count = boost::make_function_output_iterator([&](const auto&) { ++pairs; });
    PMP::self_intersections(cm, count,
                            CGAL::parameters::maximum_number(static_cast<unsigned int>(
                                std::max<size_t>(1, maxSelfIntersections))));
    c.selfIntersections = pairs;
    c.selfIntersectionsCapped = pairs >= maxSelfIntersections;
    if (c.closed()) {
        c.outward = PMP::is_outward_oriented(cm);
        c.volumeMm3 = PMP::volume(cm);
    }
    return c;
}

bool meshesIntersect(const TriangleMesh& a, const TriangleMesh& b) {
    const CgalMesh ca = toCgalMesh(a), cb = toCgalMesh(b);
    const bool bothClosed = CGAL::is_closed(ca) && CGAL::is_closed(cb);
    return PMP::do_intersect(ca, cb, CGAL::parameters::do_overlap_test_of_bounded_sides(bothClosed),
                             CGAL::parameters::default_values());
}

}  // namespace veil
