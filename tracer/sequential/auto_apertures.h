#pragma once
// Automatic clear semi-diameters, as lens design programs compute them: the largest ray
// height on each surface over every field and wavelength, for rays around the rim of the
// pupil and the chief ray (real aiming), without vignetting.

#include "tracer/sequential/sequential_model.h"

namespace veil {

// Returns a copy of the prescription in which every surface without a clear
// semi-diameter (0) gets the traced one, flagged semiDiameterAutomatic. Surfaces that have
// one keep it. rimRays: rays around the pupil rim per field and wavelength.
Prescription withAutomaticSemiDiameters(const SequentialModel& model, int rimRays = 64);

}  // namespace veil
