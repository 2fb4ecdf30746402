#pragma once
// Learned directions for the photons' scatters (RenderOptions::scatterGuideFraction,
// `veil render --scatter-guide`, docs/render.md "Photons scattered toward what the sensor sees").
//
// Light scattered by a mount inside a barrel reaches the image only where it lands on a part
// the pixels see (a view point gathers it). From a lit mount most of a Lambertian hemisphere
// looks at parts no pixel sees: on the dark mounts of the seed's figure 10a, about 1 photon in
// 200 carries the gathered light. The guide learns, per cell of a grid over the scene (cubes,
// kCellsAlongLongest along the scene's longest side, at most kMaxSlots of them, hashed beyond),
// how much light the photons that scattered there went on to have gathered, per cell of an
// equal-area kBands x kSectors grid over the sphere of directions (bands of equal height in z,
// sectors of equal angle about it). A gathered value counts for every scatter on the photon's
// path before it. The next pass draws a scattered direction from the mixture
//     p(w) = (1 - g) p_bsdf(w) + g q(cell of w) kCellCount / (4 pi)
// (g the guided fraction, q the learned light's share of the cell, uniform within it) and
// multiplies the photon's flux by p_bsdf(w) / p(w): the one-sample estimate over the mixture,
// whose weight stays below 1 / (1 - g), and whose bsdf half covers every direction the surface
// scatters into, so each pass stays unbiased whatever was learned. A direction the guide draws
// where the surface does not scatter ends the photon (weight 0).
//
// The same sums give the weight windows (RenderOptions::weightWindow, `--weight-window W`):
// per cube, the light gathered after its scatters over the flux they scattered, its yield;
// over the passes, the light gathered over the flux emitted. A photon that scatters in a cube
// then expects ratio = (its flux / its source's flux per photon) (cube's yield / mean yield)
// of what an average photon brings. Above W it splits into min(ratio, kMaxSplit) photons of its
// flux over that count, each drawing its own direction; below 1 / W it plays Russian roulette, kept
// with probability max(ratio, kMinSurvival), its flux divided by it. Where the photon heads toward
// what the sensor sees it is followed more often; where it heads away, less (adjoint-driven Russian
// roulette and splitting). Both keep the expected flux, so each pass stays unbiased; a cube with
// fewer than kMinScatters scatters learned has no window.
//
// The learned light is weighted per image region (EmissionGuide::regionWeight) where the
// emission guide is on, so a dim part of the image draws photons as well as a bright one.
// Like the other guides, the learned sums are the render's state: checkpoint, resume and MPI
// give bitwise the same passes.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "geometry/frame.h"
#include "tracer/runtime/rng.h"
#include "tracer/transport/interaction.h"

namespace veil {

class ScatterGuide {
  public:
    static constexpr int kBands = 12, kSectors = 12;
    static constexpr int kCellCount = kBands * kSectors;
    static constexpr int kCellsAlongLongest = 16;
    static constexpr int kMaxSlots = 1024;
    static constexpr int kMaxSplit = 8;
    static constexpr double kMinSurvival = 0.05;
    static constexpr double kMinScatters = 100.0;

    ScatterGuide() = default;
    // The grid over the scene's bounds (not empty).
    explicit ScatterGuide(const Bounds3& scene);

    size_t slots() const { return slots_; }
    // The learned values: [slot][cell] the region-weighted light gathered after a scatter
    // there; then per slot the plain light gathered after its scatters, the flux they
    // scattered and their count; then the plain light gathered and the flux emitted.
    size_t bins() const { return slots_ * (kCellCount + 3) + 2; }
    // The slot of a point (points outside the bounds take the nearest cell's).
    int slot(const Vec3& p) const;
    // The cell of a unit direction.
    static int cellOf(const Vec3& w);
    size_t bin(int slot, int cell) const {
        return static_cast<size_t>(slot) * kCellCount + static_cast<size_t>(cell);
    }
    size_t gatheredBin(int slot) const {
        return slots_ * kCellCount + 3 * static_cast<size_t>(slot);
    }
    size_t scatteredBin(int slot) const { return gatheredBin(slot) + 1; }
    size_t scattersBin(int slot) const { return gatheredBin(slot) + 2; }
    size_t totalGatheredBin() const { return slots_ * (kCellCount + 3); }
    size_t emittedBin() const { return totalGatheredBin() + 1; }

    // Sampling tables for guided fraction g in [0, 1) from the learned sums (bins() values,
    // >= 0). A slot with no light learned is not guided.
    void prepare(const std::vector<double>& learned, double g, double window = 0.0);
    double fraction() const { return g_; }
    // The photons a scattered photon of relative flux `relative` (its flux over its source's
    // flux per photon, before the emission guide's density) in `slot` becomes, from one uniform u,
    // and the factor on its flux: {1, 1} without a window there; {n, 1 / n} split; {1, 1 / q} or
    // {0, 0} after roulette.
    struct Window {
        int photons = 1;
        double factor = 1.0;
    };
    Window window(int slot, double relative, double u) const;
    // Its expected share of an average photon's light there (-1: no window).
    double ratio(int slot, double relative) const;
    bool guides(int slot) const { return g_ > 0.0 && !cdf_.empty() && lit_[slot] != 0; }
    // A direction drawn from slot's learned cells (u0 the cell, u1 u2 within it), and that
    // density per steradian (0 where slot is not guided).
    Vec3 sample(int slot, double u0, double u1, double u2) const;
    double pdf(int slot, const Vec3& w) const;
    // Scattered child c of `in` at a place of `slot`: its direction from the mixture (one
    // uniform chooses the guide or the surface, then the guide's three or the surface's two),
    // `weight` multiplied by the surface's density of it over the mixture's. nullopt where the
    // surface gives no direction or the guide drew one the child does not scatter into. A slot
    // the guide does not guide: the surface's direction, weight unchanged.
    std::optional<Vec3> draw(const Interaction& in, int c, int slot, CounterRng& rng,
                             double& weight) const;

  private:
    Vec3 lo_{0.0};
    double inverseEdge_ = 1.0;
    int n_[3] = {1, 1, 1};
    bool hashed_ = false;
    size_t slots_ = 1;
    double g_ = 0.0;
    double window_ = 0.0;
    std::vector<double> yield_;  // [slot]: relative to the mean yield; < 0 unknown
    std::vector<double> cdf_;   // [slot][cell]: cumulative share, the last 1
    std::vector<double> q_;     // [slot][cell]: share
    std::vector<uint8_t> lit_;  // [slot]
};

}  // namespace veil
