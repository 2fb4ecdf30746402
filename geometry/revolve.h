#pragma once
// Solids of revolution: a closed profile polygon in the (r, z) half plane (r >= 0), turned
// about the z axis into a closed, outward-oriented triangle mesh.
//
//        z                         The profile is given counter-clockwise with r to the
//        ^     +------+            right and z up (positive signed area), so its interior
//        |     |      |            lies to the left of every edge; the mesh normals then
//        |     +--+   |            point out of the solid. Vertices with r == 0 lie on the
//        |        |   |            axis: they become one mesh vertex (a pole), edges into
//        |        +---+            them become triangle fans, and edges along the axis
//        +-------------------> r   produce no faces, so there are no degenerate triangles.
//
// Tessellation. The circle is cut into N equal angular segments, phi_k = 2 pi k / N, and every
// profile vertex (r, z) becomes the ring of points (r cos phi_k, r sin phi_k, z). The quad
// between two rings is a planar trapezoid (its two horizontal sides are parallel), so the
// mesh is exactly the union of N wedges, each the profile swept along a chord: every mesh
// point has the form (r p, z) with (r, z) in the profile and p on the chord between
// (cos phi_k, sin phi_k) and (cos phi_k+1, sin phi_k+1). Consequences:
//   - the chord error, the largest distance between the exact surface of revolution and the
//     mesh, is r_max (1 - cos(pi / N)), reached at the middle of the chords of the largest
//     ring; chordSegmentCount() picks the smallest N that keeps it below a tolerance;
//   - the mesh volume is exactly V * N sin(2 pi / N) / (2 pi), with V = 2 pi * integral of r
//     over the profile (Pappus) the volume of the exact solid: relative error about
//     (2 pi / N)^2 / 6, or (4/3) tol / r_max at the chord tolerance tol;
//   - two profiles that do not meet give meshes that do not meet when revolved with the same
//     N (the map (r, z, p) -> (r p, z) is one to one for r > 0): parts built with a common
//     segment count keep the clearances of their profiles exactly; a mesh point at profile
//     radius r lies at a radius between r cos(pi / N) and r.
//
// Mesh layout: triangles are emitted profile edge by profile edge, so the triangles of one
// edge (or of consecutive edges) form one contiguous range (RevolvedMesh::edgeFirstTriangle)
// that can be named as its own scene object (the knife edge of a stop).

#include <cstdint>
#include <ostream>
#include <span>
#include <string>
#include <vector>

#include "geometry/triangle_mesh.h"
#include "geometry/vec.h"

namespace veil {

// Smallest N >= 3 with rMaxMm (1 - cos(pi / N)) <= chordToleranceMm. Throws
// std::invalid_argument for a tolerance <= 0 or a radius < 0 or not finite.
int chordSegmentCount(double rMaxMm, double chordToleranceMm);
// rMaxMm (1 - cos(pi / segments)): the chord error of a ring of that radius.
double chordError(double rMaxMm, int segments);

struct RevolvedMesh {
    TriangleMesh mesh;
    // Triangles of profile edge i (from vertex i to vertex i + 1, the last edge closing the
    // polygon) are [edgeFirstTriangle[i], edgeFirstTriangle[i + 1]); size = edges + 1.
    // Edges along the axis own an empty range.
    std::vector<uint32_t> edgeFirstTriangle;
    int segments = 0;
};
std::ostream& operator<<(std::ostream& os, const RevolvedMesh& m);

// Revolves a closed polygon (the last vertex connects back to the first) with `segments`
// angular steps. Preconditions, each checked with a std::invalid_argument naming it: at least
// 3 vertices, finite, r >= 0, no repeated consecutive vertex, counter-clockwise (positive
// area), simple (no two edges cross or touch except consecutive ones at their common vertex).
// A profile vertex on the axis whose two edges both leave the axis makes a pinch point (two
// cones meeting at their tips); such a mesh is closed but not manifold at that vertex.
RevolvedMesh revolveProfile(std::span<const Vec2> profile, int segments);
// Why revolveProfile() would refuse `profile` (the message of its std::invalid_argument,
// without the function's name), or "" when the profile can be revolved. Quadratic in the
// vertex count (the simplicity check).
std::string profileDefect(std::span<const Vec2> profile);

// Signed area of a polygon in (r, z) (positive when counter-clockwise) and the volume of its
// exact solid of revolution, 2 pi * integral of r dA (Pappus), mm^3.
double profileArea(std::span<const Vec2> profile);
double profileRevolvedVolume(std::span<const Vec2> profile);

}  // namespace veil
