#include "tracer/render/photon_pass.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <numbers>
#include <numeric>

#include "tracer/records/detector.h"
#include "tracer/records/path_history.h"
#include "tracer/render/designed_path.h"
#include "tracer/render/part_light.h"
#include "tracer/render/render.h"
#include "tracer/runtime/ordered_blocks.h"
#include "tracer/runtime/qmc.h"
#include "tracer/runtime/rng.h"
#include "tracer/surfaces/media.h"
#include "tracer/transport/interaction.h"

namespace veil {

namespace {

// The grid over the face a narrow lobe's aimed splats aim at (BlockTracer::splatLobe).
constexpr int kSplatAimGrid = 8;
constexpr int kSplatAimCells = kSplatAimGrid * kSplatAimGrid;

// The scattered child of `in` on the side of `dir` (reflected or transmitted), -1 for none.
int scatterChildToward(const Interaction& in, const Vec3& dir) {
    const bool transmit = glm::dot(dir, in.context.normal) < 0.0;
    for (int k = 0; k < in.count; ++k)
        if (in.children[k].scatter && in.children[k].transmit == transmit) return k;
    return -1;
}

// A view point as the grid stores it: where it is (float) and on which object, so that the
// candidates of a cell are tested from contiguous memory; the full view point is read only
// for those that pass.
struct GridEntry {
    float x = 0.0f, y = 0.0f, z = 0.0f;
    int32_t object = -1;
    uint32_t index = 0;
};

// View points in a uniform grid of cells of size 2r, each stored in every cell its sphere
// overlaps (at most 8), in compressed rows: a photon looks in its own cell only.
class ViewPointGrid {
  public:
    ViewPointGrid(const std::vector<ViewPoint>& vps, double radiusMm) : r_(radiusMm) {
        cell_ = 2.0 * radiusMm;
        size_t want = 1;
        while (want < 2 * vps.size() + 16) want <<= 1;
        mask_ = want - 1;
        start_.assign(want + 1, 0);
        // Count, prefix, fill.
        auto eachCell = [&](const ViewPoint& v, auto&& f) {
            int64_t lo[3], hi[3];
            for (int a = 0; a < 3; ++a) {
                lo[a] = cellIndex(v.positionMm[a] - r_);
                hi[a] = cellIndex(v.positionMm[a] + r_);
            }
            for (int64_t x = lo[0]; x <= hi[0]; ++x)
                for (int64_t y = lo[1]; y <= hi[1]; ++y)
                    for (int64_t z = lo[2]; z <= hi[2]; ++z) f(bucket(x, y, z));
        };
        for (const ViewPoint& v : vps) eachCell(v, [&](size_t b) { ++start_[b + 1]; });
        for (size_t b = 0; b < want; ++b) start_[b + 1] += start_[b];
        entries_.resize(start_[want]);
        std::vector<uint32_t> fill(start_.begin(), start_.end() - 1);
        for (size_t i = 0; i < vps.size(); ++i) {
            const ViewPoint& v = vps[i];
            const GridEntry e{
                static_cast<float>(v.positionMm.x), static_cast<float>(v.positionMm.y),
                static_cast<float>(v.positionMm.z), v.object, static_cast<uint32_t>(i)};
            eachCell(v, [&](size_t b) { entries_[fill[b]++] = e; });
        }
    }
    // The view points whose cells hash to p's bucket (a superset of those within r).
    std::pair<const GridEntry*, const GridEntry*> candidates(const Vec3& p) const {
        const size_t b = bucket(cellIndex(p.x), cellIndex(p.y), cellIndex(p.z));
        return {entries_.data() + start_[b], entries_.data() + start_[b + 1]};
    }

  private:
    int64_t cellIndex(double x) const { return static_cast<int64_t>(std::floor(x / cell_)); }
    size_t bucket(int64_t x, int64_t y, int64_t z) const {
        const uint64_t h =
            uint64_t(x) * 73856093u ^ uint64_t(y) * 19349663u ^ uint64_t(z) * 83492791u;
        return static_cast<size_t>((h ^ (h >> 29)) & mask_);
    }
    double r_ = 0.0, cell_ = 1.0;
    size_t mask_ = 0;
    std::vector<uint32_t> start_;
    std::vector<GridEntry> entries_;
};

// A judged gather: the verdict of the joined path for view points whose backward suffix is
// events[firstEvent, + eventCount), scattered toward them on the given side (back: reflect)
// into the given medium, at one photon hit.
struct Verdict {
    uint32_t firstEvent = 0, eventCount = 0;
    int medium = 0;
    bool back = false;
    uint64_t matched = 0;
};
constexpr size_t kVerdictCache = 16;
// A part photon's split at its point: directions for about this many splatted lobes that
// reach the detector (PartLight::Start::legsPerLobe).
constexpr double kLobesPerPartPhoton = 4.0;

struct PhotonBranch {
    Ray ray;
    double flux = 0.0;
    int medium = 0, startObject = -1, startPrimitive = -1;
    bool specular = false, scattered = false;  // the events it has seen
    int segments = 0;
    // The flux below which it plays Russian roulette after its first scatter: rouletteRelativeFlux
    // of its flux just after that scatter (scale-free: a photon that scattered off a 0.1 %
    // mount is followed as far as one that scattered off a 30 % one).
    double rouletteFlux = 0.0;
    int designed = 0;               // its step on the lens's designed path (DesignedPath)
    // Its key on the connection's chains (LensConnector::advance): the designed step, or a
    // ghost route's node.
    int route = 0;
    size_t state = 0;               // with criteria: its path state's offset in the photon's arena
    uint64_t alive = ~uint64_t{0};  // criteria its path may still match
    int scatterVertex = -1;  // with a scatter guide: its last scatter (BlockTracer::vertices_)
};

// A block's photons keep what they deposit as a log, image by image in order (image 0..5 the
// plain visible, caustic and secondary light, the gathered light within half the radius, the
// image-forming light and the photon halves' difference; kPlainImages + kCriterionImages k +
// slot criterion k's: slots 0..3 as the plain ones, 4 its halves' difference), added to the
// pass's images in block order (tracer/runtime/ordered_blocks.h): bitwise the same images for
// every thread count, memory with the gathers of a few blocks, not images per block.
constexpr uint32_t kPlainImages = 6, kCriterionImages = 5;
constexpr uint32_t kParityImage = 5, kCriterionParitySlot = 4;
struct Deposit {
    uint32_t image;
    int pixel;
    double value;
};
struct PhotonBlock {
    std::vector<Deposit> deposits;
    // Deposits summed per image and pixel instead of logged (the lobe splats: thousands per
    // photon), [image][pixel]; an image no splat reached stays empty.
    std::vector<std::vector<double>> dense;
    std::vector<double> learned;
    std::vector<double> emissionLearned;  // with an emission guide: [its bin]
    std::vector<double> scatterLearned;   // with a scatter guide: [its bin]
    uint64_t photons = 0, segments = 0, gathers = 0, pruned = 0;
    uint64_t ghostWork = 0;    // the segments and gathers of the ghost photons
    uint64_t visibleWork = 0;  // the segments of the visible photons
    double gatheredSum = 0.0, gatheredSquares = 0.0;  // PhotonImages'
    // With PhotonTile::perPhoton: each photon's gathered light, photons [first, first + size).
    uint64_t first = 0;
    std::vector<double> perPhoton;
};

// One photon as emitted: its random stream (shared by all its branches) and the thresholds of
// its branches.
struct Photon {
    CounterRng rng;
    size_t source = 0;
    bool deposits = false;  // its source's visible light is the photons' to deposit
    int wavelength = 0;
    double wavelengthNm = 0.0;
    double rouletteFlux = 0.0;  // after the first scatter, rouletteRelativeFlux of the photon
    // Until their first scatter photons split at every interface. The first ghostPhotons of a
    // source's quasi-random photons, and the visible photons, follow every branch (below the
    // cull, roulette at the rescue level) and deposit the visible light; the others' branches
    // play roulette below rouletteFlux, as after a scatter: their weak ghosts matter only
    // where they scatter. A visible photon drops its scattered children and gathers nothing.
    bool splitAll = false, visibleOnly = false;
    double visibleScale = 0.0;  // its visible deposits' factor
    double lowFlux = 0.0, keepFlux = 0.0;
    Ray emitted{};  // as the source emitted it (the lens connection's audit)
    int emissionCell = -1;  // with an emission guide: its cell there
    // Its source's flux per photon, before the emission guide's density: the weight windows'
    // average photon.
    double nominalFlux = 0.0;
};

// What a whole pass shares, built once: the view point grid, the rim corrections, the
// emission's Sobol scrambles, the detector's smoothing disk. Blocks of photons read it from
// any thread (the rim corrections are filled in as view points first need them).
class PhotonPass {
  public:
    PhotonPass(const TransportView& ts, const DetectorImage& detector, const BackwardResult& back,
               const RenderOptions& options, const PathJudge* judge, int k, double radiusMm,
               const Ranks& ranks, const LensConnector* connector,
               const EmissionGuide* emissionGuide, const ScatterGuide* scatterGuide,
               const PartLight* partPhotons, const PhotonTile& tile);

    // The photons (photonsPerPass per source), then the visible photons
    // (visiblePhotonsPerPass per source whose visible light the photons deposit), then the
    // photons from the lit parts (partPhotons).
    uint64_t total() const { return withVisible() + partPhotons_; }
    uint64_t withVisible() const { return gathering() + visiblePhotons_ * visibleSources_.size(); }
    uint64_t gathering() const { return perSource_ * ts_.sources.size(); }
    // The probe rays of the disks the pass's photons gathered into (each counted once, however
    // many threads raced to fit it): once the photons are traced, the same for every thread
    // and rank count. Across ranks, a collective call.
    uint64_t diskRays() const;
    void markReached(uint32_t i, bool otherSide) const {
        // Written once: a store at every gather would bounce the line between the threads.
        std::atomic<uint8_t>& r = reached_[2 * size_t{i} + (otherSide ? 1 : 0)];
        if (r.load(std::memory_order_relaxed) == 0) r.store(1, std::memory_order_relaxed);
    }
    PhotonBlock traceBlock(uint64_t first, uint64_t last) const;
    PhotonImages emptyImages() const;
    static void add(const PhotonBlock& b, PhotonImages& result);
    static Bytes pack(const PhotonBlock& b);
    static PhotonBlock unpack(const Bytes& bytes);

  private:
    friend class BlockTracer;
    // A view point's gathering disk for the light from one side (viewPointDisk), computed the
    // first time it gathers light from that side: its radius as a fraction of the pass's, and
    // 1 / its area share at that radius and at half of it, negative when the view point lies
    // in a gap on that side. The values depend on the view point alone (the spiral turned by
    // its index), so threads racing on them write the same bits.
    struct Disk {
        double radiusFactor = 1.0, inverseShare = 1.0, inverseHalfShare = 1.0;
        bool viewInGap = false;  // GatherDisk's
    };
    Disk disk(uint32_t i, bool otherSide) const;
    // Across ranks every rank's photons reach nearly every view point, and each rank would
    // find the same corrections again: they are computed once, blocks of view points split
    // over the ranks, and shared; the other side's only where light can come through (not on
    // opaque parts, whose transmission is 0).
    void shareCorrectionsAcrossRanks();
    // The pixels that share a deposit landing at `point`: those whose centres lie within rho
    // (its own pixel alone when none does); none when it misses the grid.
    void splatCells(const Vec3& point, std::vector<int>& cells) const;
    Photon emit(uint64_t i, EmittedRay& e) const;

    const TransportView& ts_;
    const DetectorImage& detector_;
    const BackwardResult& back_;
    const RenderOptions& options_;
    // The photon halves' images (PhotonImages::parity) are booked only when the balance by
    // error reads them: two more deposits a gather otherwise spent for nothing.
    bool halves_ = false;
    const PathJudge* judge_;
    const LensConnector* connector_;
    const EmissionGuide* emissionGuide_;
    const ScatterGuide* scatterGuide_;
    const PartLight* parts_;  // photon mode, with targets; or null
    const uint64_t partPhotons_, partSeed_;
    const DesignedPath designed_;
    const int k_;
    const double radiusMm_;
    const Ranks& ranks_;
    const PhotonTile tile_;
    const std::vector<ViewPoint>& vps_;
    const ViewPointGrid grid_;
    const double r2_, gapMm_;
    // Per view point and side (kDiskSlots floats): radius factor, 1 / half share, the probe
    // rays the disk cost, then 1 / share (0: not yet computed; written last with release, so
    // a reader that sees it sees the others).
    static constexpr size_t kDiskSlots = 5;
    mutable std::vector<std::atomic<float>> disks_;
    // Per view point and side: whether a photon of this rank gathered there (its disk's probe
    // rays count as the pass's work whichever rank fitted it).
    mutable std::vector<std::atomic<uint8_t>> reached_;
    const uint64_t perSource_, ghostPhotons_, visiblePhotons_;
    std::vector<size_t> visibleSources_;  // the sources whose visible light photons deposit
    // The visible deposits' factor of a ghost and of a visible photon: its emitted count over
    // the ghost and visible photons' together (each deposits 1 / their number of the light).
    double ghostScale_ = 0.0, visibleScale_ = 0.0;
    const uint64_t photonSeed_;
    // One scramble of the Sobol points per source and pass, for the photons and for the
    // visible photons (independent of each other).
    std::vector<SobolOwen> emission_, visibleEmission_;
    const int renderedObject_;
    double rho_ = 0.0;  // the detector's smoothing disk this pass (mm)
    // Criteria: photon prefixes stream through the judge; a gather or a deposit judges the
    // joined path (the photon's events, its scatter at the view point, the view point's
    // backward events; or the detector hit).
    const size_t criteria_;
    const bool prune_;
    const size_t stateBytes_;
    // [property]: its lobe is splatted onto the detector instead of gathered
    // (RenderOptions::splatLobesBelowDeg).
    std::vector<uint8_t> splatted_;
};

PhotonPass::PhotonPass(const TransportView& ts, const DetectorImage& detector,
                       const BackwardResult& back, const RenderOptions& options,
                       const PathJudge* judge, int k, double radiusMm, const Ranks& ranks,
                       const LensConnector* connector, const EmissionGuide* emissionGuide,
                       const ScatterGuide* scatterGuide, const PartLight* partPhotons,
                       const PhotonTile& tile)
    : ts_(ts),
      detector_(detector),
      back_(back),
      options_(options),
      halves_(options.balancePhotons && options.balancePhotonsByError),
      judge_(judge),
      connector_(connector && connector->any() ? connector : nullptr),
      emissionGuide_(emissionGuide),
      scatterGuide_(scatterGuide),
      parts_(partPhotons && partPhotons->any() && connector_ &&
                     partPhotons->mode() == PartMode::Photons
                 ? partPhotons
                 : nullptr),
      partPhotons_(parts_ ? options.partPhotons : 0),
      partSeed_(passSeed(options.seed, static_cast<uint64_t>(k), 7)),
      designed_(*ts.scene),
      k_(k),
      radiusMm_(radiusMm),
      ranks_(ranks),
      tile_(tile),
      vps_(back.viewPoints),
      grid_(back.viewPoints, radiusMm),
      r2_(radiusMm * radiusMm),
      gapMm_(kGapFraction * radiusMm),
      disks_(2 * kDiskSlots * back.viewPoints.size()),
      reached_(2 * back.viewPoints.size()),
      perSource_(options.photonsPerPass),
      ghostPhotons_(options.ghostPhotons()),
      visiblePhotons_(options.visiblePhotonsPerPass),
      photonSeed_(passSeed(options.seed, static_cast<uint64_t>(k), 1)),
      renderedObject_(detector.geometry().object),
      criteria_(judge ? static_cast<size_t>(judge->count()) : 0),
      prune_(judge && options.prune),
      stateBytes_(judge ? judge->stateBytes() : 0) {
    for (const bool b : splattedLobes(ts, options.splatLobesBelowDeg * std::numbers::pi / 180.0,
                                      options.followLobesBelowDeg * std::numbers::pi / 180.0))
        splatted_.push_back(b ? 1 : 0);
    for (auto& x : disks_) x.store(0.0f, std::memory_order_relaxed);
    for (auto& x : reached_) x.store(0, std::memory_order_relaxed);
    if (!ranks.single()) shareCorrectionsAcrossRanks();
    for (size_t s = 0; s < ts.sources.size(); ++s) {
        emission_.emplace_back(passSeed(options.seed, static_cast<uint64_t>(k), 3) ^
                               (0x9E3779B97F4A7C15ull * (s + 1)));
        visibleEmission_.emplace_back(passSeed(options.seed, static_cast<uint64_t>(k), 6) ^
                                      (0x9E3779B97F4A7C15ull * (s + 1)));
        if (photonsSeeSource(ts.sources[s]) && visiblePhotons_ > 0) visibleSources_.push_back(s);
    }
    const double depositing =
        static_cast<double>(ghostPhotons_ + (visibleSources_.empty() ? 0 : visiblePhotons_));
    ghostScale_ = static_cast<double>(perSource_) / depositing;
    visibleScale_ = static_cast<double>(visiblePhotons_) / depositing;
    // The detector's smoothing disk shrinks with the gathering radius.
    const DetectorGeometry& dg = detector.geometry();
    rho_ = options.detectorRadiusPixels * std::max(dg.pixelWidthMm(), dg.pixelHeightMm()) *
           (options.initialRadiusMm > 0.0 ? radiusMm / options.initialRadiusMm : 1.0);
}

PhotonPass::Disk PhotonPass::disk(uint32_t i, bool otherSide) const {
    std::atomic<float>* slot = &disks_[kDiskSlots * (2 * size_t{i} + (otherSide ? 1 : 0))];
    float c = slot[3].load(std::memory_order_acquire);
    if (c == 0.0f) {
        const double turn =
            2.0 * std::numbers::pi *
            CounterRng(passSeed(options_.seed, k_, 2), tile_.viewPointBase + i).uniform();
        const GatherDisk d =
            viewPointDisk(*ts_.scene, vps_[i], radiusMm_, options_.areaSamples, turn, otherSide);
        const double sign = d.inGap ? -1.0 : 1.0;
        slot[0].store(static_cast<float>(d.radiusMm / radiusMm_), std::memory_order_relaxed);
        slot[1].store(static_cast<float>(sign / d.halfShare), std::memory_order_relaxed);
        slot[2].store(static_cast<float>(d.rays), std::memory_order_relaxed);
        slot[4].store(d.viewInGap ? 1.0f : 0.0f, std::memory_order_relaxed);
        c = static_cast<float>(sign / d.share);
        slot[3].store(c, std::memory_order_release);
    }
    return {static_cast<double>(slot[0].load(std::memory_order_relaxed)), static_cast<double>(c),
            static_cast<double>(slot[1].load(std::memory_order_relaxed)),
            slot[4].load(std::memory_order_relaxed) != 0.0f};
}

uint64_t PhotonPass::diskRays() const {
    std::vector<uint8_t> reached(reached_.size());
    for (size_t d = 0; d < reached.size(); ++d)
        reached[d] = reached_[d].load(std::memory_order_relaxed);
    if (!ranks_.single()) {
        ByteWriter w;
        w.putVector(reached);
        for (const Bytes& b : ranks_.gatherAll(w.take())) {
            ByteReader in(b);
            const std::vector<uint8_t> theirs = in.getVector<uint8_t>();
            if (theirs.size() != reached.size())
                throw std::runtime_error("the reached view points of another rank are damaged");
            for (size_t d = 0; d < reached.size(); ++d) reached[d] |= theirs[d];
        }
    }
    uint64_t rays = 0;
    for (size_t d = 0; d < reached.size(); ++d)
        if (reached[d] != 0)
            rays +=
                static_cast<uint64_t>(disks_[kDiskSlots * d + 2].load(std::memory_order_relaxed));
    return rays;
}

void PhotonPass::shareCorrectionsAcrossRanks() {
    constexpr size_t kShareBlock = 1024;
    auto transmissive = [&](size_t i) {
        return !isOpaqueKind(ts_.scene->object(vps_[i].object).kind);
    };
    const size_t n = vps_.size(), blocks = (n + kShareBlock - 1) / kShareBlock;
    tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
        if (!ranks_.owns(b)) return;
        for (size_t i = b * kShareBlock; i < std::min(n, (b + 1) * kShareBlock); ++i) {
            disk(static_cast<uint32_t>(i), false);
            if (transmissive(i)) disk(static_cast<uint32_t>(i), true);
        }
    });
    ByteWriter w;
    for (size_t b = static_cast<size_t>(ranks_.rank()); b < blocks;
         b += static_cast<size_t>(ranks_.size()))
        for (size_t i = b * kShareBlock; i < std::min(n, (b + 1) * kShareBlock); ++i)
            for (size_t side = 0; side < (transmissive(i) ? 2u : 1u); ++side)
                for (size_t x = 0; x < kDiskSlots; ++x)
                    w.put(disks_[kDiskSlots * (2 * i + side) + x].load(std::memory_order_relaxed));
    const std::vector<Bytes> all = ranks_.gatherAll(w.take());
    for (int q = 0; q < ranks_.size(); ++q) {
        if (q == ranks_.rank()) continue;
        ByteReader in(all[static_cast<size_t>(q)]);
        for (size_t b = static_cast<size_t>(q); b < blocks;
             b += static_cast<size_t>(ranks_.size()))
            for (size_t i = b * kShareBlock; i < std::min(n, (b + 1) * kShareBlock); ++i)
                for (size_t side = 0; side < (transmissive(i) ? 2u : 1u); ++side)
                    for (size_t x = 0; x < kDiskSlots; ++x)
                        disks_[kDiskSlots * (2 * i + side) + x].store(in.get<float>(),
                                                                      std::memory_order_relaxed);
        if (!in.done())
            throw std::runtime_error("the view point shares of another rank are damaged");
    }
}

void PhotonPass::splatCells(const Vec3& point, std::vector<int>& cells) const {
    cells.clear();
    const DetectorImage& grid0 = detector_;
    const DetectorGeometry& dg = grid0.geometry();
    const auto own = grid0.pixelOf(point);
    if (!own) return;
    const double rho = rho_;
    if (rho > 0.0) {
        const Vec3 local = dg.frame.toLocalPoint(point);
        const double pw = dg.pixelWidthMm(), ph = dg.pixelHeightMm();
        const int c0 = std::max(0, int(std::floor((local.x - rho + 0.5 * dg.widthMm) / pw)));
        const int c1 =
            std::min(dg.pixelsX - 1, int(std::floor((local.x + rho + 0.5 * dg.widthMm) / pw)));
        const int r0 = std::max(0, int(std::floor((0.5 * dg.heightMm - local.y - rho) / ph)));
        const int r1 =
            std::min(dg.pixelsY - 1, int(std::floor((0.5 * dg.heightMm - local.y + rho) / ph)));
        for (int row = r0; row <= r1; ++row)
            for (int col = c0; col <= c1; ++col) {
                const int p = grid0.pixelIndex(col, row);
                const Vec2 c = grid0.pixelCentreLocal(p);
                const double dx = c.x - local.x, dy = c.y - local.y;
                if (dx * dx + dy * dy <= rho * rho) cells.push_back(p);
            }
    }
    if (cells.empty()) cells.push_back(*own);
}

Photon PhotonPass::emit(uint64_t i, EmittedRay& e) const {
    Photon ph{CounterRng(photonSeed_, i)};
    // Index j of its source's photons of its kind (the photons or the visible photons). The
    // ghost and the visible photons deposit the visible light, each 1 / (their number) of it.
    uint64_t j = 0, count = perSource_;
    if (i < gathering()) {
        ph.source = i / perSource_;
        j = i % perSource_;
        ph.splitAll = j < ghostPhotons_;
    } else {
        const uint64_t g = i - gathering();
        ph.source = visibleSources_[g / visiblePhotons_];
        j = g % visiblePhotons_;
        count = visiblePhotons_;
        ph.splitAll = ph.visibleOnly = true;
    }
    const Source& source = ts_.sources[ph.source];
    ph.deposits = ph.splitAll && photonsSeeSource(source);
    ph.visibleScale = ph.visibleOnly ? visibleScale_ : ghostScale_;
    // The emission's uniforms: Sobol dimensions 0 and 1 (the best pair) to the origin, 2 and 3
    // to the direction, 4 to the line; or the photon's own stream (as Source::emit(rng) draws
    // them).
    std::array<double, Source::kEmitUniforms> u;
    if (options_.quasiRandomPhotons) {
        const SobolOwen& q = ph.visibleOnly ? visibleEmission_[ph.source] : emission_[ph.source];
        u = {q.sample(j, 4), q.sample(j, 0), q.sample(j, 1), q.sample(j, 2), q.sample(j, 3)};
    } else {
        for (double& x : u) x = ph.rng.uniform();
    }
    double density = 1.0;
    if (emissionGuide_) {
        // The pair that places the photon (a point's direction, any other kind's origin),
        // warped by the guide but for the ghost and visible photons, which carry the visible
        // light.
        const size_t a = source.delta() == Source::Delta::Position ? 3 : 1;
        ApertureGuide::Warped w{u[a], u[a + 1], 1.0, ApertureGuide::cellOf(u[a], u[a + 1])};
        if (!ph.splitAll) w = emissionGuide_->warp(ph.source, u[a], u[a + 1]);
        u[a] = w.u;
        u[a + 1] = w.v;
        density = w.density;
        ph.emissionCell = w.cell;
    }
    e = source.emit(u, count);
    ph.nominalFlux = e.flux;
    e.flux /= density;
    ph.wavelength = e.wavelength;
    ph.wavelengthNm = e.wavelengthNm;
    ph.emitted = e.ray;
    ph.rouletteFlux = options_.rouletteRelativeFlux * e.flux;
    const double cullFlux = options_.photonMinRelativeFlux * e.flux;
    const bool cheap = !ph.splitAll && ph.rouletteFlux > 0.0;
    ph.lowFlux = cheap ? ph.rouletteFlux : cullFlux;
    ph.keepFlux = cheap ? ph.rouletteFlux : options_.photonRescueRelativeFlux * e.flux;
    return ph;
}

PhotonImages PhotonPass::emptyImages() const {
    PhotonImages result;
    const size_t pixels = static_cast<size_t>(detector_.pixelCount());
    result.visible.assign(pixels, 0.0);
    result.caustic.assign(pixels, 0.0);
    result.secondary.assign(pixels, 0.0);
    result.gatheredHalf.assign(pixels, 0.0);
    result.imageForming.assign(pixels, 0.0);
    result.parity.assign(pixels, 0.0);
    result.by.assign(criteria_, {result.visible, result.caustic, result.secondary,
                                 result.gatheredHalf, result.parity});
    result.learned.assign(back_.learned.size(), 0.0);
    if (emissionGuide_) result.emissionLearned.assign(emissionGuide_->bins(), 0.0);
    if (scatterGuide_) result.scatterLearned.assign(scatterGuide_->bins(), 0.0);
    return result;
}

void PhotonPass::add(const PhotonBlock& b, PhotonImages& result) {
    std::vector<double>* images[kPlainImages] = {&result.visible,      &result.caustic,
                                                 &result.secondary,    &result.gatheredHalf,
                                                 &result.imageForming, &result.parity};
    auto imageOf = [&](size_t i) -> std::vector<double>& {
        if (i < kPlainImages) return *images[i];
        const size_t j = i - kPlainImages;
        return result.by[j / kCriterionImages][j % kCriterionImages];
    };
    for (const Deposit& d : b.deposits) imageOf(d.image)[static_cast<size_t>(d.pixel)] += d.value;
    for (size_t i = 0; i < b.dense.size(); ++i) {
        if (b.dense[i].empty()) continue;
        std::vector<double>& image = imageOf(i);
        for (size_t p = 0; p < image.size(); ++p) image[p] += b.dense[i][p];
    }
    for (size_t p = 0; p < result.learned.size(); ++p) result.learned[p] += b.learned[p];
    for (size_t p = 0; p < result.emissionLearned.size(); ++p)
        result.emissionLearned[p] += b.emissionLearned[p];
    for (size_t p = 0; p < result.scatterLearned.size(); ++p)
        result.scatterLearned[p] += b.scatterLearned[p];
    result.photons += b.photons;
    result.segments += b.segments;
    result.gathers += b.gathers;
    result.pruned += b.pruned;
    result.ghostWork += b.ghostWork;
    result.visibleWork += b.visibleWork;
    result.gatheredSum += b.gatheredSum;
    result.gatheredSquares += b.gatheredSquares;
}

Bytes PhotonPass::pack(const PhotonBlock& b) {
    ByteWriter w;
    w.putVector(b.deposits);
    w.put(static_cast<uint64_t>(b.dense.size()));
    for (const auto& d : b.dense) w.putVector(d);
    w.putVector(b.learned);
    w.putVector(b.emissionLearned);
    w.putVector(b.scatterLearned);
    for (uint64_t n : {b.photons, b.segments, b.gathers, b.pruned, b.ghostWork, b.visibleWork})
        w.put(n);
    w.put(b.gatheredSum);
    w.put(b.gatheredSquares);
    w.put(b.first);
    w.putVector(b.perPhoton);
    return w.take();
}

PhotonBlock PhotonPass::unpack(const Bytes& bytes) {
    ByteReader r(bytes);
    PhotonBlock b;
    b.deposits = r.getVector<Deposit>();
    const uint64_t dense = r.get<uint64_t>();
    if (dense > 4096) throw std::runtime_error("a block of photons from another rank is damaged");
    b.dense.resize(dense);
    for (auto& d : b.dense) d = r.getVector<double>();
    b.learned = r.getVector<double>();
    b.emissionLearned = r.getVector<double>();
    b.scatterLearned = r.getVector<double>();
    for (uint64_t* n :
         {&b.photons, &b.segments, &b.gathers, &b.pruned, &b.ghostWork, &b.visibleWork})
        *n = r.get<uint64_t>();
    b.gatheredSum = r.get<double>();
    b.gatheredSquares = r.get<double>();
    b.first = r.get<uint64_t>();
    b.perPhoton = r.getVector<double>();
    if (!r.done()) throw std::runtime_error("a block of photons from another rank is damaged");
    return b;
}

// One block of photons, on one thread: each photon emitted, its branches followed through the
// scene, its light deposited on the detector and gathered at the view points.
class BlockTracer {
  public:
    explicit BlockTracer(const PhotonPass& pass)
        : p_(pass), scratch_(pass.stateBytes_) {
        block_.learned.assign(pass.back_.learned.size(), 0.0);
        if (pass.emissionGuide_) block_.emissionLearned.assign(pass.emissionGuide_->bins(), 0.0);
        if (pass.scatterGuide_) block_.scatterLearned.assign(pass.scatterGuide_->bins(), 0.0);
    }
    PhotonBlock run(uint64_t first, uint64_t last) {
        block_.first = first;
        if (p_.tile_.perPhoton) block_.perPhoton.assign(last - first, 0.0);
        for (uint64_t i = first; i < last; ++i) {
            gathered_ = 0.0;
            tracePhoton(i);
            if (p_.tile_.perPhoton) block_.perPhoton[i - first] = gathered_;
        }
        return std::move(block_);
    }

  private:
    void tracePhoton(uint64_t i);
    // Part photon j of the pass (PartLight::start): the light scattered at its point, followed
    // as a photon that has scattered once.
    void tracePartPhoton(uint64_t j);
    // Follows one branch until it ends, pushing the children it splits into.
    void follow(PhotonBranch br, Photon& ph);
    // Light that scattered nowhere lands on the rendered detector: the visible component of
    // the sources the photons stand for.
    void depositVisible(const PhotonBranch& br, const SceneHit& hit, const Photon& ph);
    // The share of the light scattered at `hit` the photon gathers: 1, or 0 where the lens
    // connection counts it (tracer/render/lens_connection.h), or kAuditRate where its audit
    // finds a path the connection misses.
    double gatherShare(const PhotonBranch& br, const SceneHit& hit, Photon& ph);
    // Instead of gathering at a narrow lobe (PhotonPass::splatted_): RenderOptions::lobeSplats
    // directions drawn from the lobe, each followed along specular events (one child by
    // weight) to the detector, where its light (scale of the photon's scattered flux) lands in
    // its pixel. A path that scatters again is left to the photon itself (its next gather).
    void splatLobe(const PhotonBranch& br, const SceneHit& hit, const Interaction& in, double scale,
                   Photon& ph);
    // The photon's scatter toward every view point within r of the hit.
    void gather(const PhotonBranch& br, const SceneHit& hit, const Interaction& in,
                double scatterScale, int wavelength);
    // Continue as child c with flux `flux`; false when it has no direction or no criterion can
    // match its path any more (prune).
    bool become(PhotonBranch& b, const SceneHit& hit, const Interaction& in, int c, double flux,
                Photon& ph);
    // become() past the weight window: as child c (a scatter in the scatter guide's `slot`, or
    // -1) with `flux`; `windowed`: the window changed the flux (its roulette starts anew).
    bool becomeOne(PhotonBranch& b, const SceneHit& hit, const Interaction& in, int c, int slot,
                   double flux, Photon& ph, bool windowed);
    // The children after a hit: every one before the first scatter (the ghosts live in the
    // weak reflected branches), then one by weight. False when the branch ends.
    bool next(PhotonBranch& br, const SceneHit& hit, const Interaction& in, double scatterScale,
              Photon& ph);
    // Adds `value` to image slot `slot` (0 visible, 1 caustic, 2 secondary, 3 gathered within
    // half the radius, 4 image-forming: plain only) of the plain
    // accumulator unless pruning drops it, and of every criterion matched; a spread value is
    // shared evenly by its cells.
    // dense: summed into the block's dense images (PhotonBlock::dense), not logged.
    void book(int slot, uint64_t matched, const std::vector<int>* spread, int pixel, double value,
              bool dense = false);
    // A copy of the path state at offset `from` in the photon's arena (a split branch's own):
    // its offset.
    size_t copyState(size_t from) {
        const size_t at = states_.size();
        states_.resize(at + p_.stateBytes_);
        std::memcpy(states_.data() + at, states_.data() + from, p_.stateBytes_);
        return at;
    }
    // With criteria: a photon's path state anew at its emission by `source` (the arena holds
    // it alone); the criteria it may still match.
    uint64_t startPath(size_t source) {
        states_.assign(p_.stateBytes_, std::byte{0});
        p_.judge_->reset(states_.data());
        return p_.judge_->push(states_.data(),
                               pathEvent(EventType::Emit, static_cast<int>(source), 0, 0, 0));
    }
    // Follows every branch on the stack to its end, then books the photon's gathered light.
    void drain(Photon& ph) {
        while (!stack_.empty()) {
            PhotonBranch b = stack_.back();
            stack_.pop_back();
            follow(b, ph);
        }
        block_.gatheredSum += gathered_;
        block_.gatheredSquares += gathered_ * gathered_;
    }
    // The criteria a path of this branch's events and `suffix_` matches.
    uint64_t judged(const PhotonBranch& br) {
        if (br.alive == 0) return uint64_t{0};
        return p_.judge_->matches(states_.data() + br.state, suffix_, scratch_.data());
    }

    const PhotonPass& p_;
    PhotonBlock block_;
    std::vector<PhotonBranch> stack_;
    std::vector<int> cells_;
    std::vector<std::byte> states_, scratch_;  // states: per branch
    std::vector<std::byte> splatState_;        // a lobe splat's path state
    std::vector<PathEvent> aimEvents_;         // an aimed splat's crossings
    // A splat's aim grid (splatLobe): whether each cell's centre led to the detector, and the
    // cells that did.
    std::array<uint8_t, kSplatAimCells> aimLit_{};
    std::array<int, kSplatAimCells> aimList_{};
    std::vector<PathEvent> suffix_;
    std::vector<Verdict> verdicts_;  // this hit's judged suffixes
    // The photon being traced: its source and emission guide cell (-1: no guide), and its
    // gathered light (plain caustic and secondary) so far.
    size_t source_ = 0;
    int emissionCell_ = -1;
    double gathered_ = 0.0;
    // +1 for the photons beyond the ghost photons of even index, -1 for the odd ones, 0 for
    // the ghost and the part photons and when no balance reads the halves
    // (PhotonImages::parity).
    double parity_ = 1.0;
    // With a scatter guide: the photon's scatters (its scatter guide bin, the scatter before
    // it on the same branch, -1 for none), and the last one of the branch gathering now.
    struct ScatterVertex {
        size_t bin;
        int slot;
        int parent;
    };
    std::vector<ScatterVertex> vertices_;
    int vertex_ = -1;
};

void BlockTracer::book(int slot, uint64_t matched, const std::vector<int>* spread, int pixel,
                       double value, bool dense) {
    auto into = [&](uint32_t image, double v) {
        if (dense) {
            if (block_.dense.size() <= image) block_.dense.resize(image + 1);
            std::vector<double>& d = block_.dense[image];
            if (d.empty()) d.assign(static_cast<size_t>(p_.detector_.pixelCount()), 0.0);
            d[static_cast<size_t>(pixel)] += v;
        } else if (spread) {
            const double share = v / static_cast<double>(spread->size());
            for (int px : *spread) block_.deposits.push_back({image, px, share});
        } else {
            block_.deposits.push_back({image, pixel, v});
        }
    };
    if (!spread && (slot == 1 || slot == 2)) {
        gathered_ += value;
        if (emissionCell_ >= 0)
            block_.emissionLearned[p_.emissionGuide_->bin(source_, pixel, emissionCell_)] += value;
        // Every scatter before this gather led to it.
        if (vertex_ >= 0) {
            const double weighted =
                p_.emissionGuide_ ? value * p_.emissionGuide_->regionWeight(pixel) : value;
            for (int v = vertex_; v >= 0; v = vertices_[static_cast<size_t>(v)].parent) {
                const ScatterVertex& x = vertices_[static_cast<size_t>(v)];
                block_.scatterLearned[x.bin] += weighted;
                block_.scatterLearned[p_.scatterGuide_->gatheredBin(x.slot)] += value;
            }
        }
    }
    // The gathered light again, signed by the photon's half (PhotonImages::parity).
    const bool halves = (slot == 1 || slot == 2) && parity_ != 0.0;
    const double signed_ = parity_ * value;
    if (!p_.prune_ || matched != 0) {
        into(static_cast<uint32_t>(slot), value);
        if (halves) into(kParityImage, signed_);
    }
    for (uint64_t m = matched; m != 0; m &= m - 1) {
        const uint32_t first =
            kPlainImages + kCriterionImages * static_cast<uint32_t>(std::countr_zero(m));
        if (slot < 4) into(first + static_cast<uint32_t>(slot), value);
        if (halves) into(first + kCriterionParitySlot, signed_);
    }
}

void BlockTracer::tracePartPhoton(uint64_t j) {
    const TransportView& ts = p_.ts_;
    if (p_.tile_.first) ++block_.photons;
    LensConnector::Work work;
    std::vector<PathEvent>& chain = suffix_;
    const auto st = p_.parts_->start(j, p_.partSeed_, work, p_.judge_ ? &chain : nullptr);
    block_.segments += work.rays;
    if (!st) return;
    Photon ph{CounterRng(p_.partSeed_ ^ 0x5ca77e7ULL, j)};
    parity_ = 0.0;  // a fixed count: not the balance's (PhotonImages::parity)
    ph.source = st->source;
    ph.wavelength = st->line;
    ph.wavelengthNm = st->wavelengthNm;
    const SceneHit at = PartLight::hitOf(*ts.scene, *st);
    const Interaction in =
        interact(ts, at, -st->toLight, st->line, st->wavelengthNm, TransportMode::Flux);
    const double scattered = scatteredShare(in);
    const double flux = st->flux / static_cast<double>(p_.partPhotons_) * scattered;
    if (!(flux > 0.0)) return;
    stack_.clear();
    PhotonBranch br;
    br.flux = flux;
    br.medium = at.mediumFrom;
    br.specular = true;
    br.designed = st->steps;
    br.route = st->steps;
    if (p_.judge_) {
        br.alive = startPath(st->source);
        for (const PathEvent& e : chain)
            if (br.alive != 0) br.alive = p_.judge_->push(states_.data(), e);
        if (p_.prune_ && br.alive == 0) {
            ++block_.pruned;
            return;
        }
    }
    source_ = ph.source;
    emissionCell_ = -1;
    gathered_ = 0.0;
    vertices_.clear();
    // Scattered children in proportion to their shares (the others are not the part photons'
    // light: the sources' photons keep them). The point's light costs the connection's solve,
    // so it goes a long way: as many directions as meet kLobesPerPartPhoton splatted lobes that
    // reach the detector on average (the pilot's measure), at most lobeSplats; each such lobe then
    // splits into lobeSplats splats. Measured on figure 10b (60 s): 1 lobe a photon 46.7 % mean
    // pixel error, 4 lobes 40.4 % (docs/render.md, "Photons from the lit parts").
    const int n =
        p_.parts_->productive(st->object, st->primitive)
            ? static_cast<int>(std::clamp(std::round(st->legsPerLobe * kLobesPerPartPhoton), 1.0,
                                          static_cast<double>(p_.options_.lobeSplats)))
            : 1;
    const double each = flux / n;
    ph.rouletteFlux = p_.options_.rouletteRelativeFlux * each;
    ph.lowFlux = ph.keepFlux = ph.rouletteFlux;
    for (int i = 0; i < n; ++i) {
        const int c = chooseScatterChild(in, ph.rng.uniform());
        PhotonBranch child = br;
        if (p_.judge_) child.state = copyState(br.state);  // the chain's state stays at br.state
        if (becomeOne(child, at, in, c, -1, each, ph, false)) stack_.push_back(child);
    }
    drain(ph);
}

void BlockTracer::tracePhoton(uint64_t i) {
    if (i >= p_.withVisible()) return tracePartPhoton(i - p_.withVisible());
    // The visible photons only deposit on the detector: the first tile's.
    if (i >= p_.gathering() && !p_.tile_.first) return;
    EmittedRay e;
    Photon ph = p_.emit(i, e);
    // The ghost photons' count is fixed: only the others' halves (PhotonImages::parity).
    parity_ = !p_.halves_ || ph.splitAll ? 0.0 : (i & 1) != 0 ? -1.0 : 1.0;
    if (p_.tile_.first) ++block_.photons;
    if (!(e.flux > 0.0)) return;
    stack_.clear();
    PhotonBranch first{e.ray, e.flux, 0, -1, -1, false, false, 0, ph.rouletteFlux};
    if (p_.judge_) {
        first.alive = startPath(ph.source);
        if (p_.prune_ && first.alive == 0) {
            ++block_.pruned;
            return;
        }
    }
    stack_.push_back(first);
    source_ = ph.source;
    emissionCell_ = ph.emissionCell;
    gathered_ = 0.0;
    vertices_.clear();
    drain(ph);
    if (p_.scatterGuide_) {
        block_.scatterLearned[p_.scatterGuide_->totalGatheredBin()] += gathered_;
        if (p_.tile_.first) block_.scatterLearned[p_.scatterGuide_->emittedBin()] += e.flux;
    }
}

void BlockTracer::follow(PhotonBranch br, Photon& ph) {
    const TransportView& ts = p_.ts_;
    const int w = ph.wavelength;
    for (; br.segments < p_.options_.maxPhotonSegments; ++br.segments) {
        const auto hit = ts.scene->closestHit(br.ray, kInfinity, br.startObject,
                                              br.startPrimitive, br.medium);
        ++block_.segments;
        if (ph.visibleOnly) {
            ++block_.visibleWork;
        } else if (ph.splitAll) {
            ++block_.ghostWork;
        }
        if (!hit) break;
        const double alpha = ts.media->absorptionPerMm(br.medium, w);
        if (alpha > 0.0) br.flux *= std::exp(-alpha * hit->t);
        if (ts.detectorOfObject[hit->object] >= 0) {
            if (ph.deposits && ph.splitAll && !br.scattered && hit->object == p_.renderedObject_ &&
                p_.tile_.first)
                depositVisible(br, *hit, ph);
            break;
        }
        const Interaction in =
            interact(ts, *hit, br.ray.direction, w, ph.wavelengthNm, TransportMode::Flux);
        bool scatters = false;
        for (int c = 0; c < in.count; ++c) scatters |= in.children[c].scatter;
        // A visible photon's light is the visible light: it drops its scattered children and
        // gathers nothing (gathering, a ghost photon costs about 3.5x as much on the Sun
        // example).
        if (ph.visibleOnly) {
            if (in.count == 0 || !next(br, *hit, in, 0.0, ph)) break;
            continue;
        }
        // Until its first scatter a branch is followed whatever its flux (its ghosts are the
        // visible light, smooth only when every branch of every photon lands); where it first
        // meets a scattering surface, the light it scatters plays Russian roulette: below
        // rouletteFlux it is kept with probability flux / rouletteFlux, at rouletteFlux. The
        // gathering, which costs as much for a weak ghost as for the photon itself, and the
        // scattered child take that flux; its specular children keep theirs. From then on the
        // scattered light is a photon of its own: it plays roulette below
        // rouletteRelativeFlux of its flux just after this scatter (PhotonBranch::rouletteFlux),
        // however dark the surface.
        double scatterScale = 1.0;
        if (scatters && !br.scattered) {
            const double kept = playRoulette(br.flux, ph.rouletteFlux, ph.rouletteFlux, ph.rng);
            scatterScale = kept > 0.0 ? kept / br.flux : 0.0;
        }
        // The light the part photons carry (PartMode::Photons): scattered at a target's
        // object by its chain where the connection tries, it is theirs but for the audit.
        double childScale = scatterScale;
        if (scatters && (br.specular || br.scattered) && scatterScale > 0.0) {
            const double share = gatherShare(br, *hit, ph);
            if (p_.parts_ && !br.scattered && p_.parts_->carries(ph.source, hit->object, br.route))
                childScale *= share;
            const uint64_t before = block_.gathers;
            if (share > 0.0) {
                const size_t prop = static_cast<size_t>(ts.propertyOfObject[hit->object]);
                if (prop < p_.splatted_.size() && p_.splatted_[prop] != 0) {
                    // On a stream of its own: a later tile skips the splats (they land on the
                    // detector, not at view points) and the photon goes on the same.
                    Photon splat = ph;
                    splat.rng = ph.rng.fork();
                    if (p_.tile_.first) splatLobe(br, *hit, in, scatterScale * share, splat);
                } else {
                    gather(br, *hit, in, scatterScale * share, w);
                }
            }
            if (ph.splitAll) block_.ghostWork += block_.gathers - before;
        }
        if (in.count == 0) break;
        if (!next(br, *hit, in, childScale, ph)) break;
    }
}

double BlockTracer::gatherShare(const PhotonBranch& br, const SceneHit& hit, Photon& ph) {
    const LensConnector* lc = p_.connector_;
    if (!lc || br.scattered || !lc->hasChain(ph.source, hit.object, br.route)) return 1.0;
    // The connection tries this point for this photon's fixed half: its light is the
    // connection's, but for the audit.
    LensConnector::Work work;
    const bool tried =
        lc->inView(ph.source, br.route, lc->fixedOf(ph.source, hit.object, br.route, ph.emitted),
                   hit.point, hit.object, work);
    block_.segments += work.rays;
    if (!tried) return 1.0;
    if (!(ph.rng.uniform() * LensConnector::kAuditRate < 1.0)) return 0.0;
    work = {};
    const bool found = lc->finds(ph.source, ph.wavelength, ph.wavelengthNm, br.route, hit.point,
                                 hit.object, ph.emitted, work);
    block_.segments += work.rays;
    return found ? 0.0 : static_cast<double>(LensConnector::kAuditRate);
}

void BlockTracer::depositVisible(const PhotonBranch& br, const SceneHit& hit, const Photon& ph) {
    p_.splatCells(hit.point, cells_);
    if (cells_.empty()) return;
    uint64_t matched = 0;
    if (p_.judge_) {
        suffix_.assign(1, pathEvent(EventType::DetectorHit, hit.object, hit.primitive, br.medium,
                                    br.medium));
        matched = judged(br);
    }
    book(0, matched, &cells_, 0, br.flux * ph.visibleScale);
    if (p_.designed_.completeForward(br.designed))
        book(4, matched, &cells_, 0, br.flux * ph.visibleScale);
}

void BlockTracer::splatLobe(const PhotonBranch& br, const SceneHit& hit, const Interaction& in,
                            double scale, Photon& ph) {
    const TransportView& ts = p_.ts_;
    const double scattered = scatteredShare(in);
    if (!(scattered > 0.0)) return;
    // lobeSplats directions where the part photons' pilot saw light reach the detector from
    // this place (PartLight::productive), one elsewhere: most narrow lobes in a barrel send
    // their light away from the sensor. Of those, aimedSplats aim at the face the pilot's
    // splats went on through as designed (PartLight::aimStep).
    const bool productive = p_.parts_ && p_.parts_->productive(hit.object, hit.primitive);
    int aim = -1;
    if (p_.parts_ && p_.options_.aimedSplats > 0.0) {
        aim = p_.parts_->aimStep(hit.object, hit.primitive);
        if (aim < 0) aim = p_.parts_->aimStepOfObject(hit.object);
    }
    const double arriving = br.flux * scale;
    if (!(arriving > 0.0)) return;
    const int slot = br.scattered ? 2 : 1;
    vertex_ = br.scatterVertex;
    const PartShape* face = aim >= 0 ? &p_.parts_->aimFace(aim) : nullptr;
    const int aimObject = aim < 0                      ? -1
                          : aim < p_.designed_.steps() ? p_.designed_.objectOfStep(aim)
                                                       : p_.renderedObject_;
    // Where on the face to aim: a kSplatAimGrid^2 grid over its map, each cell's centre traced
    // once from here as designed; the aimed points are drawn uniformly in the cells next to
    // (or at) a centre whose light reached the detector (the rest of the face is the lobe's
    // alone). A place of an object that aims, which the pilot did not see (its places are a
    // sample), counts as productive where some centre's light does.
    int litCells = 0;
    if (aim >= 0) {
        std::array<uint8_t, kSplatAimCells> reached{};
        bool any = false;
        for (int cell = 0; cell < kSplatAimCells; ++cell) {
            const auto y = face->at((cell % kSplatAimGrid + 0.5) / kSplatAimGrid,
                                    (cell / kSplatAimGrid + 0.5) / kSplatAimGrid);
            if (!y) continue;
            const Vec3 dir = glm::normalize(y->point - hit.point);
            const int c = scatterChildToward(in, dir);
            if (c < 0 || !(in.property->bsdf(in.context, dir) > 0.0)) continue;
            LensConnector::Work work;
            const auto on = p_.connector_->onward({hit.point, dir}, hit.object, hit.primitive,
                                                  in.children[c].medium, aim, ph.wavelength,
                                                  ph.wavelengthNm, p_.renderedObject_, work);
            block_.segments += work.rays;
            if (on && p_.detector_.pixelOf(on->detectorHit.point)) {
                reached[static_cast<size_t>(cell)] = 1;
                any = true;
            }
        }
        for (int cell = 0; any && cell < kSplatAimCells; ++cell) {
            const int i = cell % kSplatAimGrid, j = cell / kSplatAimGrid;
            bool near = false;
            for (int dj = -1; dj <= 1 && !near; ++dj)
                for (int di = -1; di <= 1 && !near; ++di) {
                    const int ii = i + di, jj = j + dj;
                    near = ii >= 0 && jj >= 0 && ii < kSplatAimGrid && jj < kSplatAimGrid &&
                           reached[static_cast<size_t>(jj * kSplatAimGrid + ii)] != 0;
                }
            aimLit_[static_cast<size_t>(cell)] = near ? 1 : 0;
            if (near) aimList_[static_cast<size_t>(litCells++)] = cell;
        }
    }
    const int n = productive || litCells > 0 ? p_.options_.lobeSplats : 1;
    // At least one direction from the lobe: the aim covers only its cells.
    const int nAim =
        litCells > 0 ? std::min(n - 1, static_cast<int>(std::lround(n * p_.options_.aimedSplats)))
                     : 0;
    const double roulette = p_.options_.rouletteRelativeFlux * arriving * scattered / n;
    const int nLobe = n - nAim;
    // The aim's density per mm^2 of a point y on the face.
    auto aimDensity = [&](const Vec3& y, int primitive) {
        const auto uv = face->uvOf(y);
        if (!uv) return 0.0;
        const int i = std::min(kSplatAimGrid - 1, static_cast<int>(uv->x * kSplatAimGrid));
        const int j = std::min(kSplatAimGrid - 1, static_cast<int>(uv->y * kSplatAimGrid));
        if (!aimLit_[static_cast<size_t>(j * kSplatAimGrid + i)]) return 0.0;
        return static_cast<double>(kSplatAimCells) / litCells * face->densityAt(y, primitive);
    };
    // The lobe's density of a direction (a scattered child in proportion to its share, then
    // its channel's pdf), and the aim's (a point on the face by area, per steradian at the
    // place): the balance heuristic over the two, nLobe and nAim samples.
    auto lobePdf = [&](const Vec3& dir) {
        const int c = scatterChildToward(in, dir);
        return c < 0 ? 0.0
                     : in.children[c].share / scattered * in.property->scatterPdf(in.context, dir);
    };
    auto judgeStart = [&](int c) {
        uint64_t alive = br.alive;
        if (!p_.judge_) return alive;
        splatState_.assign(states_.begin() + static_cast<std::ptrdiff_t>(br.state),
                           states_.begin() + static_cast<std::ptrdiff_t>(br.state) +
                               static_cast<std::ptrdiff_t>(p_.stateBytes_));
        if (alive != 0)
            alive = p_.judge_->push(splatState_.data(),
                                    pathEvent(in.children[c].event, hit.object, hit.primitive,
                                              br.medium, in.children[c].medium));
        return alive;
    };
    auto land = [&](const SceneHit& h, int medium, uint64_t alive, double flux) {
        const auto pixel = p_.detector_.pixelOf(h.point);
        if (!pixel) return;
        uint64_t matched = 0;
        if (p_.judge_ && alive != 0) {
            suffix_.assign(
                1, pathEvent(EventType::DetectorHit, h.object, h.primitive, medium, medium));
            matched = p_.judge_->matches(splatState_.data(), suffix_, scratch_.data());
        }
        book(slot, matched, nullptr, *pixel, flux, true);
        book(3, matched, nullptr, *pixel, flux, true);
    };
    const double lobeStart = nLobe > 0 ? arriving * scattered / nLobe : 0.0;
    for (int j = 0; j < nLobe; ++j) {
        // A scattered child in proportion to its share, a direction from its lobe.
        const int c = chooseScatterChild(in, ph.rng.uniform());
        const auto dir = in.direction(c, ph.rng);
        if (!dir) continue;
        uint64_t alive = judgeStart(c);
        if (p_.judge_ && p_.prune_ && alive == 0) continue;
        Ray ray{hit.point, *dir};
        double flux = lobeStart;
        // The path's designed step from the aimed face on (kOff once it leaves it), and the
        // aim's density of this direction, where its first hit is on that face.
        int at = aim >= 0 && nAim > 0 ? aim : DesignedPath::kOff;
        double aimPdf = 0.0;
        int medium = in.children[c].medium, from = hit.object, fromPrimitive = hit.primitive;
        for (int segment = 0; segment < p_.options_.maxPhotonSegments; ++segment) {
            const auto h = ts.scene->closestHit(ray, kInfinity, from, fromPrimitive, medium);
            ++block_.segments;
            if (!h) break;
            if (segment == 0 && at != DesignedPath::kOff) {
                const double cosY = std::abs(glm::dot(ray.direction, h->normal));
                if (h->object == aimObject && cosY > 0.0)
                    aimPdf = aimDensity(h->point, h->primitive) * h->t * h->t / cosY;
                if (!(aimPdf > 0.0)) at = DesignedPath::kOff;
            }
            const double alpha = ts.media->absorptionPerMm(medium, ph.wavelength);
            if (alpha > 0.0) flux *= std::exp(-alpha * h->t);
            if (ts.detectorOfObject[h->object] >= 0) {
                if (h->object != p_.renderedObject_) break;
                double w = 1.0;
                if (p_.designed_.completeForward(at)) {
                    const double pl = nLobe * lobePdf(*dir);
                    w = pl / (pl + nAim * aimPdf);
                }
                land(*h, medium, alive, flux * w);
                break;
            }
            const Interaction next = interact(ts, *h, ray.direction, ph.wavelength, ph.wavelengthNm,
                                              TransportMode::Flux);
            if (next.count == 0) break;
            const int k = next.count > 1 ? chooseChild(next, ph.rng.uniform()) : 0;
            if (next.children[k].scatter) break;  // the photon's own later gathers count it
            at = p_.designed_.forward(at, h->object, next.children[k].event);
            flux *= next.total;
            flux = playRoulette(flux, roulette, roulette, ph.rng);
            if (!(flux > 0.0)) break;
            const auto d = next.direction(k, ph.rng);
            if (!d) break;
            if (p_.judge_ && alive != 0) {
                alive = p_.judge_->push(splatState_.data(),
                                        pathEvent(next.children[k].event, h->object, h->primitive,
                                                  medium, next.children[k].medium));
                if (p_.prune_ && alive == 0) break;
            }
            ray = {h->point, *d};
            medium = next.children[k].medium;
            from = h->object;
            fromPrimitive = h->primitive;
        }
    }
    // The aimed directions: a point on the face by area, the designed path on from it
    // (LensConnector::onward), counted where that path's first crossing is the drawn point.
    for (int j = 0; j < nAim; ++j) {
        const int cell = aimList_[static_cast<size_t>(
            std::min(litCells - 1, static_cast<int>(ph.rng.uniform() * litCells)))];
        const double u = (cell % kSplatAimGrid + ph.rng.uniform()) / kSplatAimGrid;
        const double v = (cell / kSplatAimGrid + ph.rng.uniform()) / kSplatAimGrid;
        const auto y = face->at(u, v);
        if (!y) continue;
        Vec3 dir = y->point - hit.point;
        const double d2 = glm::dot(dir, dir);
        if (!(d2 > 0.0)) continue;
        const double d = std::sqrt(d2);
        dir /= d;
        const double cosY = std::abs(glm::dot(dir, y->normal));
        const double cosX = std::abs(glm::dot(dir, in.context.normal));
        if (!(cosY > 0.0) || !(cosX > 0.0)) continue;
        const double f = in.property->bsdf(in.context, dir);
        if (!(f > 0.0)) continue;
        const int c = scatterChildToward(in, dir);
        if (c < 0) continue;
        uint64_t alive = judgeStart(c);
        if (p_.judge_ && p_.prune_ && alive == 0) continue;
        LensConnector::Work work;
        const auto on = p_.connector_->onward(
            {hit.point, dir}, hit.object, hit.primitive, in.children[c].medium, aim, ph.wavelength,
            ph.wavelengthNm, p_.renderedObject_, work, p_.judge_ ? &aimEvents_ : nullptr);
        block_.segments += work.rays;
        if (!on) continue;
        if (!on->firstMeets(y->point, d)) continue;
        const double pa =
            nAim * static_cast<double>(kSplatAimCells) / litCells * y->density * d2 / cosY;
        const double flux = arriving * f * cosX / (nLobe * lobePdf(dir) + pa) * on->transmit;
        if (!(flux > 0.0) || !std::isfinite(flux)) continue;
        if (p_.judge_ && alive != 0)
            for (size_t e = 0; e + 1 < aimEvents_.size() && alive != 0; ++e)
                alive = p_.judge_->push(splatState_.data(), aimEvents_[e]);
        if (p_.judge_ && p_.prune_ && alive == 0) continue;
        land(on->detectorHit, on->medium, alive, flux);
    }
}

void BlockTracer::gather(const PhotonBranch& br, const SceneHit& hit, const Interaction& in,
                         double scatterScale, int wavelength) {
    const auto [firstVp, lastVp] = p_.grid_.candidates(hit.point);
    verdicts_.clear();
    vertex_ = br.scatterVertex;
    // The photon's side of the face, and whether it lies in a gap there (looked at once, when
    // a view point first needs it).
    const double photonCos = glm::dot(br.ray.direction, hit.normal);
    int photonInGap = -1, photonViewInGap = -1;
    // The float pre-test keeps every view point within r: its radius is widened by the
    // rounding of the float coordinates.
    const float px = static_cast<float>(hit.point.x), py = static_cast<float>(hit.point.y),
                pz = static_cast<float>(hit.point.z);
    const double wide =
        p_.radiusMm_ * (1.0 + 1e-6) +
        1e-6 * (std::abs(hit.point.x) + std::abs(hit.point.y) + std::abs(hit.point.z));
    const float wide2 = static_cast<float>(wide * wide);
    const std::vector<PathEvent>& vpEvents = p_.back_.events;
    for (const GridEntry* it = firstVp; it != lastVp; ++it) {
        if (it->object != hit.object) continue;
        const float dx = it->x - px, dy = it->y - py, dz = it->z - pz;
        if (dx * dx + dy * dy + dz * dz > wide2) continue;
        const ViewPoint& v = p_.vps_[it->index];
        if (v.wavelength != wavelength) continue;
        if (!(glm::dot(v.normal, hit.normal) > kGatherNormalCos)) continue;
        const Vec3 d = v.positionMm - hit.point;
        const double d2 = glm::dot(d, d);
        if (d2 > p_.r2_) continue;
        const double f = in.property->bsdf(in.context, v.toDetector);
        if (!(f > 0.0)) continue;
        // The photon's scatter here toward the view point's pixel: a reflection when it
        // arrives on the view point's side. It counts where both lie in a gap on its side or
        // neither, within the view point's own radius.
        const bool back = photonCos * glm::dot(v.toDetector, hit.normal) < 0.0;
        const PhotonPass::Disk disk = p_.disk(it->index, !back);
        p_.markReached(it->index, !back);
        const double correction = disk.inverseShare;
        const double rv2 = p_.r2_ * disk.radiusFactor * disk.radiusFactor;
        if (d2 > rv2) continue;
        if (photonInGap < 0) {
            const Vec3 side = photonCos < 0.0 ? hit.normal : -hit.normal;
            photonInGap =
                inGapAt(*p_.ts_.scene, hit.point, hit.object, hit.primitive, side, p_.gapMm_) ? 1
                                                                                                : 0;
        }
        if ((correction < 0.0) != (photonInGap == 1)) continue;
        // Transmitted light leaves on the view point's side: the photon's point there in the
        // view point's kind of place too.
        if (!back) {
            if (photonViewInGap < 0) {
                const Vec3 side = photonCos < 0.0 ? -hit.normal : hit.normal;
                photonViewInGap =
                    inGapAt(*p_.ts_.scene, hit.point, hit.object, hit.primitive, side, p_.gapMm_)
                        ? 1
                        : 0;
            }
            if (disk.viewInGap != (photonViewInGap == 1)) continue;
        }
        ++block_.gathers;
        uint64_t matched = 0;
        if (p_.judge_ && br.alive != 0) {
            // View points with the same suffix (stored once by the backward pass) get the same
            // verdict at this hit.
            const auto known =
                std::find_if(verdicts_.begin(), verdicts_.end(), [&](const Verdict& x) {
                    return x.firstEvent == v.firstEvent && x.eventCount == v.eventCount &&
                           x.back == back && x.medium == v.medium;
                });
            if (known != verdicts_.end()) {
                matched = known->matched;
            } else {
                suffix_.assign(1, pathEvent(back ? EventType::ScatterReflect
                                                 : EventType::ScatterTransmit,
                                            hit.object, hit.primitive, br.medium, v.medium));
                suffix_.insert(suffix_.end(), vpEvents.begin() + v.firstEvent,
                               vpEvents.begin() + v.firstEvent + v.eventCount);
                matched = judged(br);
                if (verdicts_.size() < kVerdictCache)
                    verdicts_.push_back({v.firstEvent, v.eventCount, v.medium, back, matched});
            }
        }
        const double kernel = 1.0 / (std::numbers::pi * rv2);
        // Caustic light has scattered once, here; a photon that scattered before, or a view
        // point behind a followed lobe, makes it secondary.
        const int slot = br.scattered || v.behindScatter ? 2 : 1;
        const double value = v.weight * br.flux * scatterScale * f * kernel * std::abs(correction);
        book(slot, matched, nullptr, v.pixel, value);
        // The same light gathered within half the radius: the estimate that bounds the
        // radius bias (RenderState::radiusBias).
        if (4.0 * d2 <= rv2)
            book(3, matched, nullptr, v.pixel,
                 v.weight * br.flux * scatterScale * f * 4.0 * kernel *
                     std::abs(disk.inverseHalfShare));
        if (!block_.learned.empty()) block_.learned[v.guideBin] += value;
    }
}

bool BlockTracer::become(PhotonBranch& b, const SceneHit& hit, const Interaction& in, int c,
                         double flux, Photon& ph) {
    const InteractionChild& child = in.children[c];
    const int slot = child.scatter && p_.scatterGuide_ ? p_.scatterGuide_->slot(hit.point) : -1;
    if (slot < 0 || ph.splitAll || p_.options_.weightWindow == 0.0)
        return becomeOne(b, hit, in, c, slot, flux, ph, false);
    // The weight window: split or roulette by what the photon expects to bring from here. The
    // light it scatters is then a photon of its own (its roulette relative to its new flux).
    const ScatterGuide::Window w =
        p_.scatterGuide_->window(slot, flux / ph.nominalFlux, ph.rng.uniform());
    if (w.photons == 0) return false;
    const bool windowed = w.factor != 1.0;
    flux *= w.factor;
    for (int j = 1; j < w.photons; ++j) {
        PhotonBranch copy = b;
        if (p_.judge_) copy.state = copyState(b.state);
        if (becomeOne(copy, hit, in, c, slot, flux, ph, true)) stack_.push_back(copy);
    }
    return becomeOne(b, hit, in, c, slot, flux, ph, windowed);
}

bool BlockTracer::becomeOne(PhotonBranch& b, const SceneHit& hit, const Interaction& in, int c,
                            int slot, double flux, Photon& ph, bool windowed) {
    const InteractionChild& child = in.children[c];
    // The ghost photons scatter as the surface does: they carry the visible light, and the
    // guide learns from them too.
    const auto dir = slot >= 0 && !ph.splitAll ? p_.scatterGuide_->draw(in, c, slot, ph.rng, flux)
                                               : in.direction(c, ph.rng);
    if (!dir) return false;
    if (p_.judge_ && b.alive != 0) {
        b.alive = p_.judge_->push(
            states_.data() + b.state,
            pathEvent(child.event, hit.object, hit.primitive, b.medium, child.medium));
    }
    if (p_.prune_ && b.alive == 0) {
        ++block_.pruned;
        return false;
    }
    if (child.scatter && (!b.scattered || windowed))
        b.rouletteFlux = p_.options_.rouletteRelativeFlux * flux;
    b.designed = p_.designed_.forward(b.designed, hit.object, child.event);
    b.route = p_.connector_ ? p_.connector_->advance(b.route, hit.object, child.event) : b.designed;
    (child.scatter ? b.scattered : b.specular) = true;
    b.flux = flux;
    b.ray = {hit.point, *dir};
    b.medium = child.medium;
    b.startObject = hit.object;
    b.startPrimitive = hit.primitive;
    if (slot >= 0) {
        vertices_.push_back(
            {p_.scatterGuide_->bin(slot, ScatterGuide::cellOf(*dir)), slot, b.scatterVertex});
        b.scatterVertex = static_cast<int>(vertices_.size()) - 1;
        block_.scatterLearned[p_.scatterGuide_->scatteredBin(slot)] += flux;
        block_.scatterLearned[p_.scatterGuide_->scattersBin(slot)] += 1.0;
    }
    return true;
}

bool BlockTracer::next(PhotonBranch& br, const SceneHit& hit, const Interaction& in,
                       double scatterScale, Photon& ph) {
    int c = 0;
    double flux = 0.0;
    if (!br.scattered && in.count > 1) {
        for (int k = in.count - 1; k >= 1; --k) {
            const double f = br.flux * in.children[k].share *
                             (in.children[k].scatter ? scatterScale : 1.0);
            if (!(f > 0.0)) continue;
            // A scattered child's flux played its roulette already (the incident flux,
            // scatterScale): it starts a photon of its own.
            const double keep = in.children[k].scatter
                                    ? f
                                    : playRoulette(f, ph.lowFlux, ph.keepFlux, ph.rng);
            if (!(keep > 0.0)) continue;
            PhotonBranch child = br;
            child.segments = br.segments + 1;
            if (p_.judge_) child.state = copyState(br.state);
            if (become(child, hit, in, k, keep, ph)) stack_.push_back(child);
        }
        c = 0;
        flux = br.flux * in.children[0].share * (in.children[0].scatter ? scatterScale : 1.0);
        if (!(flux > 0.0)) return false;
        if (!in.children[0].scatter) flux = playRoulette(flux, ph.lowFlux, ph.keepFlux, ph.rng);
        if (!(flux > 0.0)) return false;
    } else {
        c = in.count > 1 ? chooseChild(in, ph.rng.uniform()) : 0;
        flux = br.flux * in.total * (in.children[c].scatter ? scatterScale : 1.0);
        if (!(flux > 0.0)) return false;
    }
    if (!become(br, hit, in, c, flux, ph)) return false;
    if (br.scattered) {
        br.flux = playRoulette(br.flux, br.rouletteFlux, br.rouletteFlux, ph.rng);
        if (!(br.flux > 0.0)) return false;
    }
    return true;
}

PhotonBlock PhotonPass::traceBlock(uint64_t first, uint64_t last) const {
    return BlockTracer(*this).run(first, last);
}

}  // namespace

EmissionGuide::EmissionGuide(size_t sources, int pixelsX, int pixelsY)
    : sources_(sources),
      pixelsX_(pixelsX),
      pixelsY_(pixelsY),
      guide_(static_cast<int>(std::max<size_t>(sources, 1)) * ApertureGuide::kBlockPixels, 1) {
    if (pixelsX < 1 || pixelsY < 1)
        throw std::invalid_argument("EmissionGuide: the detector has no pixels");
}

int EmissionGuide::region(int pixel) const {
    const int x = pixel % pixelsX_, y = pixel / pixelsX_;
    return (y * kRegions / pixelsY_) * kRegions + x * kRegions / pixelsX_;
}

size_t EmissionGuide::bin(size_t source, int pixel, int cell) const {
    return (source * kRegionCount + static_cast<size_t>(region(pixel))) *
               ApertureGuide::kCellCount +
           static_cast<size_t>(cell);
}

void EmissionGuide::prepare(const std::vector<double>& learned, double g) {
    if (learned.size() != bins())
        throw std::invalid_argument("EmissionGuide: " + std::to_string(learned.size()) +
                                    " learned values for " + std::to_string(bins()) + " bins");
    constexpr size_t cells = ApertureGuide::kCellCount;
    std::vector<double> light(guide_.bins(), 0.0);  // [source][cell]
    std::vector<double> regions(kRegionCount, 0.0);  // over all sources
    for (size_t s = 0; s < sources_; ++s) {
        const double* x = learned.data() + s * kRegionCount * cells;
        std::vector<double> total(kRegionCount, 0.0);
        double all = 0.0;
        for (size_t r = 0; r < kRegionCount; ++r) {
            for (size_t c = 0; c < cells; ++c) {
                const double v = std::max(x[r * cells + c], 0.0);
                total[r] += v;
                regions[r] += v;
            }
            all += total[r];
        }
        if (!(all > 0.0) || !std::isfinite(all)) continue;
        const double lit = kLitFraction * all / kRegionCount;
        for (size_t r = 0; r < kRegionCount; ++r) {
            if (!(total[r] > 0.0)) continue;
            const double weight = std::min(1.0, total[r] / lit) / total[r];
            for (size_t c = 0; c < cells; ++c)
                light[s * cells + c] += weight * std::max(x[r * cells + c], 0.0);
        }
    }
    regionWeight_.clear();
    const double everywhere = std::accumulate(regions.begin(), regions.end(), 0.0);
    if (everywhere > 0.0 && std::isfinite(everywhere)) {
        const double mean = everywhere / kRegionCount, lit = kLitFraction * mean;
        regionWeight_.assign(kRegionCount, 0.0);
        for (size_t r = 0; r < kRegionCount; ++r)
            regionWeight_[r] = regions[r] > 0.0
                                   ? mean * std::min(1.0, regions[r] / lit) / regions[r]
                                   : 1.0 / kLitFraction;
    }
    guide_.prepare(light, g);
}

PhotonImages tracePhotons(const TransportView& ts, const DetectorImage& detector,
                          const BackwardResult& back, const RenderOptions& options,
                          const PathJudge* judge, int k, double radiusMm, const Ranks& ranks,
                          const LensConnector* connector, const EmissionGuide* emissionGuide,
                          const ScatterGuide* scatterGuide, const PartLight* partPhotons,
                          const Deadline& deadline) {
    PhotonImages result;
    tracePhotons(ts, detector, back, options, judge, k, radiusMm, PhotonTile{}, result, ranks,
                 connector, emissionGuide, scatterGuide, partPhotons, deadline);
    return result;
}

void tracePhotons(const TransportView& ts, const DetectorImage& detector,
                  const BackwardResult& back, const RenderOptions& options, const PathJudge* judge,
                  int k, double radiusMm, const PhotonTile& tile, PhotonImages& into,
                  const Ranks& ranks, const LensConnector* connector,
                  const EmissionGuide* emissionGuide, const ScatterGuide* scatterGuide,
                  const PartLight* partPhotons, const Deadline& deadline) {
    const PhotonPass pass(ts, detector, back, options, judge, k, radiusMm, ranks, connector,
                          emissionGuide, scatterGuide, partPhotons, tile);
    if (tile.first) {
        into = pass.emptyImages();
        if (tile.perPhoton) into.perPhoton.assign(pass.total(), 0.0);
    }
    constexpr uint64_t kBlock = 4096;
    forBlocksInOrderOnRanks(
        ranks, pass.total(), kBlock,
        [&](uint64_t first, uint64_t last) {
            deadline.check();
            return pass.traceBlock(first, last);
        },
        [&](const PhotonBlock& b) {
            PhotonPass::add(b, into);
            if (b.perPhoton.empty()) return;
            if (b.perPhoton.size() > into.perPhoton.size() ||
                b.first > into.perPhoton.size() - b.perPhoton.size())
                throw std::runtime_error("a block of photons lies beyond the pass's photons");
            for (size_t j = 0; j < b.perPhoton.size(); ++j)
                into.perPhoton[b.first + j] += b.perPhoton[j];
        },
        PhotonPass::pack, PhotonPass::unpack);
    into.diskRays += pass.diskRays();
}

}  // namespace veil
