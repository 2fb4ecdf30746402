#pragma once
// Lens elements as closed solids of exact faces, added to the scene's object table.
//
// Every lens element of the prescription (Prescription::elements()) becomes a closed solid
// bounded by named exact faces, each its own SceneObject:
//
//   L4.front, L4.back   the optical surfaces, exact up to the clear semi-diameter
//                       (ObjectKind::LensFace; MirrorFace for the silvered back of a Mangin)
//   L4.flat1, L4.flat2  flat annular shoulders between the clear semi-diameter and the
//                       element's mechanical radius, on the front and the back side
//                       (ObjectKind::LensFlat; only where the radius exceeds the face)
//   L4.edge             the butt end, a cylinder at the mechanical radius (ObjectKind::LensEdge)
//
// Section through the axis (upper half; light toward +z, biconvex singlet):
//
//        r
//        ^          rimF            rimB
//      R |           +----- edge -----+        edge:  cylinder r = R, rimF <= z <= rimB
//        |     flat1 |                | flat2  flats: planes z = rimF, r from cF to R,
//     cF |           +                |               and z = rimB, r from cB to R
//     cB |          /                 +        rimF = zF + sagF(cF), rimB = zB + sagB(cB)
//        |         /      glass        \       faces: exact, r <= cF (front), r <= cB
//        |        ( front          back )             (back)
//      0 +--------+---------------------+-----> z
//                 zF                    zB
//
// The rim heights are computed once and shared: the flat is placed at exactly rimF, the
// cylinder runs between exactly rimF and rimB, and the face's own rim is the sag at cF in
// its frame. Intersections accept a point a few ulps beyond an edge (exact_face.h), so
// neighbouring faces overlap by rounding instead of leaving a crack: a ray from inside the
// glass always leaves through one of the element's faces.
//
// Cemented groups. The surface between two glasses is ONE face (named after the element in
// front, L2.back, with the alias L3.front; Prescription::aliasesOf), with glass on both
// sides. It is exact out to rc = the smaller element's mechanical radius, where the two
// glasses stop touching. If the other element is larger, its part of the interface beyond
// rc is a flat annular step at the height of the shared face's rim (its flat2 if it is the
// element in front, flat1 if it is behind), and each element has its own edge:
//
//         r
//         ^      A.rimF       rimC       B.rimB
//     R_A |        +-- A.edge --+
//         | A.flat1|            | A.flat2: the step, plane z = rimC, r from rc to R_A
//      rc |        +            +-- B.edge --+
//         |       /     A       )     B      | B.flat2
//         |      /             )             +
//         |     ( A.front     ) shared face   \ B.back
//       0 +-----+-------------+----------------+--> z
//
// With equal radii there is no step and both edges start at rimC.
//
// Sizes. The element's mechanical radius R is the largest mechanical semi-diameter of its
// surfaces (a surface without one counts with its clear semi-diameter): a lens has one
// outer diameter, and the smaller side gets a wider flat (as lens drawings in OpticStudio
// do). Every lens surface needs a clear semi-diameter (ModelError otherwise: the scene needs
// sizes). Thickness must stay positive everywhere from the axis to R: front and back faces
// that cross, or flats that cross, are a ModelError naming the element
// ("L3: negative edge thickness -0.4 mm at r = 12.9 mm"). Neighbouring elements across an
// air gap must not overlap either.
//
// Anamorphic faces (toroidal, biconic). Their rim on a circle is a curve, not a plane, so no
// flat or step can meet it: such a face runs out to the element's mechanical radius R (its
// clear semi-diameter only sizes the sequential aperture), and the edge cylinder ends on the
// face itself (CylinderPatch rim curves, exact_face.h). A cemented anamorphic face between
// elements of different radii would need a curved step: ModelError. Thickness and air gaps
// are checked at 17 azimuths over a quarter turn as well as the radii (the sags are even in x
// and in y); rimZ is NaN and rimZLo, rimZHi enclose the rim.
//
// Placement. Surface 1's vertex is at z = 0 and z accumulates the thicknesses (negative
// after a mirror), as in tracer/sequential/sequential_model.cpp; faces and flats are placed at
// their z along the element's axis (LensSolid::placement), the edge cylinder with that frame
// itself. In a coaxial system the placement is the identity and z is global. After a coordinate
// break (geometry/surface_frames.h) an element sits on the axis of its front surface's
// frame; a break between an element's faces (a wedge, a tilted face) is a ModelError, and
// neighbours on different axes are not checked against each other for overlap. Mirrors in
// air take their surface's frame. Elements traversed toward -z (after a mirror) have their
// front at the larger z.
//
// Media. A SurfacePatch's normal is +z at its vertex, so mediumFront is the medium on the
// face's +z side and mediumBack the one on its -z side (scene.h). These are geometric: the
// glass lies on the side of the face toward the element's other face, whichever way light
// travels there. The edge's normal points outward: air outside (mediumFront), glass inside.
// One Medium is registered per distinct Material (air is medium 0).
//
// Mirrors.
//  * A second-surface mirror (Mangin: glass, then a silvered back, then back through the
//    glass) is one element whose back face is a MirrorFace with glass on the inner side and
//    air behind it. The return pass's exit surface is the front face again: its name becomes
//    an alias of the front face rather than a second object.
//  * A mirror in air is a single MirrorFace (named M1, M2, ...; part = its own name) sized to
//    its clear semi-diameter, with air on both sides: a thin front-surface mirror without a
//    substrate for now. A central hole (Surface::innerSemiDiameterMm, a Cassegrain primary)
//    makes its aperture the annulus from the hole to the clear semi-diameter: light crosses
//    the mirror's surface freely inside the hole.
//  * A mirror that coincides with a face of an element (same vertex and shape: a Maksutov's
//    spot secondary, aluminised on the corrector) is cut out of that face: the spot is a
//    MirrorFace disc with the face's media, the face keeps the annulus around it.
//  * In general a surface that coincides with one already built (a repeated pass through
//    the same glass) adds its names as aliases of that face instead of a second copy.
//
// Holes. Only mirrors in air may have one. A hole in a lens element or in a spot mirror on a
// lens face would need a bore through the glass: ModelError ("holes in lens elements are not
// modelled"). A surface that repeats a face already built must have the same hole as it.
//
// Other surfaces (object, dummy planes, the stop, the image) get no objects here: the
// mechanics builder makes the stop plate and the scene builder adds the image. A hole on
// such a surface only vignettes sequential rays (a Zemax obscuration on a dummy plane); in
// the scene, whatever casts that shadow (the secondary mirror, a spider) must be an object.

#include <ostream>
#include <string>
#include <vector>

#include "geometry/scene.h"
#include "lensdata/prescription.h"

namespace veil {

struct LensSolidOptions {
    std::string edgeProperty = "lens_edge";  // butt ends
    std::string flatProperty = "lens_flat";  // flats and steps
    // Refracting faces; empty = each face takes its Surface::coating (which may itself be
    // empty: the scene's default for lens faces).
    std::string opticalFaceProperty;
    // Mirror faces; empty = Surface::coating.
    std::string mirrorProperty;
};
std::ostream& operator<<(std::ostream& os, const LensSolidOptions& o);

// One side of an element: where it meets air (an optical face and maybe a flat) or its
// cemented neighbour (the shared face and maybe a step).
struct LensSide {
    int surface = -1;           // prescription index of the optical surface
    SurfaceShape shape;         // its shape, local frame at the vertex
    double vertexZMm = 0.0;     // z of its vertex along the element's axis (placement)
    double faceRadiusMm = 0.0;  // the exact face ends here: clear sd, or rc when cemented
    double rimZMm = 0.0;        // vertexZ + sag(faceRadius): plane of the flat or step
    // An enclosure of the rim's z: rimZMm itself for a surface of revolution; for an
    // anamorphic face, whose rim is a curve (rimZMm is NaN), the range of its sag there.
    double rimZLoMm = 0.0, rimZHiMm = 0.0;
    bool cemented = false;
};
std::ostream& operator<<(std::ostream& os, const LensSide& s);

// The solid of one lens element, in global coordinates (mm).
struct LensSolid {
    std::string name;  // "L4"
    Material material;
    double edgeRadiusMm = 0.0;  // mechanical radius R: the edge cylinder
    LensSide front;             // the side light enters first
    LensSide back;
    double direction = 1.0;  // +1 when back lies at +z of front, -1 after an odd number of mirrors
    // The element's axis: its z values (vertexZMm, rimZMm, frontZ(), backZ()) are local z in
    // this frame. Identity for coaxial systems, where they are global z; after a coordinate
    // break, the front surface's frame moved along its axis to where the unfolded z is 0.
    Frame placement;

    // z of the front or back boundary at radial distance r <= edgeRadiusMm: the face inside
    // faceRadius, the flat (rimZ) beyond.
    // Sides of revolution only (an anamorphic side throws std::logic_error: use the next two).
    double frontZ(double rMm) const;
    double backZ(double rMm) const;
    // z of the front or back boundary at (x, y), r <= edgeRadiusMm, every side.
    double frontZAt(double xMm, double yMm) const;
    double backZAt(double xMm, double yMm) const;
};
std::ostream& operator<<(std::ostream& os, const LensSolid& s);

// The solids of a prescription's lens elements, checked (sizes present, positive thickness
// from the axis to the edge, no overlap with a neighbour across an air gap). Elements that
// repeat a pass through glass already listed are left out. Throws ModelError.
std::vector<LensSolid> lensSolids(const Prescription& p);

// The prescription's elements without the repeated passes through glass already listed (the
// way back out of a cemented Mangin mirror crosses its front element again): one per piece of
// glass, as the solids and the mounts build them.
std::vector<Element> distinctElements(const Prescription& p);

// An image inside a medium (an immersion objective's specimen in water, a sensor under glass
// cemented to it): the gap before the image holds glass, which a solid cannot leave open.
// Every function here that builds solids first gives such a prescription a face
// kImmersedImageClearanceMm behind the image, of the image surface's shape, where the medium
// ends, named as the element's back face (L12.back), an absorber (the medium goes on in truth:
// light past the sensor is lost in it). A sensor at the image then lies inside the medium and
// meets the light as it arrives there: no interface, no Fresnel loss and no total internal
// reflection at the image. The added face has no sequential surface
// (SceneObject::sequentialSurface -1). Returns its index, or -1 where the image is in air.
inline constexpr double kImmersedImageClearanceMm = 1e-3;
int endImmersedImage(Prescription& p);

// The thinnest point of an element (Thickness: first == second == its index in the solids)
// or the narrowest air gap between neighbours (AirGap: second == first + 1), mm. Negative
// values are overlaps; lensSolids() requires thickness > 0 and gaps >= -1e-9 mm.
struct LensSolidProblem {
    enum class Kind { Thickness, AirGap };
    Kind kind = Kind::Thickness;
    int first = 0, second = 0;  // indices into the solids
    double valueMm = 0.0;
    double atRadiusMm = 0.0;
    bool atEdge = false;  // Thickness: the edge between the flats (or rims) is the thinnest
};

// The solids as lensSolids() plans them, without the thickness and overlap checks: instead,
// `measures` gets the thinnest point of every element and the narrowest gap of every pair
// of neighbours that are compared (cemented neighbours and neighbours across a mirror or a
// coordinate break are not). Structural errors (missing sizes, holes in glass) still throw.
std::vector<LensSolid> measuredLensSolids(const Prescription& p,
                                          std::vector<LensSolidProblem>& measures);

// Adds the faces of every lens element and every mirror to the scene (see the top of this
// file). Throws ModelError for missing sizes, negative thickness, overlapping elements and
// name clashes.
void addLensSolids(const Prescription& p, Scene& scene, const LensSolidOptions& options = {});

}  // namespace veil
