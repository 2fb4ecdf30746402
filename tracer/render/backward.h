#pragma once
// The backward pass of the bidirectional renderer (the seed's section 3, figure 7, first
// stage): rays leave every detector pixel toward the exit aperture and are traced against
// the light through the specular chain (refraction, Fresnel and mirror reflection, TIR),
// carrying importance in TransportMode::Importance (the n^2 rule at refraction,
// tracer/surfaces/optical_property.h). Two things come out:
//
//   visible    where a backward ray reaches a light source through specular events only, the
//              source's radiance toward the ray, times the ray's weight: the flux each pixel
//              receives from sources it sees through the lens (the seed's "visible luminance
//              of light sources"); a DetectorImage whose per-pixel statistics use
//              n = raysPerPixel samples
//   viewPoints where a backward ray meets a surface that scatters, a view point (the seed's
//              integration sphere centre): the point, the object, the direction the light must
//              leave toward the detector, the pixel and the weight that multiplies the radiance
//              leaving there; the caustic and secondary components are gathered at these
//              points by the photon pass (tracer/render/render.h)
//   direct     at every view point, next-event estimation toward each source (one sample per
//              source, Source::sampleIncident, a shadow ray that any object blocks): the
//              seed's "direct luminance", light that reaches the scattering surface from the
//              source with nothing in between, times the view point's weight and the flux
//              BSDF toward the detector; a DetectorImage like `visible`
//
// Weights. A pixel ray from samplePixelRay() starts with W_e cos(theta_pixel) / pdf (mm^2 sr:
// the pixel's etendue through the aperture, in expectation), divided by raysPerPixel, times
// the number of model wavelengths (one is drawn per ray, uniformly). Each specular event
// multiplies it by the child's Importance weight; glass absorbs exp(-alpha t). So a ray that
// sees radiance L (unit / (mm^2 sr)) adds weight x L (unit) to its pixel, and the pixel's sum
// estimates the flux it receives.
//
// Splitting: in split mode every specular child is followed (a Fresnel interface gives two
// branches), down to minRelativeWeight of the ray's starting weight; in random mode one child
// is chosen by weight. Determinism: ray k of pixel p uses CounterRng(seed, p * raysPerPixel +
// k); pixels run in parallel and are merged in pixel order, so any thread count gives the same
// bits.

#include <cstdint>
#include <ostream>
#include <span>
#include <vector>

#include "tracer/records/detector.h"
#include "tracer/render/aperture_guide.h"
#include "tracer/render/lens_connection.h"
#include "tracer/render/path_judge.h"
#include "tracer/runtime/deadline.h"
#include "tracer/transport/interaction.h"

namespace veil {

class PartLight;  // tracer/render/part_light.h

struct BackwardOptions {
    uint64_t raysPerPixel = 16;
    uint64_t seed = 1;
    bool split = true;                // every specular child, or one chosen by weight
    int maxSpecularDepth = 64;        // specular events followed along a branch
    double minRelativeWeight = 1e-6;  // split mode: branches below this share of the ray end
    bool direct = true;               // next-event estimation at the view points
    // View point roulette: a view point whose weight is below this share of its ray's
    // starting weight is stored with probability weight / (share * start) and then carries
    // share * start (unbiased). Keeps the weak split branches (ghost reflections) from
    // flooding the photon gathering with view points that carry little. 0 = store all.
    double viewPointRelativeWeight = 0.0;
    // Narrow lobes: at a surface whose scatter lobe is narrower than this (its half width at
    // half maximum, lobeHalfWidthRad), no view point is stored. Its direct light is estimated
    // there and the branch goes on along one direction drawn from the lobe, up to 4 such
    // surfaces, to the next surface that gathers or to a source it sees: a photon would have
    // to arrive within the lobe's width of the one direction that reaches the pixel. Light
    // found that way is caustic (one followed lobe) or secondary (more, or a view point behind
    // one). 0: every scattering surface stores view points.
    double followLobesBelowRad = 0.0;
    // Which sources the visible image counts (by index in the scene's sources; empty: all).
    // The renderer counts the sun and the delta kinds with its photons instead (light tracing
    // finds a 0.5 degree sun far better than rays searching for it from the pixels).
    std::vector<bool> visibleSources;
    // Path criteria (tracer/render/path_judge.h), or none. With them every view point keeps its
    // backward events (ViewPoint::firstEvent) and the visible and direct light is also split
    // by criterion (BackwardResult::visibleByCriterion, directByCriterion). With prune, a
    // branch stops as soon as no photon could make its path match any criterion, and the
    // plain images count only light that matches at least one.
    const PathJudge* judge = nullptr;
    bool prune = false;
    // Learned aperture sampling (tracer/render/aperture_guide.h), or none (uniform over the
    // aperture). With it, each ray's aperture uniforms go through guide->warp() and its
    // weight is divided by the warp's density; view points keep their ray's guide bin and
    // BackwardResult::learned holds the visible and direct light per bin.
    const ApertureGuide* guide = nullptr;
    // Light connected through the lens (tracer/render/lens_connection.h), or none: at every
    // view point, the light of each of its chains, solved and added to the caustic image
    // (secondary behind a followed lobe), its path judged as the photons' would be. The photon
    // pass then leaves that light to it.
    const LensConnector* connector = nullptr;
    // Small lit parts traced to the sensor (tracer/render/part_light.h), or none: a view point
    // on a part, reached along the designed path down to a chain's step, leaves that chain's
    // connection to them (PartLight::owns).
    const PartLight* parts = nullptr;
    // The ranks the pixels are split over (tracer/runtime/ranks.h), in blocks of 64 by index: every
    // rank traces its blocks, all ranks' pixels are shared, and every rank returns the whole
    // result, bitwise that of one process.
    Ranks ranks = Ranks::alone();
    // Checked once per block of pixels: once it has passed, traceBackward throws
    // DeadlinePassed (tracer/runtime/deadline.h). One process only: ranks must stop together.
    Deadline deadline;
};
std::ostream& operator<<(std::ostream& os, const BackwardOptions& o);

struct ViewPoint {
    Vec3 positionMm{0.0};
    Vec3 normal{0.0};      // the object's orientation (SceneHit::normal)
    Vec3 toDetector{0.0};  // unit: the direction light leaves toward the pixel
    int object = -1;
    int primitive = 0;
    int pixel = 0;
    int wavelength = 0;     // model wavelength index
    int medium = 0;         // where the light leaving toward the detector travels
    int otherMedium = 0;    // the medium across the surface
    bool fromFront = true;  // toDetector points to the side `normal` points to
    double weight = 0.0;    // multiplies the radiance leaving along toDetector (unit/(mm^2 sr))
    // With criteria: the path from here to the detector as light travels it, the events
    // after this point's own scatter event up to the detector hit, in
    // BackwardResult::events[firstEvent, firstEvent + eventCount).
    uint32_t firstEvent = 0;
    uint32_t eventCount = 0;
    // With a guide: the (pixel block, aperture cell) bin of the ray that stored this point.
    uint32_t guideBin = 0;
    // Its ray followed a narrow lobe between it and the detector: its light has scattered
    // once more (direct light is secondary, gathered light secondary).
    bool behindScatter = false;
};
std::ostream& operator<<(std::ostream& os, const ViewPoint& v);

struct BackwardResult {
    DetectorImage visible;
    DetectorImage direct;               // empty sums when options.direct is false
    // The part of `visible` that crossed the lens as designed (tracer/render/designed_path.h).
    DetectorImage imageForming;
    // Sources the rays saw behind followed narrow lobes (followLobesBelowRad): one lobe,
    // caustic; more, secondary.
    DetectorImage caustic, secondary;
    std::vector<ViewPoint> viewPoints;  // in pixel order, then ray order
    std::vector<PathEvent> events;      // the view points' backward events (with criteria)
    // With criteria: [criterion][pixel], the flux of the visible and direct light whose
    // joined path matches the criterion (sums over the pixel's rays).
    std::vector<std::vector<double>> visibleByCriterion, directByCriterion;
    std::vector<std::vector<double>> causticByCriterion, secondaryByCriterion;
    // With a guide: the visible and direct light the rays brought back, per guide bin.
    std::vector<double> learned;
    uint64_t rays = 0;
    uint64_t segments = 0;
    uint64_t connectionRays = 0;  // traced by the lens connections (in `segments` too)
    uint64_t prunedBranches = 0;  // backward branches stopped by the criteria (prune)
    // Over the pixel rays, the sum of each one's stray light (visible, direct, caustic and
    // secondary as it brought them back, less the image-forming light) and of its square: how
    // many rays carry that light (RenderState::effectiveRays).
    double raySum = 0.0, raySquares = 0.0;
    // The visible image's total flux variance: the sum of its pixels' (independent) ones.
    double visibleTotalVariance(uint64_t raysPerPixel) const;
    double directTotalVariance(uint64_t raysPerPixel) const;
};

// Traces raysPerPixel backward rays from every pixel of `detector` (its geometry; the image's
// sums are not used) through `aperture`. The detector's own object ends a ray that returns to
// it. Throws std::invalid_argument for raysPerPixel = 0 or an aperture of no area.
BackwardResult traceBackward(const TransportView& ts, const DetectorImage& detector,
                             const ExitAperture& aperture, const BackwardOptions& options);
// The same for the pixels [firstPixel, endPixel) alone (a tile of the sensor: Renderer), added
// to `into`: its images and sums gather the tiles of a pass (firstPixel 0 starts them anew),
// while its view points and events become the tile's own. Each pixel's rays are those of the
// whole sensor's trace, so a pass traced by tiles in pixel order has the same images.
void traceBackward(const TransportView& ts, const DetectorImage& detector,
                   const ExitAperture& aperture, const BackwardOptions& options, int firstPixel,
                   int endPixel, BackwardResult& into);

// The half width at half maximum of a property's scatter lobe about its specular direction
// (radians): a Gaussian's half width, the widest ABg lobe's (in direction cosines, at normal
// incidence); pi / 2 for Lambertian, tabulated, K-correlation and particulate models.
double lobeHalfWidthRad(const OpticalProperty& p);
// [property]: whether the backward rays follow its lobe (it scatters, with a half width below
// belowRad; BackwardOptions::followLobesBelowRad).
std::vector<bool> followedLobes(const TransportView& ts, double belowRad);
// [property]: whether photons splat its lobe onto the detector instead of gathering there
// (RenderOptions::splatLobesBelowDeg): it scatters, with a half width below splatBelowRad, and
// the backward rays do not follow it (followBelowRad). Empty when splatBelowRad is 0.
std::vector<bool> splattedLobes(const TransportView& ts, double splatBelowRad,
                                double followBelowRad);

// The context of light travelling along `lightDirection` (unit) onto the view point's
// surface: normal toward the light's side, n1 the index there (media at wavelength index
// v.wavelength), opaque by the object's kind. With it, bsdf(context, v.toDetector) is the
// flux BSDF from that light toward the detector.
SurfaceContext lightContext(const TransportView& ts, const ViewPoint& v, const Vec3& lightDirection,
                            double wavelengthNm);

// The direct component at one view point: one sample per source toward it, each with its
// shadow ray, two uniforms per source from rng (in source order, drawn whether or not the
// sample counts). The radiance leaving toward the detector times v.weight.
double directAt(const TransportView& ts, const ViewPoint& v, double wavelengthNm, CounterRng& rng);
// The same, also adding each contribution to perSourceSide[2 s + side]: source s, side 0 when
// the light scatters back into the detector's side (ScatterReflect), 1 when it crosses the
// surface (ScatterTransmit). perSourceSide holds 2 x sources values.
double directAt(const TransportView& ts, const ViewPoint& v, double wavelengthNm, CounterRng& rng,
                std::span<double> perSourceSide);

}  // namespace veil
