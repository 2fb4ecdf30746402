#pragma once
// TriangleMesh <-> CGAL::Surface_mesh, for the CGAL-based checks and builders.
//
// INTERNAL: this header pulls in CGAL, which is slow to compile. Include it only from .cpp
// files (mesh_check.cpp, tests), never from a header that other modules include.
//
// The kernel is Exact_predicates_inexact_constructions_kernel: points are plain doubles (the
// conversion is exact both ways) and every predicate (orientation, intersection tests) is
// exact, so checks on our double-precision meshes give exact answers.

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Surface_mesh.h>

#include "geometry/triangle_mesh.h"

namespace veil {

using CgalKernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using CgalPoint = CgalKernel::Point_3;
using CgalMesh = CGAL::Surface_mesh<CgalPoint>;

// Whether the triangles form a polygon mesh CGAL can hold: every edge used at most twice,
// in opposite directions, and every vertex's triangles form one fan (PMP's
// is_polygon_soup_a_polygon_mesh). Open meshes qualify.
bool isCgalPolygonMesh(const TriangleMesh& m);
// Vertices keep their order and triangles theirs (face i is triangle i). Throws
// std::invalid_argument when !isCgalPolygonMesh(m).
CgalMesh toCgalMesh(const TriangleMesh& m);
TriangleMesh fromCgalMesh(const CgalMesh& m);

}  // namespace veil
