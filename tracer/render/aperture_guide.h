#pragma once
// Learned importance sampling of where the renderer's pixel rays cross the exit aperture
// (RenderOptions::guideFraction, `veil render --guide`).
//
// A pixel sees the scattered light of a lens through a small part of its exit aperture: on
// the Sun example most pixel rays leave the lens through the front without meeting a lit
// surface, and in a typical pixel one of its ~5 view points per pass carries 80 % of its
// gathered light. The guide learns, per block of kBlockPixels x kBlockPixels pixels, how the
// light each pixel ray brought back (visible, direct and gathered, as it entered the image)
// spreads over a kCells x kCells grid on the unit square that samplePixelRay() maps, area for
// area, onto the aperture disk; the next pass draws its aperture points from the mixture
//     p(cell) = (1 - g) / kCells^2 + g * (light learned in the cell) / (light learned),
// g the guided fraction, and divides each ray's weight by the density of that mixture on the
// unit square (its cell's p times kCells^2). Every cell keeps at least (1 - g) of its uniform
// density, so no ray's weight grows beyond 1 / (1 - g) and no part of the aperture is left
// out: each pass stays an unbiased estimate, whatever the learned light. The warp maps the
// stratified uniforms cell by cell (the row by the marginal, the column within it), so the
// strata keep their spread.
//
// Passes are no longer independent samples of one distribution: pass k depends on passes
// 1..k-1 through the guide. Each pass is still unbiased given those before it, so the passes'
// deviations are uncorrelated and the mean and the error from their spread keep their
// meaning. The learned sums are part of the render's state and its checkpoint; a resumed run
// gives bitwise an uninterrupted one.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace veil {

class ApertureGuide {
  public:
    static constexpr int kBlockPixels = 16;  // pixels per block side
    static constexpr int kCells = 16;        // aperture cells per side of the unit square
    static constexpr int kCellCount = kCells * kCells;

    ApertureGuide() = default;
    ApertureGuide(int pixelsX, int pixelsY);

    // The learned light is held per (pixel block, cell): bins() values.
    size_t bins() const { return static_cast<size_t>(blocksX_) * blocksY_ * kCellCount; }
    size_t bin(int pixel, int cell) const;
    // The cell of a point (u, v) of the unit square (u the column).
    static int cellOf(double u, double v);

    // Sampling tables for guided fraction g in [0, 1) from learned sums (bins() values,
    // >= 0). g = 0 or a block with no light learned: the identity, density 1.
    void prepare(const std::vector<double>& learned, double g);

    struct Warped {
        double u = 0.0, v = 0.0;  // the aperture's uniforms
        double density = 1.0;     // of (u, v) on the unit square
        int cell = 0;
    };
    // Maps uniforms (u, v) in [0, 1) of pixel `pixel` to the guided ones.
    Warped warp(int pixel, double u, double v) const;
    // The density warp() gives the point (u, v) of the unit square.
    double density(int pixel, double u, double v) const;

  private:
    size_t block(int pixel) const;
    int pixelsX_ = 0, pixelsY_ = 0, blocksX_ = 0, blocksY_ = 0;
    // Per block: whether guided, the cells' probabilities, the row CDF (kCells + 1) and each
    // row's column CDF (kCells x (kCells + 1)).
    std::vector<uint8_t> guided_;
    std::vector<double> probability_, rowCdf_, columnCdf_;
};

}  // namespace veil
