#pragma once
// Paraxial pupils and the system aperture.
//
// The system aperture (EPD, image-space F/#, object-space NA or float by stop) fixes the
// paraxial marginal ray, and with it the stop radius; the entrance pupil is the paraxial
// image of the stop in object space. All z positions are global (surface 1 vertex at 0).

#include <ostream>

#include "tracer/sequential/sequential_model.h"

namespace veil {

struct PupilData {
    int wavelength = 0;             // index the pupil was computed at
    double stopRadiusMm = 0.0;      // paraxial marginal ray height at the stop
    double entrancePupilZMm = 0.0;  // global z of the entrance pupil (infinite if telecentric)
    double entrancePupilRadiusMm = 0.0;
    double objectZMm = 0.0;    // global z of the object plane (-inf at infinity)
    double marginalNu0 = 0.0;  // reduced angle of the marginal ray in object space
    double marginalY1 = 0.0;   // marginal ray height at surface 1
};
std::ostream& operator<<(std::ostream& os, const PupilData& p);

// Computes the pupil at wavelength w (normally the primary). Throws ModelError if the
// aperture definition cannot be used (NA with an object at infinity, float by stop without
// a stop size, a stop that no paraxial ray reaches).
PupilData computePupil(const SequentialModel& model, int w);

// Effective focal length 1/power at wavelength w (positive for a converging system, also
// through mirrors). Infinite for an afocal system.
double effectiveFocalLengthMm(const SequentialModel& model, int w);

}  // namespace veil
