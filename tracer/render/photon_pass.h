#pragma once
// The forward stage of a render pass (tracer/render/render.h, the seed's figure 7, second stage):
// photons leave the sources through the interaction step (flux mode). The first
// RenderOptions::ghostPhotonsPerPass of a source split at every interface until their first
// scatter (every Fresnel branch; below photonMinRelativeFlux of the photon a branch plays
// roulette, kept at photonRescueRelativeFlux); the others follow one child by weight. Where a
// branch first scatters, the light it scatters plays roulette below rouletteRelativeFlux of the
// emitted flux (on the incident flux: weak ghosts rarely scatter); after that one child by
// weight, with Russian roulette below rouletteRelativeFlux of its flux just after that first
// scatter (scale-free: light scattered once by a 0.1 % mount is followed as far as light
// scattered by a 30 % one, the seed's dark-mount claim). They add three images:
//   visible    a splitting photon of the sun, a collimated or a point source that reaches the
//              detector without scattering (its flux times photons / ghost photons), spread
//              over the pixels within the detector smoothing disk
//              (RenderOptions::detectorRadiusPixels, shrinking with the radius)
//   caustic    gathered at the pass's view points (a spatial hash of cells 2r wide) when the
//              photon has seen specular events only: weight x flux x bsdf / (share pi r_v^2),
//              r_v the view point's radius fitted to the piece of surface it lies on and
//              share its own part of its disk (viewPointDisk)
//   secondary  the same once the photon has scattered before
// and, with path criteria, the same three per criterion on the joined paths.
// At a splatted lobe (RenderOptions::splatLobesBelowDeg: a scatter lobe narrower than 15
// degrees that the pixel rays do not follow) a photon gathers nothing: it draws directions
// from the lobe (RenderOptions::lobeSplats where the part photons' pilot saw light reach the
// detector from that place, one elsewhere), follows each along specular events to the
// rendered detector, and adds its light to the pixel it lands in, caustic or secondary as a
// gather there would be. A view point on a narrow lobe gathers a photon only when it arrives
// within the lobe's width of the one direction that reaches the pixel; the splat finds the
// same paths (last scatter there, then specular to the detector) from the light's side.
// Part photons (RenderOptions::partPhotons, tracer/render/part_light.h PartMode::Photons) start
// on the parts the lens lights as designed with the light the connection finds there; the
// sources' photons give their scattered children there only to the connection's audit.
// Emission: photon j of a source takes point j of an Owen-scrambled Sobol sequence
// (tracer/runtime/qmc.h), scrambled by passSeed(seed, k, 3) and the source, for its origin,
// direction and line (RenderOptions::quasiRandomPhotons; otherwise its own random numbers).
// Deterministic: photon i of pass k draws its other choices from
// CounterRng(passSeed(seed, k, 1), i), blocks of 4096 photons are reduced in a fixed order.

#include <array>
#include <cstdint>
#include <vector>

#include "tracer/render/aperture_guide.h"
#include "tracer/render/backward.h"
#include "tracer/render/lens_connection.h"
#include "tracer/render/path_judge.h"
#include "tracer/render/render_options.h"
#include "tracer/render/scatter_guide.h"

namespace veil {

class PartLight;

struct PhotonImages {
    std::vector<double> visible, caustic, secondary;  // flux per pixel
    // The caustic and secondary light gathered within half of each view point's radius, with
    // the half disk's own kernel and share: a second estimate of the same light whose
    // difference from the first bounds the radius bias (RenderState::radiusBias).
    std::vector<double> gatheredHalf;
    // The part of `visible` that crossed the lens as designed (DesignedPath): the sources'
    // image-forming light.
    std::vector<double> imageForming;
    // The gathered light (caustic and secondary, splats included) of the photons beyond the
    // ghost photons (the ones the photon balance scales) of even index minus that of the odd
    // ones: an image whose square estimates the variance those photons give the pass's
    // gathered light (each half, twice its light, differs from the other by twice this; the
    // variance of their mean is a quarter of that difference's square). The photon balance
    // weighs it against the rest (balancedPhotonsByError, render.h). Booked only with
    // RenderOptions::balancePhotons and balancePhotonsByError (zeros otherwise): it costs a
    // deposit a gather.
    std::vector<double> parity;
    // With criteria: [criterion] {visible, caustic, secondary, gatheredHalf, parity}.
    std::vector<std::array<std::vector<double>, 5>> by;
    // With a guide (back.learned not empty): the gathered light per guide bin of its view
    // points (tracer/render/aperture_guide.h).
    std::vector<double> learned;
    // With an emission guide: the light the photons gathered (caustic and secondary, plain) per
    // bin of that guide (EmissionGuide::bin: source, image region, cell of the emission).
    std::vector<double> emissionLearned;
    // With a scatter guide: the light gathered after a scatter per bin of that guide
    // (ScatterGuide::bin: the scatter's place, the cell of its direction), region-weighted.
    std::vector<double> scatterLearned;
    uint64_t photons = 0, segments = 0, gathers = 0, pruned = 0;
    // Over the photons, the sum of each one's gathered light (plain caustic and secondary, at
    // every view point it reached) and of its square: how many photons carry the gathered
    // light (RenderState::effectivePhotons).
    double gatheredSum = 0.0, gatheredSquares = 0.0;
    // The segments and gathers of the ghost photons, the segments of the visible photons, and
    // the probe rays that fitted the gathering disks the photons reached
    // (RenderPass::photonWork).
    uint64_t ghostWork = 0, visibleWork = 0, diskRays = 0;
    // With PhotonTile::perPhoton: each photon's gathered light summed over the tiles, by its
    // index in the pass (gatheredSum and gatheredSquares then hold only the last tile's).
    std::vector<double> perPhoton;
};

// One tile of a pass traced by tiles of the sensor (Renderer): the pass's photons traced again
// for each tile's view points. Each photon follows the same path in every tile (it draws the
// same numbers: its lobe splats, which the later tiles skip, draw on a forked stream), so the
// tiles together gather what one trace over all view points would.
//   first          the first tile: it starts `into` anew, counts the photons, and alone deposits
//                  on the detector (the visible light, the lobe splats); the visible photons,
//                  which do nothing else, are traced in it alone
//   viewPointBase  the index of the tile's first view point among the pass's (the gathering
//                  disks' spirals are turned by that index, as in one trace)
//   perPhoton      book each photon's gathered light (PhotonImages::perPhoton): its sum over the
//                  tiles is the photon's gathered light
struct PhotonTile {
    bool first = true;
    uint64_t viewPointBase = 0;
    bool perPhoton = false;
};

// The photons' emission guide (RenderOptions::photonGuideFraction, docs/render.md, "Photons
// emitted where they were gathered"). Per source, a grid of ApertureGuide::kCells x kCells cells
// over the two uniforms that place its photons (Source::emit's u[1], u[2], the origin; a point
// source's u[3], u[4], the direction). The photons of a pass learn how much light each cell
// gathered into each of kRegions x kRegions regions of the image. The next pass draws a cell
// with probability (1 - g) / cells + g q(cell), q the mean over the image's regions of each
// region's light spread over the cells (its share of it), each region weighted 1, or less
// when its light is below kLitFraction of the mean region's: every lit part of the image gets
// an equal say in where photons go, not only its brightest part. A photon's flux is divided by
// the density it was drawn with (ApertureGuide::warp); every cell keeps (1 - g) of its uniform
// share, so no weight exceeds 1 / (1 - g).
class EmissionGuide {
  public:
    static constexpr int kRegions = 8;
    static constexpr int kRegionCount = kRegions * kRegions;
    static constexpr double kLitFraction = 0.01;

    EmissionGuide() = default;
    EmissionGuide(size_t sources, int pixelsX, int pixelsY);
    // The learned values: [source][region][cell].
    size_t bins() const { return sources_ * kRegionCount * ApertureGuide::kCellCount; }
    size_t bin(size_t source, int pixel, int cell) const;
    // Sampling for guided fraction g in [0, 1) from learned sums (bins() values, >= 0); a
    // source with no light learned: as it emits.
    void prepare(const std::vector<double>& learned, double g);
    // Source s's uniforms (u, v) in [0, 1), warped; their density on the unit square.
    ApertureGuide::Warped warp(size_t source, double u, double v) const {
        return guide_.warp(static_cast<int>(source) * ApertureGuide::kBlockPixels, u, v);
    }
    // The weight of light gathered into pixel's region for the other photon guides: the same
    // equal say per lit region, scaled so that a region with the mean region's light weighs 1
    // (1 everywhere before any light was learned).
    double regionWeight(int pixel) const {
        return regionWeight_.empty() ? 1.0 : regionWeight_[static_cast<size_t>(region(pixel))];
    }

  private:
    int region(int pixel) const;
    size_t sources_ = 0;
    int pixelsX_ = 1, pixelsY_ = 1;
    ApertureGuide guide_;               // one block per source
    std::vector<double> regionWeight_;  // [region], over all sources (empty: none learned)
};

// Pass k's photons, gathered at `back`'s view points with radius radiusMm. Across `ranks`
// (tracer/runtime/ranks.h) every rank holds the whole `back` and traces its blocks of photons; the
// images are complete on rank 0, bitwise those of one process.
// With a connector (tracer/render/lens_connection.h), the light it connects is not gathered (but
// for its audit). With an emission guide (EmissionGuide, prepared from the light the
// passes before gathered), the photons beyond the ghost photons are emitted through it, each
// photon's flux divided by its density, and the images' emissionLearned holds what this pass
// gathered per bin. With a scatter guide (ScatterGuide), the scatters of the photons beyond the
// ghost photons draw their directions through it where it has learned light, and the images'
// scatterLearned holds what this pass's scatters led to. `deadline` is checked once per block of
// photons (it throws DeadlinePassed once passed; one process only).
PhotonImages tracePhotons(const TransportView& ts, const DetectorImage& detector,
                          const BackwardResult& back, const RenderOptions& options,
                          const PathJudge* judge, int k, double radiusMm,
                          const Ranks& ranks = Ranks::alone(),
                          const LensConnector* connector = nullptr,
                          const EmissionGuide* emissionGuide = nullptr,
                          const ScatterGuide* scatterGuide = nullptr,
                          const PartLight* partPhotons = nullptr, const Deadline& deadline = {});
// The same for one tile of the sensor's view points (`back` holds the tile's), added to `into`
// (tile.first: `into` anew). The disk probe rays add up over the tiles.
void tracePhotons(const TransportView& ts, const DetectorImage& detector,
                  const BackwardResult& back, const RenderOptions& options, const PathJudge* judge,
                  int k, double radiusMm, const PhotonTile& tile, PhotonImages& into,
                  const Ranks& ranks = Ranks::alone(), const LensConnector* connector = nullptr,
                  const EmissionGuide* emissionGuide = nullptr,
                  const ScatterGuide* scatterGuide = nullptr,
                  const PartLight* partPhotons = nullptr, const Deadline& deadline = {});

}  // namespace veil
