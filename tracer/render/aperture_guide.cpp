#include "tracer/render/aperture_guide.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace veil {

ApertureGuide::ApertureGuide(int pixelsX, int pixelsY)
    : pixelsX_(pixelsX),
      pixelsY_(pixelsY),
      blocksX_((pixelsX + kBlockPixels - 1) / kBlockPixels),
      blocksY_((pixelsY + kBlockPixels - 1) / kBlockPixels) {
    if (pixelsX < 1 || pixelsY < 1)
        throw std::invalid_argument("ApertureGuide: the detector has no pixels");
    guided_.assign(static_cast<size_t>(blocksX_) * blocksY_, 0);
}

size_t ApertureGuide::block(int pixel) const {
    const int x = pixel % pixelsX_, y = pixel / pixelsX_;
    return static_cast<size_t>(y / kBlockPixels) * blocksX_ + x / kBlockPixels;
}

size_t ApertureGuide::bin(int pixel, int cell) const {
    return block(pixel) * kCellCount + static_cast<size_t>(cell);
}

int ApertureGuide::cellOf(double u, double v) {
    const int i = std::clamp(static_cast<int>(u * kCells), 0, kCells - 1);
    const int j = std::clamp(static_cast<int>(v * kCells), 0, kCells - 1);
    return j * kCells + i;
}

void ApertureGuide::prepare(const std::vector<double>& learned, double g) {
    if (!(g >= 0.0 && g < 1.0))
        throw std::invalid_argument("ApertureGuide: the guided fraction must be in [0, 1), not " +
                                    std::to_string(g));
    if (learned.size() != bins())
        throw std::invalid_argument("ApertureGuide: " + std::to_string(learned.size()) +
                                    " learned values for " + std::to_string(bins()) + " bins");
    const size_t blocks = guided_.size();
    probability_.assign(blocks * kCellCount, 1.0 / kCellCount);
    rowCdf_.assign(blocks * (kCells + 1), 0.0);
    columnCdf_.assign(blocks * kCells * (kCells + 1), 0.0);
    for (size_t b = 0; b < blocks; ++b) {
        const double* x = learned.data() + b * kCellCount;
        double sum = 0.0;
        for (int c = 0; c < kCellCount; ++c) sum += std::max(x[c], 0.0);
        guided_[b] = g > 0.0 && sum > 0.0 && std::isfinite(sum);
        if (!guided_[b]) continue;
        double* p = probability_.data() + b * kCellCount;
        for (int c = 0; c < kCellCount; ++c)
            p[c] = (1.0 - g) / kCellCount + g * std::max(x[c], 0.0) / sum;
        double* rows = rowCdf_.data() + b * (kCells + 1);
        for (int j = 0; j < kCells; ++j) {
            double row = 0.0;
            for (int i = 0; i < kCells; ++i) row += p[j * kCells + i];
            rows[j + 1] = rows[j] + row;
            double* columns = columnCdf_.data() + (b * kCells + j) * (kCells + 1);
            for (int i = 0; i < kCells; ++i) columns[i + 1] = columns[i] + p[j * kCells + i] / row;
            columns[kCells] = 1.0;
        }
        rows[kCells] = 1.0;
    }
}

namespace {

// The interval k of a CDF (n + 1 values from 0 to 1) holding x, and x's place in it.
std::pair<int, double> invert(const double* cdf, int n, double x) {
    int k = 0;
    while (k < n - 1 && x >= cdf[k + 1]) ++k;
    const double width = cdf[k + 1] - cdf[k];
    const double t = width > 0.0 ? (x - cdf[k]) / width : 0.5;
    return {k, std::clamp(t, 0.0, 1.0)};
}

double belowOne(double x) { return std::min(x, std::nextafter(1.0, 0.0)); }

}  // namespace

ApertureGuide::Warped ApertureGuide::warp(int pixel, double u, double v) const {
    const size_t b = block(pixel);
    if (guided_.empty() || !guided_[b] || probability_.empty()) return {u, v, 1.0, cellOf(u, v)};
    const auto [j, tv] = invert(rowCdf_.data() + b * (kCells + 1), kCells, v);
    const auto [i, tu] =
        invert(columnCdf_.data() + (b * kCells + static_cast<size_t>(j)) * (kCells + 1), kCells, u);
    Warped w;
    w.u = belowOne((i + tu) / kCells);
    w.v = belowOne((j + tv) / kCells);
    w.cell = j * kCells + i;
    w.density = probability_[b * kCellCount + static_cast<size_t>(w.cell)] * kCellCount;
    return w;
}

double ApertureGuide::density(int pixel, double u, double v) const {
    const size_t b = block(pixel);
    if (guided_.empty() || !guided_[b] || probability_.empty()) return 1.0;
    return probability_[b * kCellCount + static_cast<size_t>(cellOf(u, v))] * kCellCount;
}

}  // namespace veil
