#pragma once
// The forward stage of a render pass (tracer/render.h, the seed's figure 7, second stage):
// photons leave the sources through the interaction step (flux mode). Until their first
// scatter they split at every interface (every Fresnel branch, culled below
// RenderOptions::photonMinRelativeFlux of the photon); then one child by weight, with Russian
// roulette. They add three images:
//   visible    a photon of the sun, a collimated or a point source that reaches the detector
//              without scattering, spread over the pixels within the detector smoothing disk
//              (RenderOptions::detectorRadiusPixels, shrinking with the radius)
//   caustic    gathered at the pass's view points (a spatial hash of cells 2r wide) when the
//              photon has seen specular events only: weight x flux x bsdf / (share pi r^2),
//              share the view point's own part of its disk (viewPointAreaShare)
//   secondary  the same once the photon has scattered before
// and, with path criteria, the same three per criterion on the joined paths.
// Deterministic: photon i of pass k draws from CounterRng(passSeed(seed, k, 1), i), blocks of
// 4096 photons are reduced in a fixed order.

#include <array>
#include <cstdint>
#include <vector>

#include "tracer/backward.h"
#include "tracer/path_judge.h"
#include "tracer/render.h"

namespace veil {

struct PhotonImages {
    std::vector<double> visible, caustic, secondary;  // flux per pixel
    // With criteria: [criterion] {visible, caustic, secondary}.
    std::vector<std::array<std::vector<double>, 3>> by;
    uint64_t photons = 0, segments = 0, gathers = 0, pruned = 0;
};

// Pass k's photons, gathered at `back`'s view points with radius radiusMm.
PhotonImages tracePhotons(const TransportScene& ts, const DetectorImage& detector,
                          const BackwardResult& back, const RenderOptions& options,
                          const PathJudge* judge, int k, double radiusMm);

}  // namespace veil
