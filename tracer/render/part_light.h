#pragma once
// Light traced from the lens's small lit parts to the sensor (docs/render.md, "Small parts
// traced to the sensor").
//
// A stop's 50 um edge band, a lens's butt end or its 2 mm flat is lit through the elements in
// front of it and seen through the elements behind it. The light connected through the lens
// (tracer/render/lens_connection.h) finds the light arriving at a point exactly, but a point
// counts only where a pixel ray lands on the part, which on a narrow part happens a few times
// a pass. Here points are drawn on the parts themselves, by area, and their light is traced
// forward to the sensor (light tracing, the t = 1 strategy of bidirectional path tracing):
//
//   1. Parts. A candidate is a chain (source s, object, k) of the connector on an object that
//      scatters, whose lobe the backward rays do not follow, of any size (what counts is the
//      lit area, which the pilot finds: the rim of a mirror's holder that the converging beam
//      grazes is a few mm wide on a part of 10^4 mm^2, and few pixel rays find it), and
//      whose shape can be drawn by area (PartShape: an exact
//      face with a circular, annular or rectangular aperture, a butt end, the triangles of a
//      mesh), with a step j >= k where its light goes on toward the detector as designed (the
//      faces of steps j..N-1, then the detector; j = N straight to it, as light a lens's back
//      flat scatters out of the glass). A target is a candidate in which the pilot below
//      finds light.
//   2. Points. Each pass draws about `samples` points, split over the targets by their
//      shares of q (at least one each: split()), or evenly (a sweep's, whose variants change
//      the parts' light and so their shares), each target's from its own streams. A
//      target's sample picks a cell of one of its grids (Level: a box of the part's map
//      (u, v), PartShape, with kCells x kCells cells) with probability q over the target's
//      q, then a point uniform in the cell. q comes from a pilot
//      (fixed seed): rounds of kPilotPerCell points per cell of the whole map, up to
//      kPilotRounds while the part found light in fewer than kPilotFound points; then, where
//      the lit cells fit in a box of at most kZoom of the grid, the same on that box's own
//      grid (up to kLevels grids). Within a target, the whole map's cells get kDefensive
//      evenly, so that every point keeps a chance wherever the pilot saw nothing, and the
//      deepest grid's cells the rest, kSpread of it evenly and the rest in proportion to the
//      root mean square of each cell's estimate (the allocation that minimizes the variance
//      of a sum over strata); a target's share of all q is kDefensive evenly over the
//      targets and the rest in proportion to its light. A point's density per mm^2 is the
//      mixture's, d(x) times the sum over the target's grids of the q of the cell holding it over
//      that cell's share of the map (density()), d the map's density.
//   3. Each point's light: the connection (connect(), the same solve as at a view point) gives
//      the radiance leaving toward a direction w, drawn toward a point of the face of step j,
//      or the detector, from the aim's cells (density d_y |y - x|^2 / |cos_y| per sr); the
//      light crosses steps j..N-1 as designed (LensConnector::onward) and reaches the pixel it
//      meets with flux L |cos_x| T / (p_w p_x), times the number of model wavelengths (one
//      drawn per point), over the samples. Where w meets that face first elsewhere than at
//      the drawn point (a curved face crossed twice), the sample counts nothing: each
//      direction is counted by its first crossing alone. Where that face's map can be
//      inverted, w also comes from the part's lobe (kLobeShare) and from the target's
//      direction guide (kGuideShare, GuideFrame in part_light.cpp: a grid over directions
//      learned from the pilot's), and p_w is the mixture's density: the three densities at
//      w, the aim's through w's first crossing of the face. The pilot's points send
//      kPilotDirections directions each.
//      A point sends RenderOptions::partDirections such directions, each with that share of
//      its light: one solve of the connection serves them all.
//   4. Ownership. A view point on a target's object, reached from the detector along the
//      designed path down to step j (BackwardOptions::parts, owns()), leaves the connection of
//      the target's chain to this; the rest of its light (gathered, direct, other chains,
//      other paths to the detector: ghosts, total internal reflection at a butt end) stays the
//      view points'. Both estimate the same light, so moving it changes the noise, not the
//      expectation.
//
// Photon mode (PartMode::Photons; docs/render.md, "Photons from the lit parts"). Where the
// scene has lobes that the photons splat onto the detector (RenderOptions::splatLobesBelowDeg:
// a 5 degree Gaussian mount), light that one small part scatters onto another narrow part and
// from there to the sensor is found by the sources' photons only where they hit the first part
// (a stop's bevel) and then the second within its lobe. Here the chains' parts are the
// starting points of photons instead:
//
//   1. Parts. Every chain (s, object, k) of the connector on an object that scatters, whose
//      lobe the backward rays do not follow, whose shape can be drawn by area, at any size (a
//      whole stop plate: the pilot finds its lit bevel). A target is one whose pilot finds
//      light on the detector after at least one splatted scatter past the part: from the
//      point, one direction drawn from the part's lobe and one child by weight at every
//      interaction, as far as the detector.
//   2. Points: as above, start() draws a point and its light (the connection's) and returns
//      the photon's start, its flux that light over the point's density.
//   3. Ownership. The photon pass gives the sources' photons that reach a target's object by
//      its chain where the connection tries (LensConnector::inView) no scattered children
//      there, but for the audit (kAuditRate times, where the connection misses their path):
//      the light scattered at those points is the part photons', whatever it does next.
//
// Deterministic: sample i of a pass draws from CounterRng(seed, i), blocks of samples are
// reduced in a fixed order on rank 0 (tracer/runtime/ordered_blocks.h); thread-safe.

#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "tracer/records/detector.h"
#include "tracer/render/lens_connection.h"
#include "tracer/render/path_judge.h"
#include "tracer/runtime/deadline.h"
#include "tracer/runtime/ranks.h"
#include "tracer/transport/interaction.h"

namespace veil {

// A point drawn on an object's surface from two uniforms (u, v): by an equal-area map on exact
// faces (equal projected area on a curved face, whose density then carries its slope), and on
// a mesh by triangle count (u picks the triangle, each as likely as any other, and with v a
// point uniform on it).
struct PartPoint {
    Vec3 point{0.0};
    Vec3 normal{0.0};  // the object's orientation there (SceneHit::normal)
    int primitive = 0;
    double density = 0.0;  // of the point per mm^2, for (u, v) uniform on [0, 1)^2
};
class PartShape {
  public:
    PartShape() = default;
    // Supported: an exact face with a circular, annular or rectangular aperture, a butt end
    // (its rims too: a point beyond a rim curve is none), the triangles of a mesh object.
    explicit PartShape(const Scene& scene, int object);
    bool valid() const { return kind_ != Kind::None; }
    double areaMm2() const { return area_; }
    std::optional<PartPoint> at(double u, double v) const;
    // The density per mm^2 with which at() draws a point of this shape, at `point` (on triangle
    // `primitive` of a mesh), for (u, v) uniform: 0 where at() never lands.
    double densityAt(const Vec3& point, int primitive) const;
    // The inverse of at() on an exact face with a circular, annular or rectangular aperture:
    // the (u, v) at() maps to `point` (clamped to [0, 1]); none on other shapes.
    std::optional<Vec2> uvOf(const Vec3& point) const;
    bool invertible() const {
        return kind_ == Kind::Disc || kind_ == Kind::Annulus || kind_ == Kind::Rectangle;
    }

  private:
    enum class Kind { None, Disc, Annulus, Rectangle, Cylinder, Mesh };
    Kind kind_ = Kind::None;
    const SceneObject* object_ = nullptr;
    const TriangleMesh* mesh_ = nullptr;
    double a_ = 0.0, b_ = 0.0;  // radii (r, or r0 and r1), half sizes, or z limits
    double radius_ = 0.0;       // a butt end's
    double area_ = 0.0;
    double mapArea_ = 0.0;             // of the map's range (projected area for faces)
    std::vector<uint32_t> triangles_;  // a mesh's (ascending)
    std::vector<double> areas_;        // theirs
};

enum class PartMode { Onward, Photons };

class PartLight {
  public:
    static constexpr int kCells = 16;
    static constexpr int kCellCount = kCells * kCells;
    static constexpr int kPilotPerCell = 8;
    // The pilot's rounds (kPilotPerCell points per cell each): up to kPilotRounds, while a
    // candidate has found light in fewer than kPilotFound of its points.
    static constexpr int kPilotRounds = 16;
    static constexpr int kPilotFound = 512;
    // Directions each pilot point sends on (the light of a flat's points leaves within a few
    // degrees of the one way to the sensor: one direction a point finds it too rarely).
    static constexpr int kPilotDirections = 16;
    // The pilot's zoom: a level's box of lit cells gets a grid of its own when it holds at
    // most kZoom of the cells, up to kLevels levels.
    static constexpr double kZoom = 0.25;
    static constexpr int kLevels = 3;
    static constexpr double kDefensive = 0.25;
    // The share of a target's deepest grid spread evenly over its cells, the rest in
    // proportion to the light the pilot found in each: a pilot that found a flat's light in
    // a few dozen points leaves lit cells it happened to miss, whose points would otherwise
    // carry 100x the light of their neighbours.
    static constexpr double kSpread = 0.5;
    // The point on the next face each direction aims at: a cell of a kAim x kAim grid over the
    // face's map, drawn in proportion to the light the pilot found through it (mixed with
    // kDefensive of a uniform share), then a point uniform in the cell.
    static constexpr int kAim = 8;
    static constexpr int kAimCount = kAim * kAim;
    // The share of directions drawn from the part's own lobe instead (where the next face's
    // map can be inverted, so that the aim's density of a lobe's direction is known): light a
    // flat scatters into the glass reaches the next face within the critical angle only from
    // a few of its points, which the aim finds rarely and the lobe often.
    static constexpr double kLobeShare = 0.5;
    // Where the pilot found light, kGuideShare of the directions come from a guide instead: a
    // grid over the directions seen from the point (kGuideU x kGuideV cells, fixed to the way
    // toward the detector), each cell drawn in proportion to the light the pilot's directions
    // brought through it. The light of a flat's points that reaches the sensor leaves within
    // a few degrees of one way; the lobe finds it in one direction in a hundred.
    static constexpr double kGuideShare = 0.5;
    // The direction guide's map at a point x (GuideFrame in part_light.cpp): directions by
    // their angle theta from the way to the detector's centre, u = sin(theta / 2), and their
    // azimuth about it from the side away from the detector's axis, v.
    static constexpr int kGuideU = 32, kGuideV = 16;
    static constexpr int kGuideCount = kGuideU * kGuideV;
    // Photon mode's pilot: directions drawn from the part's lobe per point, and from a
    // splatted lobe it meets per direction.
    static constexpr int kPilotSplits = 16;

    PartLight() = default;
    // The targets (see the header comment) of the connector's chains, and their pilot.
    // followed[property]: the backward rays follow that property's lobe (no view point, no
    // part).
    // Photon mode: splatted[property] as splattedLobes() gives it (no target without one).
    PartLight(const TransportView& ts, const LensConnector& connector, int detectorObject,
              const std::vector<bool>& followed, PartMode mode = PartMode::Onward,
              const std::vector<bool>& splatted = {});
    bool any() const { return !targets_.empty(); }
    size_t targets() const { return targets_.size(); }
    PartMode mode() const { return mode_; }

    // Photon mode: whether the light source s's chain of `steps` crossings scatters at
    // `object` where the connection tries is the part photons'.
    bool carries(size_t s, int object, int steps) const;
    // Photon mode: photon i of a pass (the streams of `seed`): a point drawn on a target and
    // the light the connection finds there; none where it finds none. With `chain`, the
    // chain's events as light travels them (after Emit, before the scatter at the point).
    struct Start {
        size_t source = 0;
        int object = -1, primitive = 0, steps = 0, line = 0;
        double wavelengthNm = 0.0;
        Vec3 point{0.0}, normal{0.0};
        Vec3 toLight{0.0};  // unit, back along the arriving ray
        double distanceMm = 0.0;
        // The flux arriving on the part that the point stands for (the connection's light
        // over the point's density, times the model's lines: one is drawn per point), for
        // one photon a pass: divide by the photons.
        double flux = 0.0;
        // The pilot's directions from the target's lit points per one that met a splatted
        // lobe: how many to draw from the point for about one such lobe (the photon pass's
        // split there, at most RenderOptions::lobeSplats).
        double legsPerLobe = 1.0;
    };
    std::optional<Start> start(uint64_t i, uint64_t seed, LensConnector::Work& work,
                               std::vector<PathEvent>* chain = nullptr) const;
    // Photon mode: whether the pilot saw light reach the detector from a scatter at this
    // place (an exact face, or a mesh's triangle), as the part or as the splatted lobe after
    // it: there the photons split (RenderOptions::lobeSplats), elsewhere one direction does.
    bool productive(int object, int primitive) const;
    // Photon mode: the designed step j from which the pilot's splats from this place went on
    // as designed (faces j..N-1, then the detector; N straight to it), where the most of them
    // did; -1 where none did. The photon pass aims splats there (aimFace()).
    int aimStep(int object, int primitive) const;
    // The step most of the object's places aim at (-1 for none): a place of that object the
    // pilot did not see may still send light there (the pilot's places are a sample).
    int aimStepOfObject(int object) const {
        return objectAims_.empty() ? -1 : objectAims_[static_cast<size_t>(object)];
    }
    // The face of designed step j (N: the detector), drawn by area (PartShape); invalid where
    // it cannot be drawn.
    const PartShape& aimFace(int step) const { return faces_[static_cast<size_t>(step)]; }
    // The hit a start's light makes on its part (the interaction there).
    static SceneHit hitOf(const Scene& scene, const Start& s);

    // Whether a view point on `object`, reached from the detector down to designed step
    // `designed`, leaves the connection of source s's chain of `steps` crossings to this.
    bool owns(size_t s, int object, int steps, int designed) const;

    struct Result {
        std::vector<double> pixels;                    // flux per pixel
        std::vector<std::vector<double>> byCriterion;  // [criterion][pixel]
        uint64_t samples = 0, rays = 0, found = 0;     // found: samples that reached a pixel
        // Over the samples, the sum of the flux each brought to its pixel and of its square
        // (RenderState::effectiveRays).
        double sum = 0.0, squares = 0.0;
    };
    // One pass's estimate from about `samples` points drawn from the streams of `seed`, split
    // over the targets by their shares (`splitByLight`) or evenly
    // (RenderOptions::partSplitByLight). Each point sends `directions` directions on
    // (RenderOptions::partDirections). `deadline` is checked once per block of points (it
    // throws DeadlinePassed once passed; one process only).
    Result trace(const DetectorImage& detector, uint64_t samples, uint64_t seed,
                 const PathJudge* judge, bool prune, const Ranks& ranks, int directions = 1,
                 bool splitByLight = true, const Deadline& deadline = {}) const;

  private:
    // A box [lo, hi] of a part's map (u, v) with a kCells x kCells grid.
    struct Level {
        Vec2 lo{0.0}, hi{1.0};
        double area() const { return (hi.x - lo.x) * (hi.y - lo.y); }
        // The point at (du, dv) within cell `cell`.
        Vec2 at(int cell, double du, double dv) const;
    };
    struct Target {
        size_t source = 0;
        int object = -1, steps = 0, onward = 0;  // the chain, and the step j light goes on at
        std::vector<double> aim;                 // [aim cell]: probability (empty: uniform)
        std::vector<double> aimCumulative;       // its running sums
        std::vector<Level> levels{Level{}};      // the whole map, then the pilot's zoom
        std::vector<int> first;                  // [level]: its cell 0's stratum
        int legs = 0, lobes = 0;                 // photon mode's pilot (Start::legsPerLobe)
        std::vector<double> guide;               // [guide cell]: probability (empty: none)
        std::vector<double> guideCumulative;     // its running sums
    };
    struct Stratum {
        int target = 0, level = 0, cell = 0;
    };
    struct Splat {
        int pixel = -1;
        double flux = 0.0;
        int aim = 0;              // the aim cell
        int guide = 0;            // the direction's guide cell
        int legs = 0, lobes = 0;  // photon mode: directions drawn, and those that met a
                                  // splatted lobe
    };
    struct Scratch;
    // The point of target t at uv of its map, drawn with density uvDensity per unit of the
    // map: its flux at a pixel (at none without a detector: the pilot), false when it reaches
    // none.
    // With `directions` > 1, as many directions from the point, each with 1 / directions of
    // its light (the connection's solve shared); `each`, if given, is called for every one
    // that reaches a pixel, with the scratch's events of its path. `out` is the first.
    bool sample(const Target& t, const Vec2& uv, double uvDensity, CounterRng& rng,
                const DetectorImage* detector, Scratch& scratch, LensConnector::Work& work,
                Splat& out, int directions = 1,
                const std::function<void(const Splat&, const Scratch&)>* each = nullptr) const;
    // The density per unit of the map with which a pass draws uv on target t (its levels'
    // mixture).
    double density(const Target& t, const Vec2& uv) const;
    // The point of target t at uv and its light (Start), drawn with uvDensity.
    std::optional<Start> lit(const Target& t, const Vec2& uv, double uvDensity, CounterRng& rng,
                             LensConnector::Work& work, std::vector<PathEvent>* chain) const;
    // The pilot's sample in photon mode: from the point, kPilotSplits directions from its
    // lobe, one child by weight onward; where one meets a splatted lobe, kPilotSplits
    // directions from it on to the detector: the mean flux that reaches it.
    // With `places`, the places that led light to the detector; with `aims`, (place, j) for
    // each splat that went on from a splatted lobe's place as designed from step j.
    bool samplePhoton(const Target& t, const Vec2& uv, double uvDensity, CounterRng& rng,
                      LensConnector::Work& work, Splat& out,
                      std::vector<uint64_t>* places = nullptr,
                      std::vector<std::pair<uint64_t, int>>* aims = nullptr) const;
    static uint64_t placeKey(int object, int primitive) {
        return (static_cast<uint64_t>(static_cast<uint32_t>(object)) << 32) |
               static_cast<uint32_t>(primitive);
    }
    // The stratum of a photon-mode sample drawn from u (over all targets' strata).
    const Stratum& stratumOf(double u) const;
    // The stratum of target t's sample drawn from u (over its own strata).
    const Stratum& stratumOf(size_t t, double u) const;
    // A pass's split of `samples` over the targets (trace()): [target] running sums of its
    // count, each count max(1, round(samples x its share)), or of samples / targets with
    // !byLight.
    std::vector<uint64_t> split(uint64_t samples, bool byLight) const;

    const TransportView* ts_ = nullptr;
    const LensConnector* lc_ = nullptr;
    PartMode mode_ = PartMode::Onward;
    std::vector<bool> splatted_;        // photon mode: [property]
    std::vector<uint64_t> productive_;  // photon mode: placeKey()s, sorted
    std::vector<std::pair<uint64_t, int>> aims_;  // photon mode: (placeKey, step), sorted
    std::vector<int> objectAims_;                 // photon mode: [object] (aimStepOfObject)
    int detectorObject_ = -1;
    Vec3 detectorCentre_{0.0}, detectorAxis_{0.0, 0.0, 1.0};  // the direction guide's frame
    size_t objects_ = 0;
    std::vector<PartShape> shapes_;  // [object]: the candidates' (others invalid)
    std::vector<PartShape> faces_;   // [step]: the designed faces', then the detector's
    std::vector<Target> targets_;
    std::vector<std::vector<int>> targetsOf_;  // [source * objects + object]
    std::vector<Stratum> strata_;              // drawn with q_
    std::vector<double> q_, cumulative_;       // [stratum]: probability, running sums
    // [target]: its strata's running sums of q (from 0), and its share of all q (trace()).
    std::vector<std::vector<double>> targetCumulative_;
    std::vector<double> targetShare_;
};

}  // namespace veil
