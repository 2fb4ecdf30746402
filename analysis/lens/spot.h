#pragma once
// Spot diagrams: real rays over the pupil, landed on the image surface.

#include <ostream>
#include <vector>

#include "geometry/vec.h"
#include "tracer/sequential/ray_aiming.h"

namespace veil {

class SequentialModel;

struct SpotOptions {
    int rings = 8;  // hexapolar rings: ring k holds 6k rays, plus the centre
    AimMode aim = AimMode::Real;
    bool clipApertures = true;
};

struct SpotResult {
    int field = 0;
    int wavelength = 0;
    int raysTraced = 0;
    int raysLanded = 0;  // reached the image surface
    Vec2 chiefMm{0.0};   // chief ray on the image surface (traced without apertures)
    Vec2 centroidMm{0.0};
    double rmsRadiusMm = 0.0;       // about the centroid
    double rmsRadiusChiefMm = 0.0;  // about the chief ray
    double maxRadiusMm = 0.0;       // about the centroid (GEO radius)
    std::vector<Vec2> pointsMm;
};
std::ostream& operator<<(std::ostream& os, const SpotResult& s);

// Hexapolar pupil sampling: (px, py) in the unit disk; ring k of `rings` has radius k/rings
// and 6k rays, which samples the disk with nearly uniform density.
std::vector<Vec2> hexapolarPupil(int rings);

SpotResult computeSpot(const SequentialModel& model, const RayAimer& aimer, int field, int w,
                       const SpotOptions& options = {});

}  // namespace veil
