#pragma once
// Small prescriptions built in code for tests. Model glasses make the indices exact at the
// d line (a model glass reproduces nd exactly), so analytic formulas apply without a
// catalog.

#include <cmath>

#include "lensdata/prescription.h"

namespace veil::test {

// Starts a prescription with an object at `objectDistanceMm` (kInfinity for infinity), one
// wavelength (the d line) and the given entrance pupil diameter.
inline Prescription startLens(double objectDistanceMm, double epdMm) {
    Prescription p;
    p.system.aperture = {SystemAperture::Kind::EntrancePupilDiameter, epdMm};
    p.system.wavelengths = {{587.5618, 1.0}};
    p.system.fields = {{0.0, 0.0, 1.0}};
    Surface object;
    object.thicknessMm = objectDistanceMm;
    p.surfaces.push_back(object);
    return p;
}

inline Surface surface(double radiusMm, double thicknessMm, Material m = Material::air()) {
    Surface s;
    s.curvature = radiusMm == 0.0 || std::isinf(radiusMm) ? 0.0 : 1.0 / radiusMm;
    s.thicknessMm = thicknessMm;
    s.material = m;
    return s;
}

inline void finishLens(Prescription& p) {
    p.surfaces.push_back(Surface{});  // image
    p.assignNames();
    p.validate();
}

// An equiconvex singlet of model glass nd 1.5 (radii +-radiusMm) in an f/- beam of 10 mm,
// both faces sized clearSd, mechSd; the image 50 mm behind.
inline Prescription equiconvexSinglet(double radiusMm, double centreMm, double clearSd,
                                      double mechSd) {
    Prescription p = startLens(kInfinity, 10.0);
    Surface s1 = surface(radiusMm, centreMm, Material::model(1.5, 60.0));
    s1.clearSemiDiameterMm = clearSd;
    s1.mechSemiDiameterMm = mechSd;
    Surface s2 = surface(-radiusMm, 50.0);
    s2.clearSemiDiameterMm = clearSd;
    s2.mechSemiDiameterMm = mechSd;
    p.surfaces.push_back(s1);
    p.surfaces.push_back(s2);
    finishLens(p);
    return p;
}

}  // namespace veil::test
