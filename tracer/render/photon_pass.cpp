#include "tracer/render/photon_pass.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstring>
#include <numbers>

#include "tracer/render/render.h"
#include "tracer/runtime/ordered_blocks.h"
#include "tracer/runtime/qmc.h"

namespace veil {

namespace {

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
    size_t state = 0;               // with criteria: its path state's offset in the photon's arena
    uint64_t alive = ~uint64_t{0};  // criteria its path may still match
};

}  // namespace

PhotonImages tracePhotons(const TransportScene& ts, const DetectorImage& detector,
                          const BackwardResult& back, const RenderOptions& options,
                          const PathJudge* judge, int k, double radiusMm, const Ranks& ranks) {
    const int pixels = detector.pixelCount();
    const std::vector<ViewPoint>& vps = back.viewPoints;
    const ViewPointGrid grid(vps, radiusMm);
    const double r2 = radiusMm * radiusMm;
    const double kernel = 1.0 / (std::numbers::pi * r2);
    // The rim correction, computed the first time a view point gathers light from a side:
    // 1 / its area share, negative when the view point lies in a gap on that side. The value
    // depends on the view point alone (the spiral turned by its index), so threads racing on
    // it write the same bits.
    std::vector<std::atomic<float>> inverseShare(2 * vps.size());
    for (auto& x : inverseShare) x.store(0.0f, std::memory_order_relaxed);
    auto areaCorrection = [&](uint32_t i, bool otherSide) {
        std::atomic<float>& slot = inverseShare[2 * size_t{i} + (otherSide ? 1 : 0)];
        float c = slot.load(std::memory_order_relaxed);
        if (c == 0.0f) {
            const double turn =
                2.0 * std::numbers::pi * CounterRng(passSeed(options.seed, k, 2), i).uniform();
            const DiskShare d = viewPointAreaShare(*ts.scene, vps[i], radiusMm, options.areaSamples,
                                                   turn, otherSide);
            c = static_cast<float>((d.inGap ? -1.0 : 1.0) / d.share);
            slot.store(c, std::memory_order_relaxed);
        }
        return static_cast<double>(c);
    };
    if (!ranks.single()) {
        // Across ranks every rank's photons reach nearly every view point, and each rank
        // would find the same corrections again: they are computed once, blocks of view
        // points split over the ranks, and shared; the other side's only where light can
        // come through (not on opaque parts, whose transmission is 0).
        constexpr size_t kShareBlock = 1024;
        auto transmissive = [&](size_t i) {
            return !isOpaqueKind(ts.scene->object(vps[i].object).kind);
        };
        const size_t n = vps.size(), blocks = (n + kShareBlock - 1) / kShareBlock;
        tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
            if (!ranks.owns(b)) return;
            for (size_t i = b * kShareBlock; i < std::min(n, (b + 1) * kShareBlock); ++i) {
                areaCorrection(static_cast<uint32_t>(i), false);
                if (transmissive(i)) areaCorrection(static_cast<uint32_t>(i), true);
            }
        });
        ByteWriter w;
        for (size_t b = static_cast<size_t>(ranks.rank()); b < blocks;
             b += static_cast<size_t>(ranks.size()))
            for (size_t i = b * kShareBlock; i < std::min(n, (b + 1) * kShareBlock); ++i)
                for (size_t side = 0; side < (transmissive(i) ? 2u : 1u); ++side)
                    w.put(inverseShare[2 * i + side].load(std::memory_order_relaxed));
        const std::vector<Bytes> all = ranks.gatherAll(w.take());
        for (int q = 0; q < ranks.size(); ++q) {
            if (q == ranks.rank()) continue;
            ByteReader in(all[static_cast<size_t>(q)]);
            for (size_t b = static_cast<size_t>(q); b < blocks;
                 b += static_cast<size_t>(ranks.size()))
                for (size_t i = b * kShareBlock; i < std::min(n, (b + 1) * kShareBlock); ++i)
                    for (size_t side = 0; side < (transmissive(i) ? 2u : 1u); ++side)
                        inverseShare[2 * i + side].store(in.get<float>(),
                                                         std::memory_order_relaxed);
            if (!in.done())
                throw std::runtime_error("the view point shares of another rank are damaged");
        }
    }
    const double gapMm = kGapFraction * radiusMm;
    const uint64_t perSource = options.photonsPerPass;
    const uint64_t total = perSource * ts.sources.size();
    const uint64_t ghostPhotons = options.ghostPhotons();
    const double visibleScale = static_cast<double>(perSource) / static_cast<double>(ghostPhotons);
    const uint64_t photonSeed = passSeed(options.seed, static_cast<uint64_t>(k), 1);
    // Quasi-random emission: one scramble of the Sobol points per source and pass.
    std::vector<SobolOwen> emission;
    for (size_t s = 0; s < ts.sources.size(); ++s)
        emission.emplace_back(passSeed(options.seed, static_cast<uint64_t>(k), 3) ^
                              (0x9E3779B97F4A7C15ull * (s + 1)));
    const Scene& scene = *ts.scene;
    const MediaOptics& media = *ts.media;
    const uint64_t block = 4096;

    const int renderedObject = detector.geometry().object;
    const DetectorImage& grid0 = detector;
    // The detector's smoothing disk this pass (mm), shrinking with the gathering radius.
    const DetectorGeometry& dg = grid0.geometry();
    const double rho = options.detectorRadiusPixels *
                       std::max(dg.pixelWidthMm(), dg.pixelHeightMm()) *
                       (options.initialRadiusMm > 0.0 ? radiusMm / options.initialRadiusMm : 1.0);
    // The pixels that share a deposit landing at `point`: those whose centres lie within rho
    // (its own pixel alone when none does); none when it misses the grid.
    auto splatCells = [&](const Vec3& point, std::vector<int>& cells) {
        cells.clear();
        const auto own = grid0.pixelOf(point);
        if (!own) return;
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
    };
    // Criteria: photon prefixes stream through the judge; a gather or a deposit judges the
    // joined path (the photon's events, its scatter at the view point, the view point's
    // backward events; or the detector hit).
    const size_t criteria = judge ? static_cast<size_t>(judge->count()) : 0;
    const bool prune = judge && options.prune;
    const size_t stateBytes = judge ? judge->stateBytes() : 0;
    const std::vector<PathEvent>& vpEvents = back.events;

    // A block's photons keep what they deposit as a log, image by image in order (image 0..2
    // the plain visible, caustic and secondary light, 3 + 3 k + slot criterion k's), added to
    // the pass's images in block order (tracer/runtime/ordered_blocks.h): bitwise the same images
    // for every thread count, memory with the gathers of a few blocks, not images per block.
    struct Deposit {
        uint32_t image;
        int pixel;
        double value;
    };
    struct PhotonBlock {
        std::vector<Deposit> deposits;
        std::vector<double> learned;
        uint64_t photons = 0, segments = 0, gathers = 0, pruned = 0;
    };
    PhotonImages result;
    result.visible.assign(static_cast<size_t>(pixels), 0.0);
    result.caustic.assign(static_cast<size_t>(pixels), 0.0);
    result.secondary.assign(static_cast<size_t>(pixels), 0.0);
    result.by.assign(criteria, {result.visible, result.caustic, result.secondary});
    result.learned.assign(back.learned.size(), 0.0);
    forBlocksInOrderOnRanks(
        ranks, total, block,
        [&](uint64_t first, uint64_t last) {
            PhotonBlock a;
            a.learned.assign(back.learned.size(), 0.0);
            std::vector<PhotonBranch> stack;
            std::vector<int> cells;
            std::vector<std::byte> states, scratch(stateBytes);  // states: per branch
            std::vector<PathEvent> suffix;
            std::vector<Verdict> verdicts;  // this hit's judged suffixes
            // Adds `value` to image slot `slot` (0 visible, 1 caustic, 2 secondary) of the
            // plain accumulator unless pruning drops it, and of every criterion matched; a
            // spread value is shared evenly by its cells.
            auto book = [&](int slot, uint64_t matched, const std::vector<int>* spread, int pixel,
                            double value) {
                auto into = [&](uint32_t image) {
                    if (spread) {
                        const double share = value / static_cast<double>(spread->size());
                        for (int p : *spread) a.deposits.push_back({image, p, share});
                    } else {
                        a.deposits.push_back({image, pixel, value});
                    }
                };
                if (!prune || matched != 0) into(static_cast<uint32_t>(slot));
                for (uint64_t m = matched; m != 0; m &= m - 1)
                    into(static_cast<uint32_t>(3 + 3 * std::countr_zero(m) + slot));
            };
            for (uint64_t i = first; i < last; ++i) {
                const size_t sourceIndex = i / perSource;
                const Source& source = ts.sources[sourceIndex];
                const bool deposits = photonsSeeSource(source);
                CounterRng rng(photonSeed, i);
                EmittedRay e;
                if (options.quasiRandomPhotons) {
                    // Sobol dimensions 0 and 1 (the best pair) to the origin, 2 and 3 to the
                    // direction, 4 to the line.
                    const SobolOwen& q = emission[sourceIndex];
                    const uint64_t j = i % perSource;
                    e = source.emit({q.sample(j, 4), q.sample(j, 0), q.sample(j, 1), q.sample(j, 2),
                                     q.sample(j, 3)},
                                    perSource);
                } else {
                    e = source.emit(rng, perSource);
                }
                ++a.photons;
                if (!(e.flux > 0.0)) continue;
                const int w = e.wavelength;
                const double rouletteFlux = options.rouletteRelativeFlux * e.flux;
                const double cullFlux = options.photonMinRelativeFlux * e.flux;
                // Until their first scatter photons split at every interface. The first
                // ghostPhotons of a source's quasi-random photons follow every branch (below
                // the cull, roulette at the rescue level) and deposit the visible light, for
                // all of them; the others' branches play roulette below rouletteFlux, as after
                // a scatter: their weak ghosts matter only where they scatter.
                const bool splitAll = i % perSource < ghostPhotons;
                const bool cheap = !splitAll && rouletteFlux > 0.0;
                const double lowFlux = cheap ? rouletteFlux : cullFlux;
                const double keepFlux =
                    cheap ? rouletteFlux : options.photonRescueRelativeFlux * e.flux;
                stack.clear();
                PhotonBranch first{e.ray, e.flux, 0, -1, -1, false, false, 0, rouletteFlux};
                if (judge) {
                    states.assign(stateBytes, std::byte{0});
                    judge->reset(states.data());
                    first.alive = judge->push(
                        states.data(),
                        pathEvent(EventType::Emit, static_cast<int>(sourceIndex), 0, 0, 0));
                    if (prune && first.alive == 0) {
                        ++a.pruned;
                        continue;
                    }
                }
                stack.push_back(first);
                while (!stack.empty()) {
                    PhotonBranch br = stack.back();
                    stack.pop_back();
                    // The criteria a path of this branch's events and `suffix` matches.
                    auto judged = [&] {
                        if (br.alive == 0) return uint64_t{0};
                        return judge->matches(states.data() + br.state, suffix, scratch.data());
                    };
                    for (; br.segments < options.maxPhotonSegments; ++br.segments) {
                        const auto hit = scene.closestHit(br.ray, kInfinity, br.startObject,
                                                          br.startPrimitive, br.medium);
                        ++a.segments;
                        if (!hit) break;
                        const double alpha = media.absorptionPerMm(br.medium, w);
                        if (alpha > 0.0) br.flux *= std::exp(-alpha * hit->t);
                        if (ts.detectorOfObject[hit->object] >= 0) {
                            // Light that scattered nowhere lands here: the visible component
                            // of the sources the photons stand for.
                            if (deposits && splitAll && !br.scattered &&
                                hit->object == renderedObject) {
                                splatCells(hit->point, cells);
                                if (cells.empty()) break;
                                uint64_t matched = 0;
                                if (judge) {
                                    suffix.assign(1,
                                                  pathEvent(EventType::DetectorHit, hit->object,
                                                            hit->primitive, br.medium, br.medium));
                                    matched = judged();
                                }
                                book(0, matched, &cells, 0, br.flux * visibleScale);
                            }
                            break;
                        }
                        const Interaction in = interact(ts, *hit, br.ray.direction, w,
                                                        e.wavelengthNm, TransportMode::Flux);
                        bool scatters = false;
                        for (int c = 0; c < in.count; ++c) scatters |= in.children[c].scatter;
                        // Until its first scatter a branch is followed whatever its flux (its
                        // ghosts are the visible light, smooth only when every branch of every
                        // photon lands); where it first meets a scattering surface, the light
                        // it scatters plays Russian roulette: below rouletteFlux it is kept with
                        // probability flux / rouletteFlux, at rouletteFlux. The gathering, which
                        // costs as much for a weak ghost as for the photon itself, and the
                        // scattered child take that flux; its specular children keep theirs.
                        // From then on the scattered light is a photon of its own: it plays
                        // roulette below rouletteRelativeFlux of its flux just after this
                        // scatter (PhotonBranch::rouletteFlux), however dark the surface.
                        double scatterScale = 1.0;
                        if (scatters && !br.scattered) {
                            const double kept =
                                playRoulette(br.flux, rouletteFlux, rouletteFlux, rng);
                            scatterScale = kept > 0.0 ? kept / br.flux : 0.0;
                        }
                        if (scatters && (br.specular || br.scattered) && scatterScale > 0.0) {
                            const int slot = br.scattered ? 2 : 1;
                            const auto [firstVp, lastVp] = grid.candidates(hit->point);
                            verdicts.clear();
                            // The photon's side of the face, and whether it lies in a gap there
                            // (looked at once, when a view point first needs it).
                            const double photonCos = glm::dot(br.ray.direction, hit->normal);
                            int photonInGap = -1;
                            // The float pre-test keeps every view point within r: its
                            // radius is widened by the rounding of the float coordinates.
                            const float px = static_cast<float>(hit->point.x),
                                        py = static_cast<float>(hit->point.y),
                                        pz = static_cast<float>(hit->point.z);
                            const double wide =
                                radiusMm * (1.0 + 1e-6) +
                                1e-6 * (std::abs(hit->point.x) + std::abs(hit->point.y) +
                                        std::abs(hit->point.z));
                            const float wide2 = static_cast<float>(wide * wide);
                            for (const GridEntry* it = firstVp; it != lastVp; ++it) {
                                if (it->object != hit->object) continue;
                                const float dx = it->x - px, dy = it->y - py, dz = it->z - pz;
                                if (dx * dx + dy * dy + dz * dz > wide2) continue;
                                const ViewPoint& v = vps[it->index];
                                if (v.wavelength != w) continue;
                                if (!(glm::dot(v.normal, hit->normal) > kGatherNormalCos)) continue;
                                const Vec3 d = v.positionMm - hit->point;
                                if (glm::dot(d, d) > r2) continue;
                                const double f = in.property->bsdf(in.context, v.toDetector);
                                if (!(f > 0.0)) continue;
                                // The photon's scatter here toward the view point's pixel:
                                // a reflection when it arrives on the view point's side. It
                                // counts where both lie in a gap on its side or neither.
                                const bool back =
                                    photonCos * glm::dot(v.toDetector, hit->normal) < 0.0;
                                const double correction = areaCorrection(it->index, !back);
                                if (photonInGap < 0) {
                                    const Vec3 side = photonCos < 0.0 ? hit->normal : -hit->normal;
                                    photonInGap = inGapAt(scene, hit->point, hit->object,
                                                          hit->primitive, side, gapMm)
                                                      ? 1
                                                      : 0;
                                }
                                if ((correction < 0.0) != (photonInGap == 1)) continue;
                                ++a.gathers;
                                uint64_t matched = 0;
                                if (judge && br.alive != 0) {
                                    // View points with the same suffix (stored once by the
                                    // backward pass) get the same verdict at this hit.
                                    const auto known = std::find_if(
                                        verdicts.begin(), verdicts.end(), [&](const Verdict& x) {
                                            return x.firstEvent == v.firstEvent &&
                                                   x.eventCount == v.eventCount && x.back == back &&
                                                   x.medium == v.medium;
                                        });
                                    if (known != verdicts.end()) {
                                        matched = known->matched;
                                    } else {
                                        suffix.assign(
                                            1, pathEvent(back ? EventType::ScatterReflect
                                                              : EventType::ScatterTransmit,
                                                         hit->object, hit->primitive, br.medium,
                                                         v.medium));
                                        suffix.insert(
                                            suffix.end(), vpEvents.begin() + v.firstEvent,
                                            vpEvents.begin() + v.firstEvent + v.eventCount);
                                        matched = judged();
                                        if (verdicts.size() < kVerdictCache)
                                            verdicts.push_back({v.firstEvent, v.eventCount,
                                                                v.medium, back, matched});
                                    }
                                }
                                const double value = v.weight * br.flux * scatterScale * f *
                                                     kernel * std::abs(correction);
                                book(slot, matched, nullptr, v.pixel, value);
                                if (!a.learned.empty()) a.learned[v.guideBin] += value;
                            }
                        }
                        if (in.count == 0) break;
                        // Continue as child c with flux `flux`; false when it has no direction
                        // or no criterion can match its path any more (prune).
                        auto become = [&](PhotonBranch& b, int c, double flux) {
                            const auto dir = in.direction(c, rng);
                            if (!dir) return false;
                            const InteractionChild& child = in.children[c];
                            if (judge && b.alive != 0) {
                                b.alive =
                                    judge->push(states.data() + b.state,
                                                pathEvent(child.event, hit->object, hit->primitive,
                                                          b.medium, child.medium));
                            }
                            if (prune && b.alive == 0) {
                                ++a.pruned;
                                return false;
                            }
                            if (child.scatter && !b.scattered)
                                b.rouletteFlux = options.rouletteRelativeFlux * flux;
                            (child.scatter ? b.scattered : b.specular) = true;
                            b.flux = flux;
                            b.ray = {hit->point, *dir};
                            b.medium = child.medium;
                            b.startObject = hit->object;
                            b.startPrimitive = hit->primitive;
                            return true;
                        };
                        int c = 0;
                        double flux = 0.0;
                        if (!br.scattered && in.count > 1) {
                            // Before the first scatter every child is followed (the ghosts live
                            // in the weak reflected branches); then one child by weight.
                            for (int k = in.count - 1; k >= 1; --k) {
                                const double f = br.flux * in.children[k].share *
                                                 (in.children[k].scatter ? scatterScale : 1.0);
                                if (!(f > 0.0)) continue;
                                // A scattered child's flux played its roulette above (the
                                // incident flux, scatterScale): it starts a photon of its own.
                                const double keep = in.children[k].scatter
                                                        ? f
                                                        : playRoulette(f, lowFlux, keepFlux, rng);
                                if (!(keep > 0.0)) continue;
                                PhotonBranch child = br;
                                child.segments = br.segments + 1;
                                if (judge) {  // its own copy of the path state
                                    child.state = states.size();
                                    states.resize(states.size() + stateBytes);
                                    std::memcpy(states.data() + child.state,
                                                states.data() + br.state, stateBytes);
                                }
                                if (become(child, k, keep)) stack.push_back(child);
                            }
                            c = 0;
                            flux = br.flux * in.children[0].share *
                                   (in.children[0].scatter ? scatterScale : 1.0);
                            if (!(flux > 0.0)) break;
                            if (!in.children[0].scatter)
                                flux = playRoulette(flux, lowFlux, keepFlux, rng);
                            if (!(flux > 0.0)) break;
                        } else {
                            c = in.count > 1 ? chooseChild(in, rng.uniform()) : 0;
                            flux =
                                br.flux * in.total * (in.children[c].scatter ? scatterScale : 1.0);
                            if (!(flux > 0.0)) break;
                        }
                        if (!become(br, c, flux)) break;
                        if (br.scattered) {
                            br.flux = playRoulette(br.flux, br.rouletteFlux, br.rouletteFlux, rng);
                            if (!(br.flux > 0.0)) break;
                        }
                    }
                }
            }
            return a;
        },
        [&](const PhotonBlock& b) {
            std::vector<double>* images[3] = {&result.visible, &result.caustic, &result.secondary};
            for (const Deposit& d : b.deposits) {
                std::vector<double>& image = d.image < 3
                                                 ? *images[d.image]
                                                 : result.by[(d.image - 3) / 3][(d.image - 3) % 3];
                image[static_cast<size_t>(d.pixel)] += d.value;
            }
            for (size_t p = 0; p < result.learned.size(); ++p) result.learned[p] += b.learned[p];
            result.photons += b.photons;
            result.segments += b.segments;
            result.gathers += b.gathers;
            result.pruned += b.pruned;
        },
        [](const PhotonBlock& b) {
            ByteWriter w;
            w.putVector(b.deposits);
            w.putVector(b.learned);
            for (uint64_t n : {b.photons, b.segments, b.gathers, b.pruned}) w.put(n);
            return w.take();
        },
        [](const Bytes& bytes) {
            ByteReader r(bytes);
            PhotonBlock b;
            b.deposits = r.getVector<Deposit>();
            b.learned = r.getVector<double>();
            for (uint64_t* n : {&b.photons, &b.segments, &b.gathers, &b.pruned})
                *n = r.get<uint64_t>();
            if (!r.done())
                throw std::runtime_error("a block of photons from another rank is damaged");
            return b;
        });
    return result;
}

}  // namespace veil
