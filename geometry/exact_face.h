#pragma once
// Exact (analytic) faces of lens solids, in their local frame (axis = local z).
//
//   SurfacePatch   z = sag(x, y) of an exact SurfaceShape, limited by an Aperture: the
//                  optical surface (circular aperture), a ring of it (annular aperture: a
//                  primary mirror with a hole), or a flat shoulder (PlaneShape + annulus).
//   CylinderPatch  the side wall r = radius between zMin and zMax: a lens butt end (edge).
//
// Normals: a SurfacePatch's normal is the shape's (+z at the vertex); a CylinderPatch's
// points away from the axis when outward is true, toward it otherwise. Which medium lies
// on which side of a face is the scene object's business (scene.h).

#include <optional>
#include <ostream>
#include <variant>

#include "geometry/aperture.h"
#include "geometry/frame.h"
#include "geometry/surface_shape.h"
#include "geometry/triangle_mesh.h"

namespace veil {

struct SurfacePatch {
    SurfaceShape shape;
    Aperture aperture;
};
struct CylinderPatch {
    double radiusMm = 0.0;
    double zMinMm = 0.0;
    double zMaxMm = 0.0;
    bool outward = true;
};
using FaceGeometry = std::variant<SurfacePatch, CylinderPatch>;
std::ostream& operator<<(std::ostream& os, const FaceGeometry& f);

// First hit with t in (tMin, tMax], local frame. startsOnFace: the ray starts on this face
// (the root at t ~ 0 is skipped without an epsilon, see intersectFirst()).
std::optional<ShapeHit> intersectFace(const FaceGeometry& face, const Ray& localRay, double tMin,
                                      double tMax, bool startsOnFace);
// Local bounds.
Bounds3 faceBounds(const FaceGeometry& face);
// A triangle mesh for display and export whose chord error (distance between the exact
// face and its triangles) stays below chordToleranceMm. Local frame.
TriangleMesh tessellateFace(const FaceGeometry& face, double chordToleranceMm);
// Points where the face meets the plane x = 0 (the y-z section), as polylines in (y, z):
// used for 2D layouts. Local frame; samples keep the chord error below chordToleranceMm.
std::vector<std::vector<Vec2>> sectionOfFace(const FaceGeometry& face, double chordToleranceMm);

}  // namespace veil
