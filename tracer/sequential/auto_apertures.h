#pragma once
// Automatic clear semi-diameters, as lens design programs compute them: the largest ray
// height on each surface over every field and wavelength, for rays around the rim of the
// pupil and the chief ray (real aiming), in the beam each field's vignetting factors leave
// (Field::vdx...: as Zemax and CODE V size their automatic apertures), clipped nowhere.

#include "tracer/sequential/ray_status.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

// The traced semi-diameter of every surface (the stop's: its real radius from the pupil
// solve), whatever the file gives. rimRays: rays around the pupil rim per field and
// wavelength. `failures` (optional): per surface, how many of the bundle's rays failed there,
// and how the last one failed; and how many rays ray aiming found no real ray for.
struct BundleFailures {
    std::vector<int> count;
    std::vector<RayStatus> last;
    int aim = 0;
};
std::vector<double> tracedSemiDiameters(const SequentialModel& model, int rimRays = 64,
                                        BundleFailures* failures = nullptr);

// For each mirror in air without a hole, the hole the light needs where it comes back through
// the mirror's place after leaving it (a Cassegrain primary, whose secondary sends the light
// back through it to the image): the largest radius at which the bundle's later segments
// cross the mirror's surface within its clear semi-diameter, 5 % wider; 0 where no light
// comes back. Sequential programs trace past such a mirror and files rarely give the hole; a
// solid disc would stop all the light. A hole as wide as the mirror is returned as it is:
// the caller decides.
std::vector<double> returningLightHoles(const SequentialModel& model, int rimRays = 64);

// Returns a copy of the prescription in which every surface without a clear
// semi-diameter (0) gets the traced one, flagged semiDiameterAutomatic. Surfaces that have
// one keep it. A lens or mirror surface that no ray of the bundle crosses (the rays miss it,
// or fail before it) keeps none, with a Warning naming where and how the rays failed.
Prescription withAutomaticSemiDiameters(const SequentialModel& model, int rimRays = 64);

}  // namespace veil
