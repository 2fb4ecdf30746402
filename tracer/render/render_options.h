#pragma once
// The knobs of a render pass (veil render's options, docs/render.md): what the backward stage,
// the photon pass and the progressive accumulators (render.h) read.

#include <algorithm>
#include <cstdint>
#include <ostream>

namespace veil {

struct RenderOptions {
    uint64_t raysPerPixel = 16;        // backward rays per pixel per pass
    uint64_t photonsPerPass = 100000;  // per source (balanced: the first pass's)
    // Balanced photons (balancedPhotons in render.h): each pass after the first traces as
    // many photons per source as make their work about that of the view points' side, up to
    // maxPhotonsPerPass; off: photonsPerPass in every pass.
    bool balancePhotons = false;
    // With balancePhotons: from the third pass on, the photons follow the target's error
    // instead (balancedPhotonsByError, set by the run after each pass): as many as spend the
    // pass's time where that error comes from.
    bool balancePhotonsByError = false;
    uint64_t maxPhotonsPerPass = 4000000;
    double initialRadiusMm = 0.0;      // r_1; 0: defaultInitialRadius()
    double alpha = 2.0 / 3.0;          // radius reduction, in (0, 1)
    uint64_t seed = 1;
    bool splitBackward = false;             // backward: every specular child, or one by weight
    double minRelativeWeight = 1e-4;        // backward split: branches below this share end
    double viewPointRelativeWeight = 0.05;  // view point roulette (BackwardOptions)
    int maxSpecularDepth = 64;              // backward specular events per branch
    double rouletteRelativeFlux = 0.1;      // photons below this share of their emitted flux
                                            // (after their first scatter: of their flux just
                                            // after it) play Russian roulette; 0 = off
    int maxPhotonSegments = 1000;
    // The first ghostPhotonsPerPass photons of each source (of the quasi-random sequence,
    // at most photonsPerPass) follow every specular branch until their first scatter (every
    // Fresnel branch, as veil trace does): they alone deposit the visible light of the sun,
    // collimated and point sources (their ghosts), for all photons; their branches below
    // photonMinRelativeFlux of the photon play Russian roulette, kept at
    // photonRescueRelativeFlux. The others' branches play roulette below
    // rouletteRelativeFlux (kept at it): they serve the gathered light.
    uint64_t ghostPhotonsPerPass = 16384;
    uint64_t ghostPhotons() const { return std::min(ghostPhotonsPerPass, photonsPerPass); }
    // Visible photons: visiblePhotonsPerPass more photons per pass of each sun, collimated
    // and point source (of a quasi-random sequence of their own) follow every specular branch
    // as the ghost photons do, but drop their scattered children and gather nothing: they
    // deposit the visible light alone, at about a third of a ghost photon's cost. The ghost
    // and the visible photons each deposit 1 / (their number) of it. 0: none.
    uint64_t visiblePhotonsPerPass = 0;
    // Balanced visible photons (balancedVisiblePhotons in render.h, set by the run after each
    // pass): visiblePhotonsPerPass in the first two passes, then as many as spend the pass's
    // time where the target's error comes from; off: visiblePhotonsPerPass in every pass.
    bool balanceVisible = false;
    double photonMinRelativeFlux = 1e-4;
    double photonRescueRelativeFlux = 1e-2;
    // The photons' visible deposits (the sun's ghosts) are spread evenly over the pixels whose
    // centres lie within this many pixel pitches of the hit, shrinking with the gathering
    // radius (rho_k = rho_1 r_k / r_1): density estimation on the detector, consistent as
    // the passes go on. 0: every deposit in its own pixel (no bias, more noise).
    double detectorRadiusPixels = 2.0;
    // Probes per view point of how much of its gathering disk lies on its own object (the
    // rim correction, viewPointAreaShare); 0: every disk counts as pi r^2 (biased low within r
    // of a face's rim).
    int areaSamples = 16;
    // How the photons of a pass spread over each source's emission (its origin, direction and
    // line): quasi-random points (Owen-scrambled Sobol, one scramble per source and pass:
    // still unbiased, passes still independent) or independent random ones.
    bool quasiRandomPhotons = true;
    // With criteria (Renderer's judge): stop photons and backward branches as soon as no
    // criterion can match their path; the plain images then hold only light that matches at
    // least one criterion.
    bool prune = false;
    // Learned aperture sampling (tracer/render/aperture_guide.h): the fraction of each pass's pixel
    // rays drawn where the passes before it found light, in [0, 1); 0 = uniform over the
    // aperture (every pass the same distribution).
    double guideFraction = 0.5;
    // Learned photon emission (docs/render.md, "Photons emitted where they were gathered"): the
    // fraction of each pass's photons beyond the ghost photons whose origin (a point source's:
    // direction) is drawn, on a grid over the source's uniforms, in proportion to the light the
    // photons of the passes before it gathered from each cell; each photon's flux is divided
    // by the density it was drawn with. In [0, 1); 0 = every photon as the source emits it.
    double photonGuideFraction = 0.5;
    // Learned scatter directions (tracer/render/scatter_guide.h, docs/render.md, "Photons
    // scattered toward what the sensor sees"): the fraction of the scattered directions of the
    // photons beyond the ghost photons drawn, per place in the scene, in proportion to the
    // light that the passes before gathered after scattering there in each direction; each
    // photon's flux is weighted by the bsdf's density over the mixture's. In [0, 1); 0 = every
    // direction as the surface scatters.
    double scatterGuideFraction = 0.5;
    // Weight windows at the photons' scatters (tracer/render/scatter_guide.h): from what the
    // passes before learned per place in the scene, a photon that expects more than this many
    // times an average photon's gathered light splits (into at most 8), one that expects less
    // than its inverse plays Russian roulette. 0 = off; otherwise in [1, 1e6].
    double weightWindow = 0.0;
    // Narrow lobes (BackwardOptions::followLobesBelowRad): scatter lobes with a half width at
    // half maximum below this many degrees are followed by the backward rays instead of
    // gathering photons; 0: every scattering surface gathers.
    double followLobesBelowDeg = 0.0;
    // Narrow lobes splatted (docs/render.md, "Narrow lobes splatted onto the sensor"): where a
    // photon scatters at a surface whose lobe has a half width at half maximum below this many
    // degrees (and the backward rays do not follow it), it gathers nothing at the view
    // points there; instead lobeSplats directions drawn from the lobe are traced along
    // specular paths to the detector, each adding its light to the pixel it lands in. The same
    // light as the gather (paths whose last scatter is there), found from the other end.
    // 0: every scattering surface gathers.
    double splatLobesBelowDeg = 15.0;
    // Directions per splat where the part photons' pilot saw a splatted lobe's light reach the
    // detector (one elsewhere), and the most directions a part photon draws at its point.
    int lobeSplats = 1024;
    // Of those directions, the share aimed at the face the pilot's splats from that place went
    // on through as designed (PartLight::aimStep: the next lens face behind a stop's bevel, or
    // the detector itself), a point drawn on it by area; the rest drawn from the lobe. The two
    // are weighed by multiple importance sampling (balance heuristic) on the path's direction,
    // so a direction either could draw is counted once. 0: every direction from the lobe.
    double aimedSplats = 0.5;
    // Light connected through the lens (tracer/render/lens_connection.h): at every view point
    // and followed lobe, the light of the sources that reaches it through the lens as designed
    // is solved for (Newton on the source's ray) instead of gathered from photons (at a followed
    // lobe, weighed against the lobe's own direction by multiple importance sampling).
    bool connectThroughLens = true;
    // Ghost routes (LensConnector, "Ghost routes"): the connection also solves the light a
    // bare face's Fresnel reflections bring to a part (at most two reflections), on the routes
    // its pilot finds carrying enough of the part's light; off: that light stays the
    // photons'. Needs connectThroughLens.
    bool ghostRoutes = true;
    // Small lit parts traced to the sensor (tracer/render/part_light.h): points drawn per pass
    // on the parts the lens lights as designed and the pixels see through the lens behind
    // them (a stop's edge band, butt ends, flats), their light traced forward to the pixels;
    // the view points that reach those parts along the designed path leave that light to
    // them. 0: off. Needs connectThroughLens.
    uint64_t partSamples = 65536;
    // How a pass splits those points over the lit parts: in proportion to the light the pilot
    // found on each (true), or evenly (sweeps: a variant that changes one part's light would
    // otherwise move the other parts' points and cost the variants their common random
    // numbers).
    bool partSplitByLight = true;
    // Directions each of those points sends on toward the pixels, each with its share of the
    // point's light: the connection's solve at the point, the costly part, serves them all.
    int partDirections = 32;
    static constexpr uint64_t kMaxPartSamples = uint64_t{1} << 32;
    // Photons from the small lit parts (tracer/render/part_light.h, PartMode::Photons;
    // docs/render.md, "Photons from the lit parts"): with splatted lobes in the scene, photons
    // per pass that start on the parts the lens lights as designed, with the light the
    // connection finds there, and scatter on from them as photons; the sources' photons leave
    // that scattered light to them. 0: off. Needs connectThroughLens.
    uint64_t partPhotons = 16384;
    // Tiles (docs/render.md, "Tiles of the sensor"): the most backward rays, and so view points,
    // a pass holds at once. A pass whose pixels x raysPerPixel exceed it traces its sensor in
    // tiles of tilePixels() pixels, in pixel order, each tile's view points gathering all the
    // pass's photons traced again for them: memory O(tile x raysPerPixel + pixels) for photon
    // work times the tiles. The images are those of one trace over the whole sensor (pass 1
    // bitwise; the guides after it learn sums added in another order).
    uint64_t tileRays = uint64_t{1} << 21;
    static constexpr uint64_t kMaxTileRays = uint64_t{1} << 32;
    // The pixels of a tile: tileRays / raysPerPixel, at least 1, at most `pixels`.
    int tilePixels(int pixels) const {
        const uint64_t n = std::max<uint64_t>(1, tileRays / std::max<uint64_t>(1, raysPerPixel));
        return static_cast<int>(std::min<uint64_t>(n, static_cast<uint64_t>(std::max(pixels, 1))));
    }
    // Throws std::invalid_argument naming the option when a value is out of range.
    void check() const;
};
std::ostream& operator<<(std::ostream& os, const RenderOptions& o);

}  // namespace veil
