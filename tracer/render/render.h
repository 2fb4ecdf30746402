#pragma once
// Diffuse stray light images by bidirectional stochastic ray tracing with photon maps (the
// seed's section 3, figure 7), made progressive and consistent.
//
// One pass (Renderer::runPass):
//   1. Backward (tracer/render/backward.h): raysPerPixel rays from every pixel through the exit
//      aperture (drawn partly where the passes before found light: guideFraction,
//      tracer/render/aperture_guide.h), through the specular chain. They give the visible component
//      of extended sources (window, lambertian) seen through the lens, store view points where they
//      meet scattering surfaces, and at every view point next-event estimation toward each source
//      gives the direct component.
//   2. Forward (tracer/render/photon_pass.h): photonsPerPass photons per source on quasi-random
//      points of the emission (those beyond the ghost photons drawn partly where the photons of
//      the passes before gathered light: photonGuideFraction), the same transport
//      (tracer/transport/interaction.h, flux mode).
//      Until its first scatter a photon splits at every interface (every Fresnel branch; the first
//      ghostPhotonsPerPass follow every branch, the others' weak branches play roulette);
//      then it follows one child chosen by weight, with Russian roulette relative to its flux
//      just after that first scatter (however dark the surface was). A splitting photon
//      of the sun or of a collimated or point source that reaches the detector without
//      scattering adds its flux (times photons / ghost photons) to its pixels: the visible
//      component of those sources (their ghosts, or their image in the field), which a
//      backward ray would have to hit a 0.5 degree disk to find. At every hit on a scattering
//      surface after at least one event, the photon is gathered by the view points within
//      the pass radius r on the same object and side, at the same wavelength, through a
//      spatial hash: each adds weight * flux * bsdf(photon -> detector) / (share pi r^2) to
//      its pixel (share: the part of its disk on its own object, viewPointAreaShare), the
//      caustic component when the photon has seen only specular events, the secondary one
//      when it scattered before. (A photon's first hit is the direct light, which step 1
//      counts.)
//   Steps 1 and 2 run by tiles of the sensor when its pixels x raysPerPixel exceed
//   RenderOptions::tileRays: each tile's view points gather the pass's photons, traced again
//   for them, so a pass holds one tile's view points (docs/render.md, "Tiles of the sensor").
//   With path criteria (tracer/render/path_judge.h), every contribution is also judged on its
//   joined path (the photon's or the sampled source's events, the scatter at the view point, the
//   view point's backward events) and added to the images of the criteria it matches.
// The pass's four images estimate the flux per pixel; visible and direct without bias, the
// two gathered ones with the bias of averaging the radiance over a disk of radius r.
//
// Progressive and consistent (Knaus and Zwicker, "Progressive photon mapping: a
// probabilistic approach", 2011): passes are independent (with the guide: each unbiased given
// the passes before it, their deviations uncorrelated), pass k uses the radius
//     r_{k+1}^2 = r_k^2 (k + alpha) / (k + 1),   r_1 the initial radius,
// so r_k^2 ~ k^(alpha - 1), and the image is the mean of the passes. The variance of the
// mean falls as n^-alpha and the bias as n^(alpha - 1): both vanish, and alpha = 2/3
// balances them. Errors come from the spread of the independent passes (RenderState): the
// variance of the mean over n passes from the per-pixel sums of the pass estimates and of
// their squares (n >= 2), the same formula as a forward run's per-ray statistics with a pass
// in the role of a ray (tracer/records/detector.h).
//
// Determinism: pass k draws its backward rays and photons from streams keyed by (seed, k),
// blocks are reduced in a fixed order, and the state after pass k holds exact sums: a run
// resumed from a checkpoint after pass k gives bitwise the images of an uninterrupted one,
// for any thread count.

#include <algorithm>
#include <array>
#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string_view>
#include <vector>

#include "tracer/records/detector.h"
#include "tracer/render/backward.h"
#include "tracer/render/part_light.h"
#include "tracer/render/render_options.h"
#include "tracer/transport/interaction.h"

namespace veil {

enum class RenderComponent { Visible = 0, Direct = 1, Caustic = 2, Secondary = 3 };
inline constexpr int kRenderComponents = 4;
std::string_view toString(RenderComponent c);  // "visible", "direct", "caustic", "secondary"
std::ostream& operator<<(std::ostream& os, RenderComponent c);

// What one pass estimated: the flux per pixel of each component (the pass's estimate, not yet
// averaged), and what it cost.
struct RenderPass {
    std::array<std::vector<double>, kRenderComponents> pixels;
    // With criteria: [criterion][component], the flux per pixel of the light whose joined
    // path matches the criterion.
    std::vector<std::array<std::vector<double>, kRenderComponents>> criteria;
    // The gathered light (caustic and secondary) within half of each view point's radius:
    // plain, and per criterion.
    std::vector<double> gatheredHalf;
    std::vector<std::vector<double>> criteriaGatheredHalf;
    // The photons' share of the pass's noise: their gathered light, even photons' minus odd
    // photons' (PhotonImages::parity), plain and per criterion. Its square estimates the
    // variance the photons give each pixel (balancedPhotonsByError).
    std::vector<double> photonParity;
    std::vector<std::vector<double>> criteriaPhotonParity;
    // The part of the visible light that crossed the lens as designed
    // (tracer/render/designed_path.h): the sources' image-forming light. The rest of the total
    // is stray light.
    std::vector<double> imageForming;
    uint64_t prunedBranches = 0, prunedPhotons = 0;  // stopped by the criteria (prune)
    double radiusMm = 0.0;
    uint64_t backwardRays = 0, backwardSegments = 0, viewPoints = 0;
    // Of backwardSegments, the rays the lens connections traced (tracer/render/lens_connection.h).
    uint64_t connectionRays = 0;
    uint64_t photons = 0, photonSegments = 0, gathers = 0;
    // Over its photons, the sum of each one's gathered light and of its square
    // (PhotonImages::gatheredSum, gatheredSquares).
    double gatheredSum = 0.0, gatheredSquares = 0.0;
    // Over its pixel rays, the same for the stray light each brought back
    // (BackwardResult::raySum, raySquares), and over the points on small lit parts for the
    // light each brought to its pixel (PartLight::Result::sum, squares).
    double raySum = 0.0, raySquares = 0.0;
    // The points drawn on small lit parts (tracer/render/part_light.h), those whose light
    // reached a pixel, and the rays they traced.
    uint64_t partSamples = 0, partFound = 0, partRays = 0;
    // The photons per source it traced, and its work in rays cast and gathers (counts, the
    // same for every thread and rank count): the view points' side (backward segments, the
    // rays that lit them directly) against the photons' (their segments and gathers, and the
    // probe rays of the gathering disks they reached; ghostWork the ghost photons' segments
    // and gathers, whose number is fixed; visibleWork the visible photons' segments). With
    // RenderOptions::balancePhotons, the photons per source of the next pass that even the two out
    // (balancedPhotons).
    uint64_t photonsPerSource = 0;
    // Of them, the ghost photons; and the visible photons per source (RenderOptions).
    uint64_t ghostPerSource = 0, visiblePerSource = 0;
    uint64_t viewPointWork = 0, photonWork = 0, ghostWork = 0, visibleWork = 0;
    uint64_t nextPhotonsPerSource = 0;
    double backwardSeconds = 0.0, photonSeconds = 0.0;  // wall clock of the two stages
    double partSeconds = 0.0;                           // and of the parts' points
    // With a guide: the light the pass's pixel rays brought back per guide bin (visible,
    // direct and gathered), which the passes after it learn from; then, with the photons'
    // emission guide (RenderOptions::photonGuideFraction), the light its photons gathered per
    // bin of that guide (EmissionGuide, tracer/render/photon_pass.h).
    std::vector<double> learned;
};

// The exit aperture pixel rays aim at, from the scene: a disk on the detector's axis,
// parallel to it, at the object point nearest to it (in front of its sensitive side), wide
// enough that every straight line from a pixel to any point of any other object crosses it
// (the radius of the farthest object point or detector corner from the axis; exact faces
// by their bounding boxes). Light from every object of the scene thus reaches the pixels
// through it. Throws ModelError naming an object that lies beside or behind the detector
// (then no such disk exists).
ExitAperture exitApertureFor(const Scene& scene, const DetectorGeometry& detector);

// The photons per source for the pass after `pass` that make the work of its photons about
// that of its view points: the photons beyond the ghost photons (whose number is fixed) scaled
// by (viewPointWork - ghostWork) / (their work; the visible photons' is neither side's), by at
// most 4x either way per pass, kept within
// [kMinBalancedPhotons, maxPhotonsPerPass - ghost photons] beyond the ghost photons. Each
// pass's estimate stays unbiased whatever its photon count; the count changes only the noise
// per unit of time (docs/render.md, "Photons balanced against view points").
inline constexpr uint64_t kMinBalancedPhotons = 4096;
uint64_t balancedPhotons(const RenderOptions& options, const RenderPass& pass);

// The photons per source for the pass after `pass` that spend the pass's time where the error
// of `target` (a mean over `passes` passes, with its variances) comes from, once two passes
// have given it a variance: the photons' share of each pixel's variance per pass (the square
// of `parity`, the pass's image of the same light's photon halves, RenderPass::photonParity)
// against the rest (the passes' spread less that share), each pixel weighted by 1 / (its
// standard error x its light) as for the visible photons below. Time T_p on the photons beyond
// the ghost photons and T_r on the rest of the pass (view points, ghost and visible photons)
// leave a variance a / T_p + b / T_r at best when T_p / T_r = sqrt(a / b); the step moves the
// split to the geometric mean of now and that, by at most 4x either way, within the bounds
// of balancedPhotons. Before two passes, or where the target holds no gathered light or no
// spread: balancedPhotons (the work of the two sides evened out). The photons' count changes
// only the noise per unit of time: every pass stays unbiased (docs/render.md, "Photons
// balanced against the error").
uint64_t balancedPhotonsByError(const RenderOptions& options, const RenderPass& pass,
                                const DetectorImage& target, const std::vector<double>& parity,
                                int passes);

// The visible photons per source for the pass after `pass` that spend the pass's time where
// the error of `target` (a mean over `passes` passes, with its variances) comes from: the
// visible light's share of its variance (the variance of `visible`, the same image's visible
// component; none: no share) against the rest, each pixel weighted by 1 / (its standard error
// x its light), as its mean relative error responds to them. Per pass, time T_v on the visible
// photons and T_r on the rest leave a variance a / T_v + b / T_r at best when
// T_v / T_r = sqrt(a / b) (a and b in the units of the pass's split, the visible light's
// variance per pass scaled to the pass's photons: inverseSum is the sum over the passes of
// 1 / (ghost + visible photons)). The step moves the split to the geometric mean of the two,
// by at most 4x either way, within [kMinVisiblePhotons, maxPhotonsPerPass] and with the
// visible photons' work at most kMostVisibleWork x the rest's. After one pass (no variance
// yet): as it was, or a quarter when `visible` holds no light. A pass without visible photons
// (none asked for, or no source the photons see): as it was. Each pass stays unbiased
// whatever its count (docs/render.md, "Visible photons balanced against the error").
inline constexpr uint64_t kMinVisiblePhotons = 1024;
inline constexpr uint64_t kAutoVisiblePhotons = 65536;  // veil render's first two passes
inline constexpr double kMostVisibleWork = 8.0;
uint64_t balancedVisiblePhotons(const RenderOptions& options, const RenderPass& pass,
                                const DetectorImage& target, const DetectorImage* visible,
                                int passes, double inverseSum);

// r_1 when none is given: 1 % of the diagonal of the bounding box of the scene's objects
// that scatter (those with a scatter model). ModelError when no object scatters.
double defaultInitialRadius(const TransportView& ts);

// The radius bias of the gathered light, from the passes' two estimates of it: within each view
// point's radius r and within r / 2. Their difference d = E(r) - E(r/2) is itself an estimate
// with an error (its spread over the passes: the two share photons and view points, so the
// spread of the difference, not the two spreads, is what counts). A bias that grows as r^a
// (a = 2 inside a face where the radiance is smooth, a = 1 across a rim or a narrow piece)
// is d / (1 - 2^-a) of E(r): between 4/3 d and 2 d; `estimate` takes 2 d, the larger.
//   detected  |d| > 3 sigma(d): the radius changes the answer beyond its noise
//   errorWith the flux's error includes the estimate 2 d when detected, and otherwise the
//             part of it beyond one sigma of its own noise, 2 (|d| - sigma(d)) when positive:
//             a bias of one to three sigma(d) is real more often than not (the Sun example's
//             lens edges, -1 to -2 %, went undetected in 45 s runs whose statistical error was
//             0.4 to 0.8 %), while the whole 2 |d| of a noisy half-radius estimate (a narrow
//             lobe's few photons) would triple a sound error bar
//   bound     2 (|d| + 2 sigma(d)): what the bias may be, detected or not (about 2 sigma of
//             the half-radius estimate's noise when there is none)
//   bounded   the estimate holds only while r is small against the scale on which the light
//             varies; a detected bias above kBoundedShare of the light means it is not (light
//             leaving a lens flat through a 20 um band under a 3 mm disk changed by 76 %
//             between r and r/2 and was 4 times low): the result then says its bias is not
//             bounded
struct RadiusBias {
    double difference = 0.0, sigma = 0.0;
    double estimate() const { return 2.0 * difference; }
    double bound() const { return 2.0 * (std::abs(difference) + 2.0 * sigma); }
    bool detected() const { return std::abs(difference) > 3.0 * sigma && difference != 0.0; }
    static constexpr double kBoundedShare = 0.5;
    bool bounded(double light) const {
        return !detected() || std::abs(estimate()) <= kBoundedShare * std::abs(light);
    }
    // What the error holds of the bias (see above) and the error of a flux whose statistical
    // error is `statistical`.
    double included() const {
        return detected() ? std::abs(estimate())
                          : 2.0 * std::max(0.0, std::abs(difference) - sigma);
    }
    double errorWith(double statistical) const { return std::hypot(statistical, included()); }
};

// The progressive accumulators: per component and for the total, the sums over passes of
// each pixel's estimate and of its square (DetectorImage sums, one pass as one sample).
class RenderState {
  public:
    RenderState() = default;
    RenderState(const DetectorGeometry& geometry, double initialRadiusMm, double alpha,
                int criteria = 0);

    int passes() const { return passes_; }
    int pixelCount() const { return sums_[0].pixelCount(); }
    double radiusMm() const { return radiusMm_; }  // of the next pass
    double initialRadiusMm() const { return initialRadiusMm_; }
    double alpha() const { return alpha_; }
    // Adds a pass's estimates and shrinks the radius for the next.
    void add(const RenderPass& pass);
    // The same for a pass rendered across ranks (Renderer with ranks): rank 0, which holds the
    // pass's images, adds it; every other rank takes rank 0's pass count, radius and learned
    // light (what its next pass needs) and keeps no sums.
    void add(const RenderPass& pass, const Ranks& ranks);
    // Rank 0's pass count, radii, alpha and learned light on every rank (a run resumed from a
    // checkpoint that rank 0 read).
    void shareFromRoot(const Ranks& ranks);

    // The mean over the passes (flux per pixel) with the variance of the mean: read
    // pixelVariance(p, passes()) and totalVariance(passes()).
    DetectorImage component(RenderComponent c) const;
    DetectorImage total() const;
    // The mean relative standard error of the total over the lit pixels: those whose mean
    // is at least litFraction of the image's mean pixel value, each pixel's from the spread
    // of the passes, the mean divided by standardErrorBias(passes). Infinity before two
    // passes or when nothing is lit.
    static constexpr double kLitFraction = 0.01;
    double meanRelativeError() const;
    int litPixels() const;
    // The same for one component's image (its own lit pixels).
    double meanRelativeError(RenderComponent c) const;

    // Criterion k's images (the light whose path matches it), as component() and total().
    int criteria() const { return static_cast<int>(criterionSums_.size()); }
    DetectorImage criterionComponent(int k, RenderComponent c) const;
    DetectorImage criterionTotal(int k) const;
    double criterionMeanRelativeError(int k) const;

    // The radius bias of the gathered light in all (RadiusBias), and of criterion k's; the
    // mean per pixel of E(r) - E(r/2) with its variance.
    RadiusBias radiusBias() const;
    RadiusBias criterionRadiusBias(int k) const;

    // The image-forming light (the sources' image through the lens's designed path) and the
    // stray light (the total without it), as component(); the stray light's mean relative
    // pixel error over its own lit pixels.
    DetectorImage imageForming() const;
    DetectorImage strayLight() const;
    double strayMeanRelativeError() const;

    // Atomic write (a temporary renamed), with a fingerprint of the scene and options that
    // read() checks. std::runtime_error naming the path on failure, or when the file is not a
    // checkpoint of this fingerprint and grid.
    void write(const std::filesystem::path& path, uint64_t fingerprint) const;
    static RenderState read(const std::filesystem::path& path, uint64_t fingerprint,
                            const DetectorGeometry& geometry);
    bool sameSums(const RenderState& o) const;

    // The light learned per bin of the aperture guide, then of the photons' emission guide,
    // over the passes (empty before the first pass and without guides): what the next pass's
    // guides are prepared from.
    const std::vector<double>& learned() const { return learned_; }
    // How many photons carry the gathered light over the passes: (sum c)^2 / sum c^2 over
    // every photon's gathered light c (its effective number; 0 when none gathered any). Below
    // kFewPhotons a few photons make the gathered light, and its error bar from the passes'
    // spread need not hold: a pass that missed the rare photons looks like one that did not
    // need them (docs/render.md, "Error bars from few passes").
    static constexpr double kFewPhotons = 100.0;
    double effectivePhotons() const;
    // The same over the light found without photons, per ray that found it: every pixel
    // ray's stray light as the backward stage brought it back (visible, direct, caustic and
    // secondary less the image-forming light: a source seen by few pixel rays, light
    // connected at few view points) and every small lit part's point's light on its pixel;
    // and that light's mean per pass. Below kFewPhotons its error bar need not hold either.
    double effectiveRays() const;
    double rayLight() const { return passes_ > 0 ? raySum_ / passes_ : 0.0; }
    // The photons per source of the next pass when they are balanced
    // (RenderPass::nextPhotonsPerSource of the last pass added; 0 before the first).
    uint64_t photonsPerPass() const { return photonsPerPass_; }
    // The visible photons per source of the next pass when they are balanced (set by the run
    // after each pass: balancedVisiblePhotons; -1 before the first), and the sum over the
    // passes of 1 / (ghost + visible photons per source) that balancing reads.
    int64_t visiblePhotons() const { return visiblePhotons_; }
    void setVisiblePhotons(uint64_t n) { visiblePhotons_ = static_cast<int64_t>(n); }
    // Sets the photons per source of the next pass (the run's balance by the target's error,
    // balancedPhotonsByError, in place of the pass's own by work).
    void setPhotonsPerPass(uint64_t n) { photonsPerPass_ = n; }
    double visibleInverseSum() const { return visibleInverseSum_; }

  private:
    using Sums = std::array<DetectorImage, kRenderComponents + 1>;  // components, then total
    static void addTo(Sums& sums, const std::array<std::vector<double>, kRenderComponents>& x);
    // Adds a pass's E(r) - E(r/2) per pixel.
    static void addDifference(DetectorImage& sums,
                              const std::array<std::vector<double>, kRenderComponents>& x,
                              const std::vector<double>& half);
    static RadiusBias biasOf(const DetectorImage& sums, int passes);
    // Adds a pass's image-forming light and its stray light (the rest of its total).
    void addImageAndStray(const RenderPass& pass);
    Sums sums_;
    std::vector<Sums> criterionSums_;
    DetectorImage radiusDifference_;
    std::vector<DetectorImage> criterionRadiusDifference_;
    DetectorImage imageForming_, stray_;
    std::vector<double> learned_;
    double gatheredSum_ = 0.0, gatheredSquares_ = 0.0;
    double raySum_ = 0.0, raySquares_ = 0.0;
    uint64_t photonsPerPass_ = 0;
    int64_t visiblePhotons_ = -1;
    double visibleInverseSum_ = 0.0;
    int passes_ = 0;
    double radiusMm_ = 0.0, initialRadiusMm_ = 0.0, alpha_ = 2.0 / 3.0;
};

// About how many bytes a render of `pixels` pixels with these options, `criteria` path
// criteria and `sources` sources holds at its peak: one view point per pixel ray of a tile
// (RenderOptions::tileRays; with its grid entry, gathering disks and marks), the images (the
// sums of every pass so far, and one pass's own) and, tiled, each photon's gathered light. veil
// render checks it against the machine's memory before any work.
double renderMemoryBytes(uint64_t pixels, const RenderOptions& options, size_t criteria,
                         size_t sources = 1);

class Renderer {
  public:
    // `detector` gives the pixel grid (its sums are not used). Checks the options. `judge`:
    // path criteria to split the image by (tracer/render/path_judge.h), or none; it must outlive
    // the renderer. `ranks`: every pass split over them (tracer/runtime/ranks.h; pixels and photons
    // by index), every rank calling runPass; the pass's images are complete on rank 0 only,
    // bitwise those of one process (RenderState::add(pass, ranks) then keeps the ranks in step).
    Renderer(const TransportView& ts, const DetectorImage& detector, ExitAperture aperture,
             RenderOptions options, const PathJudge* judge = nullptr, Ranks ranks = Ranks::alone());
    const ExitAperture& aperture() const { return aperture_; }
    const RenderOptions& options() const { return options_; }
    // Pass k (1, 2, ...) at radius radiusMm, its pixel rays and photons guided by the light
    // learned in the passes before it (RenderState::learned(); empty: nothing learned yet).
    // photonsPerSource: the pass's photons per source (0: RenderOptions::photonsPerPass;
    // RenderState::photonsPerPass() when they are balanced).
    // visiblePhotons: its visible photons per source (-1: RenderOptions::visiblePhotonsPerPass;
    // RenderState::visiblePhotons() when they are balanced).
    // deadline: checked once per block of pixels, photons and part points; once it has passed
    // the pass throws DeadlinePassed (tracer/runtime/deadline.h) and has no result. One process
    // only (the ranks must stop together: with several, the limit is checked between passes).
    RenderPass runPass(int k, double radiusMm, const std::vector<double>& learned = {},
                       uint64_t photonsPerSource = 0, int64_t visiblePhotons = -1,
                       const Deadline& deadline = {}) const;
    // The backward stage of pass k.
    BackwardOptions backwardOptions(int k) const;

  private:
    const TransportView& ts_;
    DetectorImage detector_;
    ExitAperture aperture_;
    RenderOptions options_;
    const PathJudge* judge_ = nullptr;
    Ranks ranks_;
    LensConnector connector_;  // RenderOptions::connectThroughLens (its pilot, once)
    PartLight parts_;          // RenderOptions::partSamples (its pilot, once)
    PartLight partPhotons_;    // RenderOptions::partPhotons (PartMode::Photons; its pilot, once)
};

// Where photons land around a view point v, for the light that reaches it from one side of
// its face (its own side: reflected light; the other: transmitted light).
//   inGap  the view point lies in a gap on that side: another surface within kGapFraction x r
//          in front of it (a lens flat under a spacer's end 1 um away, an edge 50 um from the
//          barrel's bore). A photon is gathered only by view points in the same kind of place
//          as itself: the light in a gap differs by orders of magnitude from the light beside
//          it, and a disk reaching across the gap's border would carry one into the other.
//   viewInGap  for transmitted light (the other side), the same on the view point's own side,
//          where that light leaves: a photon counts only where both places match (a lens's
//          back flat under its retainer sends its light into the retainer, the open part of
//          the flat beside it toward the sensor).
//   share  the part of v's gathering disk (radius r, in its tangent plane) where such photons
//          land: on v's object, with its orientation, in v's kind of place. `samples` points
//          of the disk (a Fibonacci spiral turned by `turn` radians, equal areas) are projected
//          along the normal onto v's object, through anything else. 1 inside a face, about
//          1/2 at a straight rim, about 2 w / (pi r) on a strip of width w < r. The photon
//          estimate divides by share x pi r^2, the area photons can land on, instead of
//          pi r^2; at least 1/samples (the view point's own point counts); 1 with samples 0.
struct DiskShare {
    double share = 1.0;
    bool inGap = false, viewInGap = false;
};
inline constexpr double kGapFraction = 0.1;
DiskShare viewPointAreaShare(const Scene& scene, const ViewPoint& v, double radiusMm, int samples,
                             double turn, bool otherSide = false);
// A view point's gathering disk, fitted to the piece of surface it lies on (a lens's 2 mm
// flat, a spacer's end, a stop's 50 um edge band): where less than kFitShare of the pass's
// disk (radius r_k) lies on its piece, the piece's width w through the view point is
// measured (pieceWidth) and the disk's radius is
//     r_v = min(r_k, kPieceRadiusFraction w),
// a disk no wider than its piece: the photons averaged come from the piece, not from its
// surroundings, and the radiance across a narrow piece, which varies on the piece's scale, is
// not smeared over a disk many times wider. It shrinks with the passes once r_k does. share
// and halfShare: the parts of the disks of radius r_v and r_v / 2 where the photons land
// (viewPointAreaShare); the second serves the half-radius estimate that bounds the radius
// bias (RenderState::radiusBias). A disk whole on its face costs what it did before (its
// outer probes only); the gap rule's height stays kGapFraction r_k.
struct GatherDisk {
    double radiusMm = 0.0;
    double share = 1.0, halfShare = 1.0;
    bool inGap = false, viewInGap = false;  // as DiskShare's
    uint64_t rays = 0;                      // the probe rays it cost
};
inline constexpr int kPieceWidthLines = 4;
inline constexpr double kPieceRadiusFraction = 0.5;
inline constexpr double kFitShare = 0.5;
GatherDisk viewPointDisk(const Scene& scene, const ViewPoint& v, double radiusMm, int samples,
                         double turn, bool otherSide = false);
// The width of the piece v's photons land on (FaceProbe in render.cpp): the second narrowest
// of its chords through v along kPieceWidthLines lines turned by `turn`, each half measured
// to reachMm / 256 and at most reachMm (for a strip of width w between w and sqrt 2 w).
double pieceWidth(const Scene& scene, const ViewPoint& v, double reachMm, double gapMm, double turn,
                  bool otherSide = false);
// Whether the surface point (on object, primitive) has another surface within gapMm in
// direction side.
bool inGapAt(const Scene& scene, const Vec3& point, int object, int primitive, const Vec3& side,
             double gapMm);

// A photon is gathered by a view point, and a probe counts toward its share, only on the same
// object where the surface normal is within 25.8 degrees of the view point's: the disk stays
// on the view point's face and does not reach across a sharp edge (a stop's 45 degree knife
// chamfer gathered the sunlit front's photons into the view points behind it and doubled the
// stop's light). Gathering and share use the same rule, so a bend within r is left out of
// both the photons and the area.
inline constexpr double kGatherNormalCos = 0.9;

// Whether the photons, rather than the backward rays, count a source's visible component:
// the sun and the delta kinds (collimated, point), which a backward ray cannot find.
bool photonsSeeSource(const Source& s);

// c4(n): the mean of the sample standard deviation of n normal samples over their standard
// deviation (1 below two samples); RenderState's mean relative errors divide by it.
double standardErrorBias(uint64_t n);

// The seed of stream family `purpose` of pass k: distinct for every (seed, k, purpose).
uint64_t passSeed(uint64_t seed, uint64_t pass, uint32_t purpose);

}  // namespace veil
