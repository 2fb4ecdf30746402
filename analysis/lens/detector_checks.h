#pragma once
// Warnings for a detector that is probably misplaced: it would read a number without saying
// that the number means little. Checked once per command, before any tracing:
//
//   inside a lens element   its centre lies in the glass of an element (a free detector's
//                           z_mm inside the lens): the light it records has not left it
//   far from the image      an imaging lens (finite focal length, image at a finite
//                           distance) focuses more than max(1 mm, 2 % of the EFL) away from
//                           it: what it records is out of focus (or not yet through the lens)
//   outside the image       near the image plane, but no point of the system's field
//                           circle (the paraxial image heights, +10 %) falls on it
//   light from behind       the image-space light travels toward its back (its sensitive
//                           side faces away): the image is recorded as seen from behind
//
// Each warning names the detector, the file and line of its [detector] entry when there is
// one, and the distances involved. Stray light detectors placed on purpose elsewhere get the
// warning too: it is a note, not an error.

#include <vector>

#include "lensdata/prescription.h"

namespace veil {

struct SceneSpec;
struct SceneGeometry;

std::vector<ImportNote> detectorPlacementWarnings(const SceneSpec& spec,
                                                  const SceneGeometry& geometry);

}  // namespace veil
