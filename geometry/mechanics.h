#pragma once
// Mechanical parts of a lens built from its prescription and the scene's [mechanics] table:
// barrel with lens seats, retaining rings, spacers, the aperture stop with its knife edge, a
// field stop, baffles and vanes. Every part is a solid of revolution about the optical axis
// (geometry/revolve.h), a closed outward triangle mesh in global coordinates (surface 1's
// vertex at z = 0, as in tracer/sequential/sequential_model.h), named as users type it in criteria.
//
//   TomlDocument doc = TomlDocument::fromFile("scene.toml");
//   Prescription rx = readTomlPrescription(doc, GlassCatalog::builtIn());
//   std::optional<MechanicsSpec> spec = readMechanics(doc);   // nullopt: no [mechanics]
//   doc.checkAllUsed();
//   std::vector<MechanicalPart> parts = spec ? buildMechanics(rx, *spec) : {};
//
// A double Gauss in section (r up, z to the right; | glass, # parts):
//
//     ####################################################  barrel (outer wall)
//     #######          ######             ###########  ###  barrel bore: a seat per lens
//   re|L1|  spacer1  |L2|L3|  spacer3a ##  spacer3b |L4|L5|   spacer5  |L6|re
//   ta|  |           |  |  |          #st#          |  |  |            |  |ta
//   in|  |           |  |  |          #op#          |  |  |            |  |in
//   --+--+-----------+--+--+-----------\/-----------+--+--+------------+--+---- axis
//
// What is modelled, and how (docs/format.md has the user's view):
//   - Lens bodies: each lens element is the region between its two surfaces out to its
//     mechanical radius R (the larger mech_sd, or sd, of its faces), exactly as the lens
//     solid builds it (geometry/lens_solid.h): each face exact to its clear semi-diameter
//     and flat beyond, a cemented face exact to the smaller element's R. Cemented elements
//     form one group. Mirrors without glass are thin sheets (sag out to mech_sd, the larger
//     of the mirror's sizes; solid across a central hole, so parts keep clear of it); no
//     mirror cells or substrates.
//   - Light paths: the gaps between physical surfaces (stop and other non-glass,
//     non-mirror surfaces are passed through), each with a beam radius, the largest clear
//     semi-diameter along it.
//   - Stack: bodies sorted along z, with a region before, between and after them. A region
//     is "simple" when exactly one light path crosses it and that path runs from one
//     neighbour to the other (a path crosses a region when its end points lie on both sides
//     of it in the stack order, or in it); otherwise (folded systems: light crossing
//     several times, or passing a mirror) it is "open" and gets no spacers or retainers.
//   - Barrel: a tube from the first to the last part, outer radius = largest bore + wall.
//     Its bore is stepped: at a body, its radius + clearance (widened for light of other
//     paths passing outside it); in a simple region, the smaller neighbour's radius +
//     clearance (the larger lens rests on the step: its seat), but at least the beam +
//     0.5 mm of spacer wall; in an open region, everything in it (mirrors, beams, both
//     neighbours). Plates ask for 1 mm of radial room outside their aperture.
//   - Spacers fill simple regions between neighbours (lens groups, the stop plate,
//     baffles, vanes, the field stop): inner radius = the larger clear radius of the two
//     faces they face, outer = bore - contact gap, flat ends a contact gap from the glass
//     computed from the exact sags over the radii the spacer's mesh occupies. spacer<k>
//     sits behind Lk (spacer0 in front of L1); plates split it into spacer<k>a, b, ...
//   - Retainers: rings in front of the first and behind the last part, in simple end
//     regions only (not at a mirror, never across the object or image plane); inner
//     radius = the clear radius they face + width * tan(largest field angle).
//   - Stop: an annular plate at the stop surface, inner radius = its sd (ModelError if the
//     stop has none), outer = bore - gap. Its inner cylinder, the knife edge, is exactly
//     edge_mm wide (named stop.edge); from it both faces bevel out at bevel_deg to the full
//     thickness. A stop on a lens face sits just outside the glass, on the air side.
//   - User parts ([[mechanics.parts]]): a closed (r, z) profile revolved as it is given,
//     after the barrel (they do not widen it); their radius enters the segment count.
//   - Parts never touch: every pair in contact keeps contact_gap_mm of air, so no two
//     surfaces coincide. Every part shares one angular segment count, from the chord
//     tolerance at the largest radius, so clearances in (r, z) carry over to the meshes.
//   - Checks: every mesh is closed, free of self-intersections and outward (mesh_check.h):
//     ModelError naming the part otherwise. Part against part: meshesIntersect (CGAL).
//     Part against glass and mirrors: exact sags in the (r, z) plane, sampled every 5 um
//     along both outlines, covering the mesh's chords (mesh radii between r cos(pi / N)
//     and r); deeper than 1e-9 mm at a sample is a collision. A ModelError names both:
//       "baffle1: collides with L6 (at r = 4.997 mm, z = 30.289 mm, 1.4359 mm deep)".

#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include "geometry/triangle_mesh.h"
#include "geometry/vec.h"

namespace veil {

struct Prescription;

class TomlDocument;  // lensdata/toml_document.h
class TomlTable;

// MechanicsSpec: the [mechanics] table, every length in mm, every property a name from
// [properties.*] (empty = the [mechanics] property, and if that is empty too, the scene's
// default for mechanics). Defaults are those of docs/format.md.
// Work limits, checked before any mesh is built (docs/robustness.md): every part shares
// one angular segment count, the smallest that keeps the chord error at the largest radius
// within chord_tolerance_mm, and it may not exceed kMaxMechanicsSegments (a ModelError
// "mechanics" says which radius and tolerance ask for more); a user part's profile has at
// most kMaxPartProfilePoints points (its simplicity check is quadratic).
inline constexpr int kMaxMechanicsSegments = 4096;
inline constexpr size_t kMaxPartProfilePoints = 4096;

struct MechanicsSpec {
    double chordToleranceMm = 0.01;
    double contactGapMm = 0.001;
    std::string property;  // default for every part
    // lens_edges: the property of the lens elements' butt ends and flats (Lk.edge,
    // Lk.flat1, Lk.flat2). Nothing is built for it here; the scene applies it to the lens
    // solids. Empty = the scene default.
    std::string lensEdgeProperty;

    struct Barrel {
        bool enabled = true;
        double wallMm = 2.0;
        double clearanceMm = 0.05;  // radial, lens edge to bore; must exceed the chord error
        std::string property;
    } barrel;
    struct Retainers {
        bool enabled = true;
        double widthMm = 1.5;  // axial
        std::string property;
    } retainers;
    struct Spacers {
        bool enabled = true;
        double minLengthMm = 0.1;  // less axial room than this: no spacer
        std::string property;
    } spacers;
    struct Stop {
        bool enabled = true;
        double edgeMm = 0.05;               // width of the knife edge (inner cylinder)
        std::optional<double> thicknessMm;  // unset: up to 0.5 mm, less where glass is near
        double bevelDeg = 45.0;             // bevel face against the plate's flat face
        std::string property;
        std::string edgeProperty;  // stop.edge; empty = the stop's property
    } stop;
    struct FieldStop {
        bool enabled = false;
        std::optional<double> zMm;   // mid-plane, global z
        double beforeImageMm = 1.0;  // used when zMm is unset: that far before the image
        double radiusMm = 0.0;
        double thicknessMm = 0.5;
        std::string property;
    } fieldStop;
    struct Baffle {
        bool enabled = true;
        double zMm = 0.0;  // mid-plane, global z
        double innerRadiusMm = 0.0;
        double thicknessMm = 0.5;
        std::string property;
    };
    std::vector<Baffle> baffles;
    struct Vanes {
        bool enabled = false;
        int count = 0;
        double depthMm = 0.0;  // radial, from the bore inward
        double thicknessMm = 0.5;
        double fromZMm = 0.0;  // first and last vane mid-planes, global z
        double toZMm = 0.0;
        std::string property;
    } vanes;
    // [[mechanics.parts]]: solids of revolution the user draws as a profile in (r, z), for
    // what the builder does not make from the prescription (a secondary mirror's holder, a
    // baffle tube through a primary's hole, a mirror cell, a sunshade). Built after the
    // barrel, meshed with the common segment count and checked like every part.
    struct Part {
        bool enabled = true;
        std::string name;
        std::vector<Vec2> profileMm;  // (r, z), counter-clockwise, r >= 0, simple
        std::string property;
    };
    std::vector<Part> parts;
};
std::ostream& operator<<(std::ostream& os, const MechanicsSpec& s);

// Reads the [mechanics] table of `doc` (marking its keys used); nullopt when the file has
// none. ParseError at the value at fault for wrong types, ranges or missing keys.
std::optional<MechanicsSpec> readMechanics(const TomlDocument& doc);
// Reads one [mechanics] table.
MechanicsSpec readMechanicsTable(const TomlTable& mechanics);

// A named group of a part's triangles, in the MeshRef sense (geometry/scene.h): triangles
// [firstTriangle, firstTriangle + triangleCount) of the part's mesh.
struct NamedTriangleRange {
    std::string name;      // "stop", "stop.edge", "barrel", ...
    std::string property;  // resolved: the part's (or stop.edge's) property, may be empty
    uint32_t firstTriangle = 0;
    uint32_t triangleCount = 0;
};
std::ostream& operator<<(std::ostream& os, const NamedTriangleRange& r);

struct MechanicalPart {
    std::string name;      // barrel, retainer1, retainer2, spacer<k>[a|b|...], stop, ...
    std::string property;  // resolved (part, else [mechanics] property); may be empty
    TriangleMesh mesh;     // global coordinates, closed and outward
    // The named objects the scene makes of it; together they cover the mesh exactly once.
    // One range named like the part, except the stop: "stop" and "stop.edge".
    std::vector<NamedTriangleRange> namedRanges;
    // The profile that was revolved: a counter-clockwise polygon in (r, z), mm; for 2D
    // layouts (mirror it to r < 0 for the lower half) and exact volumes.
    std::vector<Vec2> profile;
    int segments = 0;  // angular segments of the revolution (the same for every part)
};
std::ostream& operator<<(std::ostream& os, const MechanicalPart& p);

// Builds every enabled part, checks each mesh and every clearance. Parts come in z order of
// kind: barrel, retainers, spacers, stop, field stop, baffles, vanes, then the user's parts
// in the order given. Parts that do not fit
// (a spacer with no radial or axial room, a retainer behind a mirror) are left out; when
// `notes` is given, one line per part left out, moved or thinned says why. A line that
// starts with kMechanicsWarning changes the light the lens passes (a stop plate left out:
// the lens's own apertures limit it): the caller shows it as a warning. The stop plate goes
// against a face that reaches into its place (a meniscus bulging through the stop plane) and
// is left out where no plate fits at all. Throws ModelError naming the part
// (and what it collides with) on failure; ModelError naming the surface when a lens surface
// has neither sd nor mech_sd, or a semi-diameter beyond the rim of its conic.
inline constexpr std::string_view kMechanicsWarning = "warning: ";
std::vector<MechanicalPart> buildMechanics(const Prescription& prescription,
                                           const MechanicsSpec& spec,
                                           std::vector<std::string>* notes = nullptr);

}  // namespace veil
