// Mechanics from a prescription: barrel, seats, retainers, spacers, stop, field stop, baffles,
// vanes. User documentation: docs/format.md, section [mechanics]; the model is summarised in
// mechanics.h.
//
//   key                  type                      default        meaning
//   chord_tolerance_mm   number > 0                0.01           largest chord error
//   contact_gap_mm       number > 0                0.001          air between touching parts
//   property             string                    ""             default for every part
//   lens_edges           { property }                             lens butt ends and flats
//   barrel               bool | { enabled, wall_mm = 2, clearance_mm = 0.05, property }
//   retainers            bool | { enabled, width_mm = 1.5, property }
//   spacers              bool | { enabled, min_length_mm = 0.1, property }
//   stop                 bool | { enabled, edge_mm = 0.05, thickness_mm (<= 0.5 auto),
//                                 bevel_deg = 45, property, edge_property }
//   field_stop           { enabled, z_mm | before_image_mm = 1, radius_mm, thickness_mm = 0.5,
//                          property }                                 off when absent
//   baffles              [{ z_mm, inner_radius_mm, thickness_mm = 0.5, property, enabled }]
//   vanes                { enabled, count, depth_mm, thickness_mm = 0.5, from_z_mm, to_z_mm,
//                          property }                                 off when absent
//   parts                [{ name, profile_mm = [[r, z], ...], property, enabled }]
//
// Lengths in mm; z is global (surface 1's vertex at 0). Radii (r) are distances from the axis.

#include "geometry/mechanics.h"

#include <iomanip>
#include <sstream>

#include "geometry/mechanics_builder.h"
#include "geometry/surface_frames.h"
#include "lensdata/prescription.h"

namespace veil {

using mechanics_detail::MechanicsBuilder;

// Mechanics Functions

std::vector<MechanicalPart> buildMechanics(const Prescription& prescription,
                                           const MechanicsSpec& spec,
                                           std::vector<std::string>* notes) {
    // Every part is a solid of revolution about the global axis: a lens whose surfaces a
    // coordinate break tilts or decenters would be mounted where it is not.
    // (A tilted image plane alone mounts nothing off the axis.)
    const int off = firstSurfaceOffAxis(prescription, surfaceFrames(prescription));
    if (off >= 0 && off < prescription.imageIndex()) {
        const Surface& s = prescription.surfaces[off];
        const std::string name = s.name.empty() ? "surface " + std::to_string(off) : s.name;
        int lastBreak = off - 1;  // the break that took it off the axis
        while (!prescription.surfaces[lastBreak].coordinateBreak) --lastBreak;
        const Surface& b = prescription.surfaces[lastBreak];
        throw ModelError("mechanics",
                         "the mount generator builds barrels, spacers and stops about one "
                         "axis, and " + name + " is tilted or decentered off it by the "
                         "coordinate break " + (b.name.empty() ? "surface " + std::to_string(lastBreak) : b.name) +
                         ": leave [mechanics] out of this scene and bring the mounts in as "
                         "[[mesh]] parts placed in global coordinates");
    }
    if (const int a = prescription.firstAnamorphic(); a >= 0) {
        const Surface& s = prescription.surfaces[a];
        throw ModelError("mechanics",
                         "the mount generator seats lenses on rims of revolution, and " +
                             (s.name.empty() ? "surface " + std::to_string(a) : s.name) + " is " +
                             s.anamorphic->label() +
                             ": leave [mechanics] out of this scene and bring the mounts in as "
                             "[[mesh]] parts");
    }
    MechanicsBuilder builder(prescription, spec, notes);
    return builder.build();
}

// Printing

std::ostream& operator<<(std::ostream& os, const NamedTriangleRange& r) {
    os << r.name << "[" << r.firstTriangle << ", +" << r.triangleCount << ")";
    if (!r.property.empty()) os << " " << r.property;
    return os;
}

std::ostream& operator<<(std::ostream& os, const MechanicalPart& p) {
    os << "MechanicalPart{" << p.name;
    if (!p.property.empty()) os << ", property " << p.property;
    os << ", " << p.mesh << ", " << p.segments << " segments, ranges";
    for (const NamedTriangleRange& r : p.namedRanges) os << " " << r;
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const MechanicsSpec& s) {
    os << "MechanicsSpec{chord " << s.chordToleranceMm << " mm, gap " << s.contactGapMm << " mm";
    if (!s.property.empty()) os << ", property " << s.property;
    if (s.barrel.enabled)
        os << ", barrel wall " << s.barrel.wallMm << " clearance " << s.barrel.clearanceMm;
    if (s.retainers.enabled) os << ", retainers " << s.retainers.widthMm;
    if (s.spacers.enabled) os << ", spacers";
    if (s.stop.enabled) {
        os << ", stop edge " << s.stop.edgeMm;
        if (s.stop.thicknessMm) os << " thickness " << *s.stop.thicknessMm;
        os << " bevel " << s.stop.bevelDeg << " deg";
    }
    if (s.fieldStop.enabled) os << ", field stop r " << s.fieldStop.radiusMm;
    int baffles = 0;
    for (const auto& b : s.baffles) baffles += b.enabled;
    if (baffles > 0) os << ", " << baffles << " baffles";
    if (s.vanes.enabled) os << ", " << s.vanes.count << " vanes";
    for (const auto& p : s.parts)
        if (p.enabled) os << ", part " << p.name;
    return os << "}";
}

}  // namespace veil
