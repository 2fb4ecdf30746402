#pragma once
// Lens sizes that build. A lens file's semi-diameters are often not mechanical sizes: patents
// give clear apertures, programs write what they computed, and the elements they describe
// can overlap their neighbours or have negative edges (lens_solid.h refuses both). The fit
// keeps the file's sizes wherever they build and changes only the elements that do not:
//
//   1. The sizes the light needs: the traced ray bundle's semi-diameter on each face (the
//      caller traces it: tracer/sequential/auto_apertures.h), never more than the file's.
//   2. Each element that is too thin (thickness at or below zero anywhere from the axis to
//      its edge) shrinks along one path from the file's sizes to the bundle's, first its
//      outer radius (mech_sd) down to its largest clear semi-diameter, then its clear
//      semi-diameters down to the bundle's; the first point of that path whose edge is
//      min(0.5 mm, centre thickness / 4) thick is kept (or, if none is, the bundle's sizes,
//      if their edge is positive).
//   3. Each pair of neighbours that overlap across an air gap shrinks the same way: the
//      front element alone, the back one alone, or both together, whichever keeps the
//      larger sum of outer radii, until the gap is min(0.1 mm, axial gap / 2) wide (or, if
//      it never is, down to the bundle's sizes, if the gap there is not negative).
//   4. A lens whose clear apertures themselves cross (the bundle needs more than the glass
//      allows) is a ModelError naming the two faces, the radius where the light needs them
//      and the largest semi-diameter that fits.
//
// Every change is returned, per element, with the problem that made it.

#include <functional>
#include <string>
#include <vector>

#include "lensdata/prescription.h"

namespace veil {

struct LensSizeChange {
    std::string element;  // "L2"
    struct Face {
        std::string name;  // "L2.front"
        double clearBeforeMm = 0.0, clearAfterMm = 0.0;
    };
    std::vector<Face> faces;  // front, back
    double radiusBeforeMm = 0.0, radiusAfterMm = 0.0;
    std::string reason;  // what the file's sizes did: "overlapped L3: air gap -0.47 mm at ..."
    FileLoc origin;      // the element's front surface in the lens file
};

struct LensFit {
    Prescription prescription;  // the input with sizes changed where needed
    std::vector<LensSizeChange> changes;
};

// bundle(): per surface, the traced bundle's semi-diameter (0 where unknown: the file's size
// is then the least the surface needs); called only when the file's sizes do not build.
// Throws ModelError when the light itself needs glass that cannot be there, and for what
// lensSolids() refuses whatever the sizes (missing sizes, holes in glass).
LensFit fitLensSizes(const Prescription& p,
                     const std::function<std::vector<double>()>& bundleSemiDiameterMm);

// One line per change, for reports ("L2: outer radius 22.000 -> 20.950 mm, ...").
std::string describe(const LensSizeChange& c);

}  // namespace veil
