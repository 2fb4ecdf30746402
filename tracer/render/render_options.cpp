#include "tracer/render/render_options.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace veil {

void RenderOptions::check() const {
    auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
    if (raysPerPixel == 0) fail("rays per pixel must be at least 1");
    if (photonsPerPass == 0) fail("photons per pass must be at least 1");
    if (balancePhotons && maxPhotonsPerPass < photonsPerPass)
        fail("the most photons per pass must be at least the first pass's");
    if (!(initialRadiusMm >= 0.0) || !std::isfinite(initialRadiusMm))
        fail("the initial radius must be a finite length >= 0 (0: automatic)");
    if (!(alpha > 0.0 && alpha < 1.0)) fail("alpha must lie in (0, 1)");
    if (!(minRelativeWeight >= 0.0 && minRelativeWeight < 1.0))
        fail("the minimum relative weight must lie in [0, 1)");
    if (!(viewPointRelativeWeight >= 0.0 && viewPointRelativeWeight <= 1.0))
        fail("the view point roulette threshold must lie in [0, 1]");
    if (maxSpecularDepth < 1) fail("the maximum specular depth must be at least 1");
    if (!(rouletteRelativeFlux >= 0.0 && rouletteRelativeFlux <= 1.0))
        fail("the roulette threshold must lie in [0, 1]");
    if (maxPhotonSegments < 1) fail("the maximum photon segments must be at least 1");
    if (!(photonMinRelativeFlux >= 0.0 && photonMinRelativeFlux < 1.0))
        fail("the photon cull threshold must lie in [0, 1)");
    if (ghostPhotonsPerPass == 0) fail("ghost photons per pass must be at least 1");
    if (!(photonRescueRelativeFlux > 0.0 && photonRescueRelativeFlux <= 1.0 &&
          photonRescueRelativeFlux >= photonMinRelativeFlux))
        fail("the photon rescue level must lie in [cull threshold, 1] and be > 0");
    if (areaSamples < 0 || areaSamples > 4096)
        fail("the area samples per view point must lie in [0, 4096]");
    if (!(detectorRadiusPixels >= 0.0 && detectorRadiusPixels <= 1000.0))
        fail("the detector smoothing radius must lie in [0, 1000] pixels");
    if (!(guideFraction >= 0.0 && guideFraction < 1.0))
        fail("the guided fraction of the pixel rays must lie in [0, 1)");
    if (!(photonGuideFraction >= 0.0 && photonGuideFraction < 1.0))
        fail("the guided fraction of the photons must lie in [0, 1)");
    if (!(scatterGuideFraction >= 0.0 && scatterGuideFraction < 1.0))
        fail("the guided fraction of the photons' scatters must lie in [0, 1)");
    if (!(weightWindow == 0.0 || (weightWindow >= 1.0 && weightWindow <= 1e6)))
        fail("the weight window must be 0 (off) or lie in [1, 1e6]");
    if (!(followLobesBelowDeg >= 0.0 && followLobesBelowDeg <= 90.0))
        fail("the half width below which lobes are followed must lie in [0, 90] degrees");
    if (!(splatLobesBelowDeg >= 0.0 && splatLobesBelowDeg <= 90.0))
        fail("the half width below which lobes are splatted must lie in [0, 90] degrees");
    if (lobeSplats < 1 || lobeSplats > 4096)
        fail("the splats per narrow lobe scatter must lie in [1, 4096]");
    if (!(aimedSplats >= 0.0 && aimedSplats <= 1.0))
        fail("the aimed share of a narrow lobe's splats must lie in [0, 1]");
    if (partDirections < 1 || partDirections > 1024)
        fail("the directions per part sample must lie in [1, 1024]");
    if (partSamples > kMaxPartSamples)
        fail("the part samples per pass must lie in [0, " + std::to_string(kMaxPartSamples) + "]");
    if (tileRays == 0 || tileRays > kMaxTileRays)
        fail("the rays per tile must lie in [1, " + std::to_string(kMaxTileRays) + "]");
    if (partPhotons > kMaxPartSamples)
        fail("the part photons per pass must lie in [0, " + std::to_string(kMaxPartSamples) + "]");
}

std::ostream& operator<<(std::ostream& os, const RenderOptions& o) {
    return os << "RenderOptions{" << o.raysPerPixel << " rays per pixel, " << o.photonsPerPass
              << " photons per source per pass" << (o.balancePhotons ? " (first, balanced)" : "")
              << ", r1 " << o.initialRadiusMm << " mm, alpha " << o.alpha << ", seed " << o.seed
              << (o.splitBackward ? ", split" : ", random") << ", roulette "
              << o.rouletteRelativeFlux
              << (o.quasiRandomPhotons ? ", sobol photons" : ", random photons") << ", guide "
              << o.guideFraction << ", photon guide " << o.photonGuideFraction << ", scatter guide "
              << o.scatterGuideFraction << ", weight window " << o.weightWindow
              << ", follow lobes below " << o.followLobesBelowDeg << " deg, splat lobes below "
              << o.splatLobesBelowDeg << " deg (" << o.lobeSplats << " splats, " << o.aimedSplats
              << " aimed)"
              << (o.connectThroughLens
                      ? (o.ghostRoutes ? ", connected through the lens (ghost routes too)"
                                       : ", connected through the lens")
                      : "")
              << ", " << o.partSamples << " part samples (" << o.partDirections << " directions), "
              << o.partPhotons << " part photons, tiles of " << o.tileRays << " rays}";
}

}  // namespace veil
