#pragma once
// The y-z section (plane x = 0) of a scene, for 2D layouts and ray path pictures.
//
// Exact faces give their section profiles (sectionOfFace); meshes are sliced triangle by
// triangle. Pieces are then chained end to end: each lens element's faces (its cemented
// face included) close into one loop, each closed mesh into one loop per piece of its
// section. Coordinates are (z, y) in mm.

#include <string>
#include <vector>

#include "geometry/scene.h"

namespace veil {

struct SectionPath {
    std::string part;  // lens element (L3), mechanical part (spacer2), or object name
    ObjectKind kind = ObjectKind::Dummy;
    std::vector<Vec2> zy;
    bool closed = false;
};

std::vector<SectionPath> sceneSection(const Scene& scene, double chordToleranceMm);

// Slices a triangle mesh with the plane x = 0 and chains the pieces into polylines (closed
// loops for a closed mesh). Each crossing point is computed once per mesh edge, so pieces
// of neighbouring triangles join exactly. Points returned as (z, y).
std::vector<std::vector<Vec2>> sliceMeshX0(const TriangleMesh& mesh, size_t firstTriangle,
                                           size_t triangleCount, std::vector<bool>* closed);

}  // namespace veil
