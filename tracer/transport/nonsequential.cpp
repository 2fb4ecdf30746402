#include "tracer/transport/nonsequential.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <exception>
#include <thread>

#include "geometry/scene.h"
#include "tracer/records/detector.h"
#include "tracer/records/path_history.h"
#include "tracer/render/path_judge.h"
#include "tracer/runtime/ordered_blocks.h"
#include "tracer/runtime/rng.h"
#include "tracer/sequential/sequential_trace.h"
#include "tracer/transport/interaction.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const TransportOptions& o) {
    return os << "TransportOptions{"
              << (o.mode == TransportOptions::Mode::Split ? "split" : "random")
              << ", min relative flux " << o.minRelativeFlux << ", rescue " << o.rescueRelativeFlux
              << ", max split depth " << o.maxSplitDepth << ", roulette " << o.rouletteRelativeFlux
              << ", max segments " << o.maxSegments << ", seed " << o.seed << "}";
}

double FluxBudget::imbalance() const {
    return (emitted + rouletteGain) - (detected + absorbed() + escaped + culled + dropped);
}

void FluxBudget::merge(const FluxBudget& o) {
    emitted += o.emitted;
    detected += o.detected;
    absorbedSurface += o.absorbedSurface;
    absorbedVolume += o.absorbedVolume;
    escaped += o.escaped;
    culled += o.culled;
    cut += o.cut;
    dropped += o.dropped;
    rouletteGain += o.rouletteGain;
    for (int r = 0; r < kDropReasons; ++r) droppedBranches[r] += o.droppedBranches[r];
    prunedBranches += o.prunedBranches;
    rays += o.rays;
    segments += o.segments;
    branches += o.branches;
}

std::ostream& operator<<(std::ostream& os, const FluxBudget& b) {
    return os << "FluxBudget{emitted " << b.emitted << ", detected " << b.detected << ", absorbed "
              << b.absorbed() << " (surface " << b.absorbedSurface << ", volume "
              << b.absorbedVolume << "), escaped " << b.escaped << ", culled " << b.culled
              << " (cut " << b.cut << ")"
              << ", dropped " << b.dropped << " (" << b.droppedBranches[0] << " "
              << DropReason::NoRefractedDirection << ", " << b.droppedBranches[1] << " "
              << DropReason::NoScatterDirection << "), roulette gain " << b.rouletteGain
              << ", imbalance " << b.imbalance() << "}";
}

namespace {

struct Branch {
    Ray ray;
    double flux = 0.0;
    int medium = 0;
    int depth = 0;
    int segments = 0;
    int startObject = -1;
    int startPrimitive = -1;
    NodeIndex node = kNoNode;             // its last event in the history (when recorded)
    std::shared_ptr<BranchState> filter;  // online pruning state (copied on write at splits)
    // Its own random numbers: the ray's stream for the first branch and whoever continues it
    // (the first child of a split), a stream of its own for every other child, keyed by its
    // parent's key, the split depth and the child. A branch culled in one run and followed in
    // another (a sweep's variants: another reflectance, another min-flux outcome) then
    // shifts no other branch's numbers, so the variants share their paths (common random
    // numbers) wherever their physics agrees.
    uint64_t key = 0;
    CounterRng rng{0, 0};
};

// The key of child k (>= 1) of a split at `depth` of the branch with `key`: distinct for
// every split along a lineage (the depth grows), mixed (splitmix64) across lineages.
uint64_t childKey(uint64_t key, int depth, int k) {
    uint64_t z = key * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(depth) * 64u +
                 static_cast<uint64_t>(k) + 1u;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return (z ^ (z >> 31)) | 1u;  // never 0, the ray's own key
}

// One block of rays as traced: its budget and, per detector, the log of what its rays
// deposited (tracer/records/detector.h, DetectorLog), added to the run's images in block order.
struct Accumulator {
    const std::vector<DetectorImage>* detectors = nullptr;  // the grids (pixelOf)
    FluxBudget budget;
    std::vector<DetectorLog> logs;
    // The current ray's contributions, one list per detector, logged once the ray (with all
    // its branches) is done: sums of squares are per emitted ray, per pixel and in total.
    std::vector<RayContribution> scratch;
    uint64_t rays = 0;  // emitted
    uint64_t end = 0;   // one past the block's last ray (one process)

    Bytes pack() const {
        ByteWriter w;
        w.put(rays);
        w.put(budget);
        for (const DetectorLog& log : logs) log.pack(w);
        return w.take();
    }
    void unpack(const Bytes& bytes) {
        ByteReader r(bytes);
        rays = r.get<uint64_t>();
        budget = r.get<FluxBudget>();
        for (DetectorLog& log : logs) log = DetectorLog::unpack(r);
        if (!r.done()) throw std::runtime_error("a block of rays from another rank is damaged");
    }

    explicit Accumulator(const std::vector<DetectorImage>& grids)
        : detectors(&grids), logs(grids.size()), scratch(grids.size()) {}
    void flushRay() {
        for (size_t d = 0; d < scratch.size(); ++d)
            if (!scratch[d].empty()) logs[d].add(scratch[d]);
    }
};

class RayTracer {
  public:
    RayTracer(const TransportView& ts, const TransportOptions& o)
        : ts_(ts), o_(o), sceneBounds_(ts.scene->bounds()) {}

    const PathHistory& history() const { return history_; }

    void trace(int sourceIndex, uint64_t rayIndex, uint64_t raysPerSource, Accumulator& acc) {
        const Source& source = ts_.sources[sourceIndex];
        CounterRng rng(o_.seed, rayIndex);
        const EmittedRay e = source.emit(rng, raysPerSource);
        FluxBudget& b = acc.budget;
        b.emitted += e.flux;
        ++b.rays;
        NodeIndex root = kNoNode;
        if (o_.recordHistories)
            root = history_.start(sourceIndex, static_cast<float>(e.wavelengthNm), e.ray.origin,
                                  e.ray.direction, e.flux, 0);
        if (!(e.flux > 0.0)) return;
        const int w = e.wavelength;
        const double cullFlux = o_.minRelativeFlux * e.flux;
        const double rouletteFlux = o_.rouletteRelativeFlux * e.flux;
        rescueFlux_ = o_.rescueRelativeFlux * e.flux;
        stack_.clear();
        Branch first{e.ray, e.flux, 0, 0, 0, -1, -1, root, nullptr};
        first.rng = rng;  // the ray's stream, after the emission's numbers
        if (o_.filter) {
            first.filter = o_.filter->start();
            PathEvent emit;
            emit.type = EventType::Emit;
            emit.object = sourceIndex;
            emit.flux = static_cast<float>(e.flux);
            if (!first.filter->push(emit)) {
                cull(first, CullReason::Criterion, b);
                acc.flushRay();
                return;
            }
        }
        stack_.push_back(std::move(first));
        while (!stack_.empty()) {
            Branch br = std::move(stack_.back());
            stack_.pop_back();
            ++b.branches;
            follow(br, w, e.wavelengthNm, cullFlux, rouletteFlux, rayIndex, acc);
        }
        acc.flushRay();
    }

  private:
    // Appends an event to the branch's history (when recording) and moves the branch on it.
    NodeIndex record(NodeIndex parent, EventType type, const Vec3& position, const Vec3& direction,
                     double flux, int object, int face, int medium, uint8_t detail = 0) {
        if (!o_.recordHistories) return kNoNode;
        PathNode n;
        n.position = position;
        n.direction = direction;
        n.flux = flux;
        n.object = object;
        n.face = face;
        n.medium = static_cast<int16_t>(medium);
        n.type = type;
        n.detail = detail;
        return history_.append(parent, n);
    }
    void cull(Branch& br, CullReason why, FluxBudget& b) {
        b.culled += br.flux;
        if (why == CullReason::MinFlux || why == CullReason::MaxSplitDepth ||
            why == CullReason::MaxSegments)
            b.cut += br.flux;
        if (why == CullReason::Criterion) ++b.prunedBranches;
        record(br.node, EventType::Culled, br.ray.origin, br.ray.direction, br.flux, -1, 0,
               br.medium, static_cast<uint8_t>(why));
    }
    // Feeds the branch's online filter its next event; false: the branch is no longer wanted.
    bool wanted(Branch& br, EventType type, int object, int face, int mediumBefore, int mediumAfter,
                double flux) {
        if (!br.filter) return true;
        PathEvent e = pathEvent(type, object, face, mediumBefore, mediumAfter);
        e.flux = static_cast<float>(flux);
        return br.filter->push(e);
    }

    // Where a ray leaving the scene crosses its bounding box (for drawing Exit events).
    Vec3 exitPoint(const Ray& r) const {
        double tFar = 0.0;
        for (int a = 0; a < 3; ++a) {
            if (r.direction[a] == 0.0) continue;
            const double bound = r.direction[a] > 0 ? sceneBounds_.hi[a] : sceneBounds_.lo[a];
            const double t = (bound - r.origin[a]) / r.direction[a];
            tFar = a == 0 || tFar == 0.0 ? t : std::min(tFar, t);
        }
        return r.origin + std::max(0.0, tFar) * r.direction;
    }

    // Moves a branch onto child k of an interaction at `hit`: its direction (drawn now for a
    // scattered child), medium, history node and filter state. False when the branch ends
    // here (no direction: dropped; the filter refuses it: culled).
    bool continueAs(Branch& br, const Interaction& in, int k, const SceneHit& hit, NodeIndex parent,
                    double arriving, CounterRng& rng, FluxBudget& b) {
        const InteractionChild& child = in.children[k];
        const std::optional<Vec3> d = in.direction(k, rng);
        if (!d) {
            b.dropped += br.flux;
            ++b.droppedBranches[static_cast<int>(DropReason::NoScatterDirection)];
            return false;
        }
        br.ray = {hit.point, *d};
        br.medium = child.medium;
        br.startObject = hit.object;
        br.startPrimitive = hit.primitive;
        br.node = record(parent, child.event, hit.point, *d, arriving, hit.object, hit.primitive,
                         br.medium);
        if (!wanted(br, child.event, hit.object, hit.primitive, hit.mediumFrom, br.medium,
                    arriving)) {
            cull(br, CullReason::Criterion, b);
            return false;
        }
        return true;
    }

    // A branch below minRelativeFlux (cullFlux): Russian roulette kept at the rescue flux, or
    // cut without one. False: it ends.
    bool aboveMin(Branch& br, double cullFlux, CounterRng& rng, FluxBudget& b) {
        if (!(br.flux < cullFlux)) return true;
        const double rescue = rescueFlux_;
        if (!(rescue > 0.0)) {
            cull(br, CullReason::MinFlux, b);
            return false;
        }
        if (!(rng.uniform() * rescue < br.flux)) {
            cull(br, CullReason::RussianRoulette, b);
            return false;
        }
        b.rouletteGain += rescue - br.flux;
        br.flux = rescue;
        return true;
    }

    // The branch's flux against the cull threshold and Russian roulette, after every bounce.
    bool survives(Branch& br, double cullFlux, double rouletteFlux, CounterRng& rng,
                  FluxBudget& b) {
        if (!aboveMin(br, cullFlux, rng, b)) return false;
        if (rouletteFlux > 0.0 && br.flux < rouletteFlux) {
            if (rng.uniform() * rouletteFlux < br.flux) {
                b.rouletteGain += rouletteFlux - br.flux;
                br.flux = rouletteFlux;
            } else {
                cull(br, CullReason::RussianRoulette, b);
                return false;
            }
        }
        return true;
    }

    void follow(Branch& br, int w, double wavelengthNm, double cullFlux, double rouletteFlux,
                uint64_t rayIndex, Accumulator& acc) {
        FluxBudget& b = acc.budget;
        CounterRng& rng = br.rng;
        const Scene& scene = *ts_.scene;
        while (true) {
            if (br.segments >= o_.maxSegments) {
                cull(br, CullReason::MaxSegments, b);
                return;
            }
            const auto hit =
                scene.closestHit(br.ray, kInfinity, br.startObject, br.startPrimitive, br.medium);
            ++br.segments;
            ++b.segments;
            if (!hit) {
                b.escaped += br.flux;
                record(br.node, EventType::Exit, exitPoint(br.ray), br.ray.direction, br.flux, -1,
                       0, br.medium);
                return;
            }
            // Absorption inside the medium along the segment.
            const double alpha = ts_.media->absorptionPerMm(br.medium, w);
            if (alpha > 0.0) {
                const double kept = br.flux * std::exp(-alpha * hit->t);
                b.absorbedVolume += br.flux - kept;
                br.flux = kept;
            }
            const int det = ts_.detectorOfObject[hit->object];
            if (det >= 0) {
                // Every detector on the object records the hit; the flux is detected once
                // (the object absorbs it) when any of them has it in a pixel.
                bool pixel = false;
                for (int d = det; d >= 0; d = nextDetectorOf(ts_.nextDetector, d)) {
                    const auto p = (*acc.detectors)[d].pixelOf(hit->point);
                    if (!p) continue;
                    acc.scratch[d].add(*p, br.flux);
                    pixel = true;
                }
                if (pixel) {
                    b.detected += br.flux;
                } else {
                    b.absorbedSurface += br.flux;
                }
                record(br.node, pixel ? EventType::DetectorHit : EventType::SurfaceAbsorb,
                       hit->point, br.ray.direction, br.flux, hit->object, hit->primitive,
                       br.medium);
                return;
            }

            const Interaction in = interact(ts_, *hit, br.ray.direction, w, wavelengthNm);
            b.absorbedSurface += br.flux * in.absorbed;
            if (in.dropped > 0.0) {
                b.dropped += br.flux * in.dropped;
                ++b.droppedBranches[static_cast<int>(in.dropReason)];
            }
            if (in.count == 0) {
                record(br.node, EventType::SurfaceAbsorb, hit->point, br.ray.direction, br.flux,
                       hit->object, hit->primitive, br.medium);
                return;
            }
            const double arriving = br.flux;
            const NodeIndex parent = br.node;
            if (o_.mode == TransportOptions::Mode::Random || in.count == 1) {
                // One child carries the whole non-absorbed flux.
                const int k = in.count > 1 ? chooseChild(in, rng.uniform()) : 0;
                br.flux *= in.total;
                if (!continueAs(br, in, k, *hit, parent, arriving, rng, b)) return;
            } else {
                if (br.depth >= o_.maxSplitDepth) {
                    br.flux *= in.total;
                    cull(br, CullReason::MaxSplitDepth, b);
                    return;
                }
                // Every child its share: push all but the first, continue with the first. A
                // child is made in its place on the stack (and taken off again if it ends
                // here), not built aside and copied in whole just after its fields were written.
                for (int k = in.count - 1; k >= 1; --k) {
                    stack_.push_back(br);
                    Branch& c = stack_.back();
                    if (br.filter) c.filter = br.filter->clone();
                    c.flux = br.flux * in.children[k].share;
                    c.depth = br.depth + 1;
                    c.key = childKey(br.key, br.depth, k);
                    c.rng = CounterRng(o_.seed ^ c.key, rayIndex);
                    if (!continueAs(c, in, k, *hit, parent, arriving, c.rng, b)) {
                        stack_.pop_back();
                        continue;
                    }
                    if (!aboveMin(c, cullFlux, c.rng, b)) stack_.pop_back();
                }
                br.flux *= in.children[0].share;
                br.depth += 1;
                if (!continueAs(br, in, 0, *hit, parent, arriving, rng, b)) return;
            }
            // After every bounce, whichever way the branch went on (a split, a chosen
            // channel, or the single channel of an opaque diffuse part).
            if (!survives(br, cullFlux, rouletteFlux, rng, b)) return;
        }
    }

    const TransportView& ts_;
    const TransportOptions& o_;
    std::vector<Branch> stack_;
    PathHistory history_;
    Bounds3 sceneBounds_;
    double rescueFlux_ = 0.0;  // this ray's: rescueRelativeFlux of its emitted flux
};

}  // namespace

TraceResult traceNonsequential(const TransportView& ts, const std::vector<DetectorImage>& detectors,
                               uint64_t raysPerSource, const TransportOptions& options,
                               const std::function<void(uint64_t)>& progress,
                               const RayCallback& onRay, TraceContinuation* continuation) {
    const uint64_t sources = ts.sources.size();
    const uint64_t total = raysPerSource * sources;
    const uint64_t blockSize = std::max<uint64_t>(1, options.raysPerBlock);
    uint64_t start = 0, added = 0;
    if (continuation) {
        if (!options.ranks.single())
            throw std::invalid_argument("traceNonsequential: a continuation needs one process");
        start = continuation->start;
        added = continuation->added;
        if (start % blockSize != 0 || start > added || added > total ||
            (added > 0 && continuation->images.size() != detectors.size()))
            throw std::invalid_argument("traceNonsequential: the continuation starts at ray " +
                                        std::to_string(start) + " with " + std::to_string(added) +
                                        " added, of " + std::to_string(total));
    }
    std::atomic<uint64_t> done{start};

    // Blocks traced in parallel, added to the images in block order
    // (tracer/runtime/ordered_blocks.h): the sums do not depend on the thread count, and memory is
    // the images plus the logs of a few blocks, whatever the ray count.
    FluxBudget budget;
    std::vector<DetectorImage> images;
    if (continuation && !continuation->images.empty()) {
        images = std::move(continuation->images);
        budget = continuation->budget;
    } else {
        images = detectors;
    }
    auto work = [&]() {
        forBlocksInOrderOnRanks(
            options.ranks, total - start, blockSize,
            [&](uint64_t first, uint64_t last) {
                first += start;
                last += start;
                Accumulator acc(detectors);
                acc.end = last;
                RayTracer tracer(ts, options);
                // Progress counts rays within a block too: a block of long branching rays
                // (parallel uncoated plates) can take minutes.
                constexpr uint64_t kProgressRays = 64;
                uint64_t counted = first;
                for (uint64_t i = first; i < last; ++i) {
                    // Ray i belongs to source i / raysPerSource; its random stream is keyed by
                    // i alone, so sources never share numbers.
                    tracer.trace(static_cast<int>(i / raysPerSource), i, raysPerSource, acc);
                    if (options.recordHistories && onRay) onRay(i, tracer.history());
                    if (options.ranks.single() && i + 1 - counted == kProgressRays) {
                        done += kProgressRays;
                        counted = i + 1;
                    }
                }
                acc.rays = last - first;
                if (options.ranks.single()) done += last - counted;
                return acc;
            },
            [&](const Accumulator& acc) {
                if (!continuation || acc.end > added) {  // a resumed run's blocks are added once
                    budget.merge(acc.budget);
                    for (size_t d = 0; d < images.size(); ++d) images[d].add(acc.logs[d]);
                }
                if (!options.ranks.single()) done += acc.rays;  // rank 0 sees every block
                if (continuation && continuation->afterBlock)
                    continuation->afterBlock(std::max(acc.end, added), budget, images);
            },
            [](const Accumulator& acc) { return acc.pack(); },
            [&](const Bytes& bytes) {
                Accumulator acc(detectors);
                acc.unpack(bytes);
                return acc;
            });
    };
    if (!progress) {
        work();
    } else {
        std::exception_ptr failure;
        std::atomic<bool> finished{false};
        std::thread worker([&] {
            try {
                work();
            } catch (...) {
                failure = std::current_exception();
            }
            finished = true;
        });
        while (!finished.load()) {
            progress(done.load());
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
        }
        worker.join();
        if (failure) std::rethrow_exception(failure);
        progress(total);
    }
    return {budget, std::move(images)};
}

}  // namespace veil
