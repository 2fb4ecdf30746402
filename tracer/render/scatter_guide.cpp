#include "tracer/render/scatter_guide.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "geometry/numerics.h"

namespace veil {

ScatterGuide::ScatterGuide(const Bounds3& scene) {
    if (scene.empty() ||
        !std::isfinite(scene.lo.x + scene.lo.y + scene.lo.z + scene.hi.x + scene.hi.y + scene.hi.z))
        throw std::invalid_argument("ScatterGuide: the scene has no finite bounds");
    const Vec3 extent = scene.hi - scene.lo;
    const double longest = std::max({extent.x, extent.y, extent.z});
    const double edge = longest > 0.0 ? longest / kCellsAlongLongest : 1.0;
    lo_ = scene.lo;
    inverseEdge_ = 1.0 / edge;
    size_t cells = 1;
    for (int a = 0; a < 3; ++a) {
        n_[a] = std::clamp(static_cast<int>(std::ceil(extent[a] * inverseEdge_)), 1,
                           kCellsAlongLongest);
        cells *= static_cast<size_t>(n_[a]);
    }
    hashed_ = cells > static_cast<size_t>(kMaxSlots);
    slots_ = hashed_ ? static_cast<size_t>(kMaxSlots) : cells;
}

int ScatterGuide::slot(const Vec3& p) const {
    int i[3];
    for (int a = 0; a < 3; ++a) {
        const double x = (p[a] - lo_[a]) * inverseEdge_;
        // NaN and far points alike land in a boundary cell.
        i[a] = x >= 0.0 ? static_cast<int>(std::min(x, static_cast<double>(n_[a] - 1))) : 0;
    }
    if (!hashed_) return (i[2] * n_[1] + i[1]) * n_[0] + i[0];
    const uint64_t h = (static_cast<uint64_t>(i[0]) * 73856093u) ^
                       (static_cast<uint64_t>(i[1]) * 19349663u) ^
                       (static_cast<uint64_t>(i[2]) * 83492791u);
    return static_cast<int>(h % static_cast<uint64_t>(kMaxSlots));
}

int ScatterGuide::cellOf(const Vec3& w) {
    const int band = std::clamp(static_cast<int>((w.z + 1.0) * 0.5 * kBands), 0, kBands - 1);
    double turn = std::atan2(w.y, w.x) / (2.0 * kPi);
    if (turn < 0.0) turn += 1.0;
    const int sector = std::clamp(static_cast<int>(turn * kSectors), 0, kSectors - 1);
    return band * kSectors + sector;
}

void ScatterGuide::prepare(const std::vector<double>& learned, double g, double window) {
    if (learned.size() != bins())
        throw std::invalid_argument("ScatterGuide: " + std::to_string(learned.size()) +
                                    " learned values for " + std::to_string(bins()) + " bins");
    if (!(g >= 0.0 && g < 1.0))
        throw std::invalid_argument("ScatterGuide: the guided fraction must lie in [0, 1)");
    if (!(window == 0.0 || (window >= 1.0 && window <= 1e6)))
        throw std::invalid_argument("ScatterGuide: the weight window must be 0 or in [1, 1e6]");
    g_ = g;
    window_ = window;
    yield_.assign(slots_, -1.0);
    const double mean = learned[totalGatheredBin()] / learned[emittedBin()];
    if (window > 0.0 && mean > 0.0 && std::isfinite(mean)) {
        for (size_t s = 0; s < slots_; ++s) {
            const int slot = static_cast<int>(s);
            const double scattered = learned[scatteredBin(slot)];
            if (!(learned[scattersBin(slot)] >= kMinScatters && scattered > 0.0)) continue;
            const double y = std::max(learned[gatheredBin(slot)], 0.0) / scattered / mean;
            if (std::isfinite(y)) yield_[s] = y;
        }
    }
    cdf_.assign(slots_ * kCellCount, 0.0);
    q_.assign(slots_ * kCellCount, 0.0);
    lit_.assign(slots_, 0);
    if (g == 0.0) return;
    for (size_t s = 0; s < slots_; ++s) {
        const double* x = learned.data() + s * kCellCount;
        double total = 0.0;
        for (int c = 0; c < kCellCount; ++c) total += std::max(x[c], 0.0);
        if (!(total > 0.0) || !std::isfinite(total)) continue;
        lit_[s] = 1;
        double sum = 0.0;
        for (int c = 0; c < kCellCount; ++c) {
            const double share = std::max(x[c], 0.0) / total;
            q_[s * kCellCount + c] = share;
            sum += share;
            cdf_[s * kCellCount + c] = sum;
        }
        cdf_[s * kCellCount + kCellCount - 1] = 1.0;
    }
}

Vec3 ScatterGuide::sample(int slot, double u0, double u1, double u2) const {
    const double* cdf = cdf_.data() + static_cast<size_t>(slot) * kCellCount;
    // The first cell whose cumulative share exceeds u0 (an empty cell never: its share adds
    // nothing, so u0 < its cumulative share would hold for the cell before it).
    const int cell = std::min(static_cast<int>(std::upper_bound(cdf, cdf + kCellCount, u0) - cdf),
                              kCellCount - 1);
    const int band = cell / kSectors, sector = cell % kSectors;
    const double z = std::clamp(-1.0 + 2.0 * (band + u1) / kBands, -1.0, 1.0);
    const double phi = 2.0 * kPi * (sector + u2) / kSectors;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    return {r * std::cos(phi), r * std::sin(phi), z};
}

double ScatterGuide::ratio(int slot, double relative) const {
    if (yield_.empty()) return -1.0;
    const double y = yield_[static_cast<size_t>(slot)];
    return y >= 0.0 ? relative * y : -1.0;
}

ScatterGuide::Window ScatterGuide::window(int slot, double relative, double u) const {
    const double r = ratio(slot, relative);
    if (!(r >= 0.0)) return {};
    if (r > window_) {
        const int n = static_cast<int>(std::min(r, static_cast<double>(kMaxSplit)));
        return {n, 1.0 / n};
    }
    if (r < 1.0 / window_) {
        const double q = std::max(r, kMinSurvival);
        return u < q ? Window{1, 1.0 / q} : Window{0, 0.0};
    }
    return {};
}

double ScatterGuide::pdf(int slot, const Vec3& w) const {
    if (!guides(slot)) return 0.0;
    return q_[bin(slot, cellOf(w))] * kCellCount / (4.0 * kPi);
}

std::optional<Vec3> ScatterGuide::draw(const Interaction& in, int c, int slot, CounterRng& rng,
                                       double& weight) const {
    if (!guides(slot)) return in.direction(c, rng);
    std::optional<Vec3> dir;
    if (rng.uniform() < g_) {
        const double u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
        dir = sample(slot, u0, u1, u2);
    } else {
        dir = in.direction(c, rng);
        if (!dir) return std::nullopt;
    }
    // The surface's density of the direction, on child c's side only (a direction the guide
    // drew on the other side is not c's to carry).
    const double cosOut = glm::dot(*dir, in.context.normal);
    const bool side = in.children[c].transmit ? cosOut < 0.0 : cosOut > 0.0;
    const double surface = side ? in.property->scatterPdf(in.context, *dir) : 0.0;
    if (!(surface > 0.0)) return std::nullopt;
    weight *= surface / ((1.0 - g_) * surface + g_ * pdf(slot, *dir));
    return dir;
}

}  // namespace veil
