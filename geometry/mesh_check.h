#pragma once
// Validity checks of triangle meshes with CGAL's Polygon Mesh Processing (PMP), for the
// mechanics we build and the meshes users import.
//
//   MeshCheck c = checkMesh(mesh);
//   if (!c.valid()) throw ModelError("spacer2", c.problems());
//
// What "valid" means for a solid the tracer flies through: closed (every edge shared by
// exactly two triangles that run through it in opposite directions), no degenerate
// (zero-area) triangle, no two triangles that cross or touch other than along their shared
// edge or vertex, and oriented with the normals (v1 - v0) x (v2 - v0) pointing out, so the
// enclosed volume is positive.
//
// Edge counts come from the index lists (exact, also for broken meshes). Self-intersection,
// orientation and volume use CGAL on the exact-predicate kernel (geometry/cgal_mesh.h), which
// needs a polygon mesh: when the triangles are not one (an edge used three times, a vertex
// whose triangles form two fans) those three are not computed. CGAL stays inside the .cpp.

#include <cstddef>
#include <ostream>
#include <string>

#include "geometry/triangle_mesh.h"

namespace veil {

struct MeshCheck {
    size_t vertices = 0;
    size_t triangles = 0;
    size_t borderEdges = 0;          // edges of one triangle only: holes
    size_t nonManifoldEdges = 0;     // edges of three or more triangles
    size_t misorientedEdges = 0;     // edges whose two triangles run through them the same way
    size_t degenerateTriangles = 0;  // repeated vertex index or collinear corners (exact test)
    bool polygonMesh = false;        // CGAL can hold it (the checks below ran)
    size_t selfIntersections = 0;    // pairs of intersecting triangles, counted up to a limit
    bool selfIntersectionsCapped = false;  // the limit was reached: there may be more
    bool outward = false;                  // closed and oriented outward (PMP::is_outward_oriented)
    double volumeMm3 = 0.0;                // signed enclosed volume when closed, else NaN

    // Every edge shared by exactly two triangles in opposite directions.
    bool closed() const {
        return polygonMesh && borderEdges == 0 && nonManifoldEdges == 0 && misorientedEdges == 0;
    }
    bool valid() const {
        return closed() && degenerateTriangles == 0 && selfIntersections == 0 && outward;
    }
    // "3 border edges (not closed); 2 self-intersecting triangle pairs"; "" when valid().
    std::string problems() const;
};
std::ostream& operator<<(std::ostream& os, const MeshCheck& c);

// Runs every check. Self-intersecting pairs are counted up to `maxSelfIntersections`.
MeshCheck checkMesh(const TriangleMesh& mesh, size_t maxSelfIntersections = 100);

// Whether two meshes meet: a triangle of one crosses or touches a triangle of the other, or
// (when both are closed) one lies inside the other (PMP::do_intersect with the bounded-side
// overlap test). Touching counts: parts in contact must leave a gap. Both must be polygon
// meshes (std::invalid_argument otherwise).
bool meshesIntersect(const TriangleMesh& a, const TriangleMesh& b);

}  // namespace veil
