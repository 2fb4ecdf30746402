#pragma once
// Fields given as image heights, resolved into object space before anything is traced.
//
// A lens file may give its fields as image heights (ZMX FTYP 2 and 3; TOML
// fields_paraxial_image_mm and fields_real_image_mm), common in camera lenses. Everything in
// veil that traces works from object space (sources, ray aiming, mechanics, ghosts), so the
// heights are turned into what reaches them: field angles for an object at infinity, object
// heights otherwise, at the primary wavelength.
//
//   paraxial image height  the paraxial chief ray (through the entrance pupil centre) meets
//                          the paraxial image plane (the back focus for an object at
//                          infinity) at the height; the map from tan(angle) (or object
//                          height) to it is linear, so one unit ray solves every field exactly
//   real image height      the real chief ray (aimed through the stop centre, no apertures)
//                          meets the image surface at the height; solved along the field's
//                          azimuth by secant steps from the paraxial answer, to 1e-9 of the
//                          height (and at least 1e-9 mm)
//
// The image is reached along the field's own azimuth: (x, y) heights give the field whose
// chief ray lands at (x, y) in a rotationally symmetric lens. The given heights stay in
// SystemData::imageHeights and givenFieldKind, for the reports.

#include "lensdata/prescription.h"

namespace veil {

class GlassCatalog;

// The prescription with its image-height fields resolved (unchanged for angle and object
// height fields). Throws ModelError naming the field when no field reaches a height (an
// afocal lens, a height beyond what any chief ray reaches, a real chief ray that fails).
Prescription resolveImageHeightFields(const Prescription& p, const GlassCatalog& catalog);

}  // namespace veil
