#pragma once
// Exact (analytic) faces of lens solids, in their local frame (axis = local z).
//
//   SurfacePatch   z = sag(x, y) of an exact SurfaceShape, limited by an Aperture: the
//                  optical surface (circular aperture), a ring of it (annular aperture: a
//                  primary mirror with a hole), or a flat shoulder (PlaneShape + annulus).
//   CylinderPatch  the side wall r = radius between zMin and zMax: a lens butt end (edge);
//                  between rim curves where it meets anamorphic faces.
//
// Normals: a SurfacePatch's normal is the shape's (+z at the vertex); a CylinderPatch's
// points away from the axis when outward is true, toward it otherwise. Which medium lies
// on which side of a face is the scene object's business (scene.h).

#include <memory>
#include <optional>
#include <ostream>
#include <variant>

#include "geometry/aperture.h"
#include "geometry/conic_roots.h"
#include "geometry/frame.h"
#include "geometry/surface_shape.h"
#include "geometry/triangle_mesh.h"

namespace veil {

struct SurfacePatch {
    SurfaceShape shape;
    Aperture aperture;
};
// Where a lens edge meets an anamorphic face the rim is a curve, not a circle in a plane:
// the edge ends on the face itself, z = vertexZMm + sagAt(shape, x, y).
struct RimCurve {
    SurfaceShape shape;
    double vertexZMm = 0.0;
    double zAt(double x, double y) const { return vertexZMm + sagAt(shape, x, y); }
};
struct RimCurves {
    std::optional<RimCurve> lower, upper;  // unset: the plane zMinMm (zMaxMm)
};
struct CylinderPatch {
    double radiusMm = 0.0;
    double zMinMm = 0.0;  // the lower limit; with a lower rim curve, an enclosure of it
    double zMaxMm = 0.0;
    bool outward = true;
    std::shared_ptr<const RimCurves> rims;  // null: both limits are planes
};
using FaceGeometry = std::variant<SurfacePatch, CylinderPatch>;
std::ostream& operator<<(std::ostream& os, const FaceGeometry& f);

// First hit with t in (tMin, tMax], local frame. startsOnFace: the ray starts on this face
// (the root at t ~ 0 is skipped without an epsilon, see intersectFirst()). A crossing of a
// patch's shape outside its aperture (in an annulus's hole) does not end the search: the
// next crossing of the same shape is taken if it lies within. Edges are inside, with an
// allowance of a few ulps of the hit's coordinates (as intersectFirst() grants at rMax), so
// faces that share an edge overlap by rounding rather than leave a crack between them.
std::optional<ShapeHit> intersectFace(const FaceGeometry& face, const Ray& localRay, double tMin,
                                      double tMax, bool startsOnFace);
// The normal of a face at a point of it (local frame): what intersectFace() reports there.
Vec3 faceNormal(const FaceGeometry& face, const Vec3& localPoint);

// A face prepared for repeated queries (geometry/face_index.h). The faces a lens is made of
// (a sphere, conic or plane with a circular or annular aperture; a butt end) are intersected
// without the general dispatch, and their normal is left out: faceNormal() of the point gives
// it, so a query that tests several faces pays for the normal of the nearest only. Other
// faces go through intersectFace() and keep its normal. t and point are intersectFace()'s
// bit for bit.
struct FaceCrossing {
    double t = 0.0;
    Vec3 point{0.0};
    Vec3 normal{0.0};
    bool hasNormal = false;  // false: faceNormal(face, point)
};
class PreparedFace {
  public:
    explicit PreparedFace(const FaceGeometry& face);
    // As intersectFace(face, ...), for the face this was prepared from.
    bool cross(const FaceGeometry& face, const Ray& localRay, double tMin, double tMax,
               bool startsOnFace, FaceCrossing& out) const;

  private:
    enum class Kind : unsigned char { General, Conic, Plane, Cylinder };
    Kind kind_ = Kind::General;
    ConicBase conic_;
    double rMax_ = 0.0;  // apertureBoundingRadius()
};

// Local bounds: the aperture's box in x, y and an enclosure of the sag over it in z (exact
// for planes, spheres and conics, whose sag is monotone in r; an interval enclosure over
// 1024 radial pieces for aspheres, over cells of (x^2, y^2) for anamorphic shapes), padded
// by a relative 1e-9 to hold edge hits.
Bounds3 faceBounds(const FaceGeometry& face);
// Boxes whose union holds the face, each much tighter than faceBounds(): points that bound
// the face closely (the renderer's exit aperture takes their corners), without the whole
// sag range of a curved face or the box across a butt end's hole. Local frame, padded as
// faceBounds().
//   disc (circular aperture)   a central disc of radius rMax / kFaceRings, then
//                              kFaceRings - 1 rings of equal width, each in kFaceSectors
//                              azimuthal sectors; a flat disc is one box
//   annulus                    kFaceSectors sectors (rings too when curved)
//   rectangle                  one box (faceBounds)
//   cylinder                   kFaceSectors sectors over its full height
// z ranges come from the same enclosure of the sag as faceBounds() (exact for conics, an
// interval bound for aspheres); x, y from the sector's corners and the axis crossings.
constexpr int kFaceRings = 4;
constexpr int kFaceSectors = 8;
std::vector<Bounds3> facePieceBounds(const FaceGeometry& face);
// The face as bands of a solid of revolution about its local z axis: every point of the face
// lies in one band's ring slab rLo <= sqrt(x^2 + y^2) <= rHi, zLo <= z <= zHi (padded as
// faceBounds()). A curved face in `bands` bands of equal radial width (each with the same
// sag enclosure as faceBounds()), a flat face or a cylinder in one; a rectangle as the ring
// of its circumscribed circle. What ExactFaceIndex culls rays with.
struct FaceBand {
    double rLo = 0.0, rHi = 0.0;
    double zLo = 0.0, zHi = 0.0;
};
std::vector<FaceBand> faceBands(const FaceGeometry& face, int bands);
// An enclosure of a shape's sag over squared radii u in [uLo, uHi] (not a sample: every
// sag there lies in [zLo, zHi]).
void sagRange(const SurfaceShape& shape, double uLo, double uHi, double& zLo, double& zHi);
// A triangle mesh for display and export whose chord error (distance between the exact
// face and its triangles) stays below chordToleranceMm. Local frame; triangles face along
// the face's normal. The rule (M = bound on the sag's curvature over the aperture, exact for
// conics, sampled and times 1.25 for aspheres; tol = chordToleranceMm):
//   disc, annulus  polar grid, vertices on the surface: ring spacing and outer arc spacing
//                  <= sqrt(3 tol / M) (linear interpolation error <= M rho^2 / 2 with the
//                  triangle's enclosing radius rho <= h / sqrt(3)), and the rim polygon
//                  within tol of the circle, R (1 - cos(dphi / 2)) <= tol; a hole's rim is a
//                  polygon circumscribed about it, so no triangle reaches into the hole.
//                  Triangles ~ 1 / tol for curved faces, ~ tol^-1/2 for flat rings.
//   rectangle      regular grid, cell sides <= sqrt(4 tol / M); exact outline.
//   cylinder       inscribed prism, R (1 - cos(dphi / 2)) <= tol; ~ tol^-1/2 triangles.
// Counts are capped (2048 rings, 4096 segments), which only a tolerance far below what a
// display needs, or a face reaching an ellipsoid's rim (M infinite there), runs into.
// Throws std::invalid_argument unless chordToleranceMm > 0.
TriangleMesh tessellateFace(const FaceGeometry& face, double chordToleranceMm);
// Points where the face meets the plane x = 0 (the y-z section), as polylines in (y, z):
// used for 2D layouts. Local frame; samples keep the chord error below chordToleranceMm
// (spacing <= sqrt(8 tol / M)). A surface patch gives its profile z = sag(0, y) over the
// aperture's y range, increasing y (two pieces for an annulus); a cylinder gives the two
// segments y = -R and y = +R from zMin to zMax (between its rim curves, if any).
std::vector<std::vector<Vec2>> sectionOfFace(const FaceGeometry& face, double chordToleranceMm);

}  // namespace veil
