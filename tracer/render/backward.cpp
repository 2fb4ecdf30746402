#include "tracer/render/backward.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <stdexcept>
#include <unordered_map>

namespace veil {

std::ostream& operator<<(std::ostream& os, const BackwardOptions& o) {
    return os << "BackwardOptions{" << o.raysPerPixel << " rays per pixel, seed " << o.seed
              << (o.split ? ", split" : ", random") << ", depth " << o.maxSpecularDepth
              << ", min weight " << o.minRelativeWeight << "}";
}

std::ostream& operator<<(std::ostream& os, const ViewPoint& v) {
    return os << "ViewPoint{object " << v.object << " at " << v.positionMm << " to detector "
              << v.toDetector << ", pixel " << v.pixel << ", wavelength " << v.wavelength
              << ", weight " << v.weight << "}";
}

double BackwardResult::visibleTotalVariance(uint64_t raysPerPixel) const {
    double v = 0.0;
    for (int p = 0; p < visible.pixelCount(); ++p) v += visible.pixelVariance(p, raysPerPixel);
    return v;
}

double BackwardResult::directTotalVariance(uint64_t raysPerPixel) const {
    double v = 0.0;
    for (int p = 0; p < direct.pixelCount(); ++p) v += direct.pixelVariance(p, raysPerPixel);
    return v;
}

SurfaceContext lightContext(const TransportScene& ts, const ViewPoint& v,
                            const Vec3& lightDirection, double wavelengthNm) {
    SurfaceContext c;
    c.direction = lightDirection;
    const bool fromNormalSide = glm::dot(lightDirection, v.normal) < 0.0;
    c.normal = fromNormalSide ? v.normal : -v.normal;
    // Medium on the normal's side and on the other.
    const int front = v.fromFront ? v.medium : v.otherMedium;
    const int back = v.fromFront ? v.otherMedium : v.medium;
    c.n1 = ts.media->index(fromNormalSide ? front : back, v.wavelength);
    c.n2 = ts.media->index(fromNormalSide ? back : front, v.wavelength);
    c.wavelengthNm = wavelengthNm;
    c.opaque = isOpaqueKind(ts.scene->object(v.object).kind);
    return c;
}

namespace {

// The context of the backward walk arriving at the view point (from the detector's side).
SurfaceContext walkContext(const TransportScene& ts, const ViewPoint& v, double wavelengthNm) {
    SurfaceContext c;
    c.direction = -v.toDetector;
    c.normal = v.fromFront ? v.normal : -v.normal;
    c.n1 = ts.media->index(v.medium, v.wavelength);
    c.n2 = ts.media->index(v.otherMedium, v.wavelength);
    c.wavelengthNm = wavelengthNm;
    c.opaque = isOpaqueKind(ts.scene->object(v.object).kind);
    return c;
}

}  // namespace

double directAt(const TransportScene& ts, const ViewPoint& v, double wavelengthNm,
                CounterRng& rng) {
    return directAt(ts, v, wavelengthNm, rng, {});
}

double directAt(const TransportScene& ts, const ViewPoint& v, double wavelengthNm, CounterRng& rng,
                std::span<double> perSourceSide) {
    // Where a contribution from direction toLight goes when split by source and side.
    auto book = [&](size_t source, const Vec3& toLight, double value) {
        if (perSourceSide.empty()) return;
        const bool sameSide = glm::dot(toLight, v.normal) * glm::dot(v.toDetector, v.normal) > 0.0;
        perSourceSide[2 * source + (sameSide ? 0 : 1)] += value * v.weight;
    };
    const OpticalProperty& prop = ts.properties[ts.propertyOfObject[v.object]];
    const Scene& scene = *ts.scene;
    // Scatter sampling from the detector's side: which channel (by its fraction), then the
    // direction; its density per sr of a direction w is P(w's side) * scatterPdf.
    const SurfaceContext walk = walkContext(ts, v, wavelengthNm);
    const Channels ch = prop.channels(walk);
    const double scatterSum = ch.scatterReflect + ch.scatterTransmit;
    auto scatterPdf = [&](const Vec3& w) {
        if (!(scatterSum > 0.0)) return 0.0;
        const bool transmit = glm::dot(w, walk.normal) < 0.0;
        const double p = (transmit ? ch.scatterTransmit : ch.scatterReflect) / scatterSum;
        return p > 0.0 ? p * prop.scatterPdf(walk, w) : 0.0;
    };
    // The medium light crosses to reach the point from direction toLight, and what it keeps.
    auto kept = [&](const Vec3& toLight, double distanceMm) {
        const bool normalSide = glm::dot(toLight, v.normal) > 0.0;
        const int medium = normalSide == v.fromFront ? v.medium : v.otherMedium;
        const double alpha = ts.media->absorptionPerMm(medium, v.wavelength);
        return alpha > 0.0 ? std::exp(-alpha * distanceMm) : 1.0;
    };
    auto flux = [&](const Vec3& toLight) {  // f cos: light from toLight scattered to the pixel
        const double f = prop.bsdf(lightContext(ts, v, -toLight, wavelengthNm), v.toDetector);
        return f * std::abs(glm::dot(toLight, v.normal));
    };
    double sum = 0.0;
    // Light sampling: one direction per source, weighed by the balance heuristic against the
    // scatter sampling below (weight 1 for the delta kinds, which scatter sampling never hits).
    for (size_t si = 0; si < ts.sources.size(); ++si) {
        const Source& s = ts.sources[si];
        const double u1 = rng.uniform(), u2 = rng.uniform();
        const auto in = s.sampleIncident(v.positionMm, v.wavelength, u1, u2);
        if (!in) continue;
        const double fc = flux(in->toSource);
        if (!(fc > 0.0)) continue;
        if (scene.closestHit({v.positionMm, in->toSource}, in->distanceMm, v.object, v.primitive))
            continue;  // blocked
        const double mis =
            in->pdfSr > 0.0 ? in->pdfSr / (in->pdfSr + scatterPdf(in->toSource)) : 1.0;
        const double value = fc * in->value * kept(in->toSource, in->distanceMm) * mis;
        sum += value;
        book(si, in->toSource, value);
    }
    // Scatter sampling: one direction, checked against every source it reaches unblocked.
    const double u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
    if (scatterSum > 0.0) {
        const bool transmit = u0 * scatterSum < ch.scatterTransmit;
        const ScatterSample ss = prop.sampleScatter(walk, transmit, u1, u2);
        if (ss.pdf > 0.0) {
            const Vec3 w = ss.direction;
            const double pdf = scatterPdf(w);
            const double fc = flux(w);
            if (pdf > 0.0 && fc > 0.0) {
                const Ray ray{v.positionMm, w};
                const auto hit = scene.closestHit(ray, kInfinity, v.object, v.primitive);
                const double tHit = hit ? hit->t : kInfinity;
                for (size_t si = 0; si < ts.sources.size(); ++si) {
                    const Source& s = ts.sources[si];
                    if (s.delta() != Source::Delta::None) continue;
                    const auto t = s.crossing(ray, tHit);
                    if (!t) continue;
                    const Vec3 q = v.positionMm + *t * w;
                    const double radiance = s.emitted(q, -w, v.wavelength);
                    if (!(radiance > 0.0)) continue;
                    const double lightPdf = s.incidentPdf(v.positionMm, q, w);
                    const double value = fc * radiance * kept(w, *t) / (pdf + lightPdf);
                    sum += value;
                    book(si, w, value);
                }
            }
        }
    }
    return sum * v.weight;
}

namespace {

struct Branch {
    Ray ray;
    double weight = 0.0;
    int startObject = -1;
    int startPrimitive = -1;
    int medium = 0;
    int depth = 0;
    int node = 0;  // with criteria: its last event in the ray's EventTree
};

// What the rays of one pixel produced, merged in pixel order afterwards.
struct PixelOutput {
    std::vector<double> visible;  // per ray, its visible-source flux
    std::vector<double> direct;   // per ray, its direct flux
    std::vector<uint8_t> cell;    // per ray, its aperture cell (with a guide)
    static_assert(ApertureGuide::kCellCount <= 256, "a cell index must fit in uint8_t");
    std::vector<ViewPoint> viewPoints;
    std::vector<PathEvent> events;  // the view points' suffixes (firstEvent local to here)
    std::vector<double> visibleBy, directBy;  // [criterion]: the pixel's sums
    uint64_t segments = 0;
    uint64_t pruned = 0;

    // As bytes, between ranks (tracer/runtime/ranks.h).
    void pack(ByteWriter& w) const {
        w.putVector(visible);
        w.putVector(direct);
        w.putVector(cell);
        w.putVector(viewPoints);
        w.putVector(events);
        w.putVector(visibleBy);
        w.putVector(directBy);
        w.put(segments);
        w.put(pruned);
    }
    void unpack(ByteReader& r) {
        visible = r.getVector<double>();
        direct = r.getVector<double>();
        cell = r.getVector<uint8_t>();
        viewPoints = r.getVector<ViewPoint>();
        events = r.getVector<PathEvent>();
        visibleBy = r.getVector<double>();
        directBy = r.getVector<double>();
        segments = r.get<uint64_t>();
        pruned = r.get<uint64_t>();
    }
};

// The backward events of one pixel ray, as a tree: node 0 is the detector hit, every later
// node the forward-order event of a specular interaction with a link toward the detector.
// Walking from a node to the root gives the path from there to the detector in the order
// light travels it.
struct EventTree {
    struct Node {
        PathEvent event;
        int next = -1;  // toward the detector
    };
    std::vector<Node> nodes;
    void start(const PathEvent& detectorHit) { nodes.assign(1, {detectorHit, -1}); }
    int add(const PathEvent& e, int next) {
        nodes.push_back({e, next});
        return static_cast<int>(nodes.size()) - 1;
    }
    // The events from `node` to the detector, appended to `out`.
    void suffix(int node, std::vector<PathEvent>& out) const {
        for (int n = node; n >= 0; n = nodes[static_cast<size_t>(n)].next)
            out.push_back(nodes[static_cast<size_t>(n)].event);
    }
};

// What one judged contribution adds: to the plain image unless pruning drops it, and to
// every criterion it matches.
double bookByCriteria(uint64_t matched, bool prune, double value, std::vector<double>& by) {
    for (uint64_t m = matched; m != 0; m &= m - 1)
        by[static_cast<size_t>(std::countr_zero(m))] += value;
    return prune && matched == 0 ? 0.0 : value;
}

}  // namespace

BackwardResult traceBackward(const TransportScene& ts, const DetectorImage& detector,
                             const ExitAperture& aperture, const BackwardOptions& options) {
    if (options.raysPerPixel == 0)
        throw std::invalid_argument("traceBackward: raysPerPixel must be at least 1");
    if (!(aperture.radiusMm > 0.0))
        throw std::invalid_argument("traceBackward: the exit aperture has no area");
    const Scene& scene = *ts.scene;
    const MediaOptics& media = *ts.media;
    const int wavelengths = media.wavelengthCount();
    const int detectorObject = detector.geometry().object;
    const uint64_t perPixel = options.raysPerPixel;
    const int pixels = detector.pixelCount();

    const PathJudge* judge = options.judge;
    const size_t criteria = judge ? static_cast<size_t>(judge->count()) : 0;
    const bool prune = judge && options.prune;
    const size_t sources = ts.sources.size();

    std::vector<PixelOutput> out(static_cast<size_t>(pixels));
    // Blocks of 64 pixels; across ranks, block b on rank b mod K (local block j is j K + rank).
    constexpr int kPixelBlock = 64;
    const Ranks& ranks = options.ranks;
    const int blocks = (pixels + kPixelBlock - 1) / kPixelBlock;
    const int rankCount = ranks.size(), rankIndex = ranks.rank();
    const int myBlocks = static_cast<int>(ranks.ownedCount(static_cast<uint64_t>(blocks)));
    auto blockPixels = [&](int j) {
        const int b = j * rankCount + rankIndex;
        return std::pair(b * kPixelBlock, std::min(pixels, (b + 1) * kPixelBlock));
    };
    const tbb::blocked_range<int> myRange(0, myBlocks, 1);
    tbb::parallel_for(myRange, [&](const tbb::blocked_range<int>& r) {
        std::vector<Branch> stack;
        EventTree tree;
        std::vector<PathEvent> suffix;
        std::vector<std::byte> state(judge ? judge->stateBytes() : 0),
            scratch(judge ? judge->stateBytes() : 0);
        std::vector<double> perSourceSide(2 * sources);
        std::vector<uint64_t> strata;
        // The criteria the path [Emit(source) head] + suffix matches.
        auto judged = [&](int source, int medium, const PathEvent* head) {
            judge->reset(state.data());
            judge->push(state.data(), pathEvent(EventType::Emit, source, 0, medium, medium));
            if (head) judge->push(state.data(), *head);
            return judge->matches(state.data(), suffix, scratch.data());
        };
        for (int j = r.begin(); j != r.end(); ++j)
            for (int p = blockPixels(j).first, pEnd = blockPixels(j).second; p != pEnd; ++p) {
                PixelOutput& po = out[static_cast<size_t>(p)];
                po.visible.assign(perPixel, 0.0);
                po.direct.assign(perPixel, 0.0);
                if (options.guide) po.cell.assign(perPixel, 0);
                po.visibleBy.assign(criteria, 0.0);
                po.directBy.assign(criteria, 0.0);
                // Stratified pixel rays: the first m^2 rays take one cell each of an m x m
                // grid over the aperture disk's (equal-area) square and, in a shuffled order,
                // one of another over the pixel; the rest are independent. Each cell has the
                // same measure, so the mean stays unbiased; it varies less across the
                // aperture view, where a pixel's light changes most.
                const uint64_t m = static_cast<uint64_t>(std::sqrt(static_cast<double>(perPixel)));
                strata.resize(m * m);
                for (uint64_t i = 0; i < m * m; ++i) strata[i] = i;
                CounterRng shuffle(options.seed ^ 0x5354524154554dull /* "STRATUM" */,
                                   static_cast<uint64_t>(p));
                for (uint64_t i = m * m; i > 1; --i)
                    std::swap(
                        strata[i - 1],
                        strata[std::min(i - 1, static_cast<uint64_t>(shuffle.uniform() * i))]);
                for (uint64_t k = 0; k < perPixel; ++k) {
                    CounterRng rng(options.seed, static_cast<uint64_t>(p) * perPixel + k);
                    std::array<double, kPixelRayUniforms> uk;
                    for (double& x : uk) x = rng.uniform();
                    if (k < m * m) {
                        const uint64_t s = strata[k];
                        uk[0] = (static_cast<double>(s % m) + uk[0]) / static_cast<double>(m);
                        uk[1] = (static_cast<double>(s / m) + uk[1]) / static_cast<double>(m);
                        uk[2] = (static_cast<double>(k % m) + uk[2]) / static_cast<double>(m);
                        uk[3] = (static_cast<double>(k / m) + uk[3]) / static_cast<double>(m);
                    }
                    // The aperture point's uniforms (uk[2], uk[3]) through the guide.
                    double density = 1.0;
                    uint32_t guideBin = 0;
                    if (options.guide) {
                        const ApertureGuide::Warped g = options.guide->warp(p, uk[2], uk[3]);
                        uk[2] = g.u;
                        uk[3] = g.v;
                        density = g.density;
                        po.cell[k] = static_cast<uint8_t>(g.cell);
                        guideBin = static_cast<uint32_t>(options.guide->bin(p, g.cell));
                    }
                    const PixelRay pr = samplePixelRay(detector, p, aperture, uk);
                    const double u = rng.uniform();  // the wavelength
                    if (!(pr.pdf > 0.0) || !(pr.importance > 0.0) || !(pr.cosPixel > 0.0)) continue;
                    const int w = std::min(wavelengths - 1, static_cast<int>(u * wavelengths));
                    const double wavelengthNm = media.wavelengthNm(w);
                    const double start = pr.importance * pr.cosPixel / (pr.pdf * density) /
                                         static_cast<double>(perPixel) * wavelengths;
                    double seen = 0.0, direct = 0.0;
                    stack.clear();
                    stack.push_back({pr.ray, start, detectorObject, -1, 0, 0, 0});
                    if (judge) {
                        tree.start(pathEvent(EventType::DetectorHit, detectorObject, 0, 0, 0));
                    }
                    while (!stack.empty()) {
                        Branch br = stack.back();
                        stack.pop_back();
                        const auto hit = scene.closestHit(br.ray, kInfinity, br.startObject,
                                                          br.startPrimitive, br.medium);
                        const double tHit = hit ? hit->t : kInfinity;
                        // Sources seen along the segment (they block nothing).
                        const double alpha = media.absorptionPerMm(br.medium, w);
                        for (size_t si = 0; si < ts.sources.size(); ++si) {
                            if (!options.visibleSources.empty() && !options.visibleSources[si])
                                continue;
                            const Source& s = ts.sources[si];
                            const auto t = s.crossing(br.ray, tHit);
                            if (!t) continue;
                            const Vec3 x = br.ray.origin + *t * br.ray.direction;
                            const double radiance = s.emitted(x, -br.ray.direction, w);
                            const double value =
                                br.weight * (alpha > 0.0 ? std::exp(-alpha * *t) : 1.0) * radiance;
                            if (!judge) {
                                seen += value;
                                continue;
                            }
                            suffix.clear();
                            tree.suffix(br.node, suffix);
                            seen += bookByCriteria(judged(static_cast<int>(si), br.medium, nullptr),
                                                   prune, value, po.visibleBy);
                        }
                        if (!hit) continue;
                        ++po.segments;
                        if (alpha > 0.0) br.weight *= std::exp(-alpha * hit->t);
                        if (hit->object == detectorObject || ts.detectorOfObject[hit->object] >= 0)
                            continue;  // a detector absorbs
                        const Interaction in = interact(ts, *hit, br.ray.direction, w, wavelengthNm,
                                                        TransportMode::Importance);
                        bool scatters = false;
                        double specular = 0.0;
                        for (int c = 0; c < in.count; ++c) {
                            scatters |= in.children[c].scatter;
                            if (!in.children[c].scatter) specular += in.children[c].share;
                        }
                        bool store = scatters;
                        double vpWeight = br.weight;
                        if (scatters && options.viewPointRelativeWeight > 0.0) {
                            const double floor = options.viewPointRelativeWeight * start;
                            const double u = rng.uniform();  // drawn at every scattering hit
                            if (vpWeight < floor) {
                                store = u * floor < vpWeight;
                                vpWeight = floor;
                            }
                        }
                        if (store) {
                            ViewPoint v;
                            v.positionMm = hit->point;
                            v.normal = hit->normal;
                            v.toDetector = -br.ray.direction;
                            v.object = hit->object;
                            v.primitive = hit->primitive;
                            v.pixel = p;
                            v.wavelength = w;
                            v.medium = hit->mediumFrom;
                            v.otherMedium = hit->mediumTo;
                            v.fromFront = hit->fromFront;
                            v.weight = vpWeight;
                            v.guideBin = guideBin;
                            if (judge) {
                                v.firstEvent = static_cast<uint32_t>(po.events.size());
                                suffix.clear();
                                tree.suffix(br.node, suffix);
                                v.eventCount = static_cast<uint32_t>(suffix.size());
                                po.events.insert(po.events.end(), suffix.begin(), suffix.end());
                            }
                            if (options.direct && !judge) {
                                direct += directAt(ts, v, wavelengthNm, rng);
                            } else if (options.direct) {
                                std::fill(perSourceSide.begin(), perSourceSide.end(), 0.0);
                                directAt(ts, v, wavelengthNm, rng, perSourceSide);
                                for (size_t k = 0; k < perSourceSide.size(); ++k) {
                                    if (perSourceSide[k] == 0.0) continue;
                                    // The light's own scatter event: from its side of the surface.
                                    const bool crosses = k % 2 == 1;
                                    const PathEvent scatter =
                                        pathEvent(crosses ? EventType::ScatterTransmit
                                                          : EventType::ScatterReflect,
                                                  v.object, v.primitive,
                                                  crosses ? v.otherMedium : v.medium, v.medium);
                                    direct += bookByCriteria(judged(static_cast<int>(k / 2),
                                                                    scatter.mediumBefore, &scatter),
                                                             prune, perSourceSide[k], po.directBy);
                                }
                            }
                            po.viewPoints.push_back(v);
                        }
                        if (!(specular > 0.0) || br.depth >= options.maxSpecularDepth) continue;
                        auto push = [&](const InteractionChild& c, double weight) {
                            Branch next;
                            next.ray = {hit->point, c.direction};
                            next.weight = weight;
                            next.startObject = hit->object;
                            next.startPrimitive = hit->primitive;
                            next.medium = c.medium;
                            next.depth = br.depth + 1;
                            if (judge) {
                                // Forward, light comes from the child's side and leaves into ours.
                                next.node = tree.add(pathEvent(c.event, hit->object, hit->primitive,
                                                               c.medium, br.medium),
                                                     br.node);
                                if (prune) {
                                    suffix.clear();
                                    tree.suffix(next.node, suffix);
                                    if (judge->suffixMayMatch(suffix) == 0) {
                                        ++po.pruned;
                                        return;
                                    }
                                }
                            }
                            stack.push_back(next);
                        };
                        if (options.split) {
                            for (int c = 0; c < in.count; ++c) {
                                const InteractionChild& child = in.children[c];
                                if (child.scatter || !(child.share > 0.0)) continue;
                                const double weight = br.weight * child.share;
                                if (weight < options.minRelativeWeight * start) continue;
                                push(child, weight);
                            }
                        } else {
                            // One specular child, chosen by weight, carries their sum.
                            const double x = rng.uniform() * specular;
                            double sum = 0.0;
                            int chosen = -1;
                            for (int c = 0; c < in.count; ++c) {
                                if (in.children[c].scatter) continue;
                                chosen = c;
                                sum += in.children[c].share;
                                if (x < sum) break;
                            }
                            push(in.children[chosen], br.weight * specular);
                        }
                    }
                    po.visible[k] = seen;
                    po.direct[k] = direct;
                }
            }
    });

    if (!ranks.single()) {
        // Every rank's pixels to every rank: the photons of each need all view points.
        ByteWriter w;
        for (int j = 0; j < myBlocks; ++j) {
            const auto [pBegin, pEnd] = blockPixels(j);
            for (int p = pBegin; p < pEnd; ++p) {
                out[static_cast<size_t>(p)].pack(w);
            }
        }
        const std::vector<Bytes> all = ranks.gatherAll(w.take());
        for (int q = 0; q < rankCount; ++q) {
            if (q == rankIndex) continue;
            ByteReader in(all[static_cast<size_t>(q)]);
            for (int b = q; b < blocks; b += rankCount) {
                for (int p = b * kPixelBlock; p < std::min(pixels, (b + 1) * kPixelBlock); ++p) {
                    out[static_cast<size_t>(p)].unpack(in);
                }
            }
            if (!in.done()) throw std::runtime_error("the pixels of another rank are damaged");
        }
    }

    BackwardResult result;
    result.visible = DetectorImage(detector.geometry());
    result.direct = DetectorImage(detector.geometry());
    result.visibleByCriterion.assign(criteria, std::vector<double>(static_cast<size_t>(pixels)));
    result.directByCriterion.assign(criteria, std::vector<double>(static_cast<size_t>(pixels)));
    if (options.guide) result.learned.assign(options.guide->bins(), 0.0);
    std::unordered_map<uint64_t, std::vector<uint32_t>> interned;  // suffix hash -> offsets
    for (int p = 0; p < pixels; ++p) {
        PixelOutput& po = out[static_cast<size_t>(p)];
        if (options.guide)
            for (uint64_t k = 0; k < perPixel; ++k)
                result.learned[options.guide->bin(p, po.cell[k])] += po.visible[k] + po.direct[k];
        for (double v : po.visible)
            if (v != 0.0) result.visible.add(p, v);
        for (double v : po.direct)
            if (v != 0.0) result.direct.add(p, v);
        // Identical suffixes (the same specular path to the detector) are stored once, so the
        // photon pass judges each once per gathering hit (tracer/render/photon_pass.cpp).
        for (ViewPoint& v : po.viewPoints) {
            const auto first = po.events.begin() + v.firstEvent;
            const auto last = first + v.eventCount;
            uint64_t h = 1469598103934665603ull ^ v.eventCount;
            for (auto e = first; e != last; ++e) {
                const uint64_t parts[] = {
                    uint64_t(e->type), uint64_t(uint32_t(e->object)), uint64_t(uint32_t(e->face)),
                    uint64_t(uint16_t(e->mediumBefore)), uint64_t(uint16_t(e->mediumAfter))};
                for (uint64_t x : parts) h = (h ^ x) * 1099511628211ull;
            }
            std::vector<uint32_t>& same = interned[h];
            const auto found = std::find_if(same.begin(), same.end(), [&](uint32_t o) {
                return std::equal(first, last, result.events.begin() + o,
                                  result.events.begin() + o + v.eventCount);
            });
            if (found != same.end()) {
                v.firstEvent = *found;
            } else {
                v.firstEvent = static_cast<uint32_t>(result.events.size());
                same.push_back(v.firstEvent);
                result.events.insert(result.events.end(), first, last);
            }
        }
        result.viewPoints.insert(result.viewPoints.end(), po.viewPoints.begin(),
                                 po.viewPoints.end());
        for (size_t k = 0; k < criteria; ++k) {
            result.visibleByCriterion[k][static_cast<size_t>(p)] = po.visibleBy[k];
            result.directByCriterion[k][static_cast<size_t>(p)] = po.directBy[k];
        }
        result.segments += po.segments;
        result.prunedBranches += po.pruned;
    }
    result.rays = static_cast<uint64_t>(pixels) * perPixel;
    return result;
}

}  // namespace veil
