#include "tracer/render/backward.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <unordered_map>

#include "geometry/scene.h"
#include "tracer/records/detector.h"
#include "tracer/records/path_history.h"
#include "tracer/render/designed_path.h"
#include "tracer/render/part_light.h"
#include "tracer/runtime/rng.h"
#include "tracer/surfaces/media.h"
#include "tracer/transport/interaction.h"

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

SurfaceContext lightContext(const TransportView& ts, const ViewPoint& v, const Vec3& lightDirection,
                            double wavelengthNm) {
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
SurfaceContext walkContext(const TransportView& ts, const ViewPoint& v, double wavelengthNm) {
    SurfaceContext c;
    c.direction = -v.toDetector;
    c.normal = v.fromFront ? v.normal : -v.normal;
    c.n1 = ts.media->index(v.medium, v.wavelength);
    c.n2 = ts.media->index(v.otherMedium, v.wavelength);
    c.wavelengthNm = wavelengthNm;
    c.opaque = isOpaqueKind(ts.scene->object(v.object).kind);
    return c;
}

// The scatter lobes at a view point as the backward walk meets them: which channel (by its
// fraction), then the direction, drawn from the detector's side; the density per sr of a
// direction w is P(w's side) * scatterPdf. fluxCos(w): f cos of the light that arrives from w
// and leaves toward the pixel (the adjoint, by reversal: lightContext).
class ViewPointLobes {
  public:
    ViewPointLobes(const TransportView& ts, const ViewPoint& v, double wavelengthNm)
        : ts_(ts),
          v_(v),
          wavelengthNm_(wavelengthNm),
          prop_(ts.properties[ts.propertyOfObject[v.object]]),
          walk_(walkContext(ts, v, wavelengthNm)),
          ch_(prop_.channels(walk_)),
          sum_(ch_.scatterReflect + ch_.scatterTransmit) {}

    const SurfaceContext& walk() const { return walk_; }
    double pdf(const Vec3& w) const {
        if (!(sum_ > 0.0)) return 0.0;
        const bool transmit = glm::dot(w, walk_.normal) < 0.0;
        const double p = (transmit ? ch_.scatterTransmit : ch_.scatterReflect) / sum_;
        return p > 0.0 ? p * prop_.scatterPdf(walk_, w) : 0.0;
    }
    double fluxCos(const Vec3& toLight) const {
        const double f = prop_.bsdf(lightContext(ts_, v_, -toLight, wavelengthNm_), v_.toDetector);
        return f * std::abs(glm::dot(toLight, v_.normal));
    }
    // A direction from three uniforms, or none (no scatter, or the lobe gave none).
    std::optional<Vec3> sample(double u0, double u1, double u2) const {
        if (!(sum_ > 0.0)) return std::nullopt;
        const bool transmit = u0 * sum_ < ch_.scatterTransmit;
        const ScatterSample ss = prop_.sampleScatter(walk_, transmit, u1, u2);
        if (!(ss.pdf > 0.0)) return std::nullopt;
        return ss.direction;
    }

  private:
    const TransportView& ts_;
    const ViewPoint& v_;
    double wavelengthNm_;
    const OpticalProperty& prop_;
    SurfaceContext walk_;
    Channels ch_;
    double sum_;
};

}  // namespace

double directAt(const TransportView& ts, const ViewPoint& v, double wavelengthNm, CounterRng& rng) {
    return directAt(ts, v, wavelengthNm, rng, {});
}

double directAt(const TransportView& ts, const ViewPoint& v, double wavelengthNm, CounterRng& rng,
                std::span<double> perSourceSide) {
    // Where a contribution from direction toLight goes when split by source and side.
    auto book = [&](size_t source, const Vec3& toLight, double value) {
        if (perSourceSide.empty()) return;
        const bool sameSide = glm::dot(toLight, v.normal) * glm::dot(v.toDetector, v.normal) > 0.0;
        perSourceSide[2 * source + (sameSide ? 0 : 1)] += value * v.weight;
    };
    const Scene& scene = *ts.scene;
    const ViewPointLobes lobes(ts, v, wavelengthNm);
    // The medium light crosses to reach the point from direction toLight, and what it keeps.
    auto kept = [&](const Vec3& toLight, double distanceMm) {
        const bool normalSide = glm::dot(toLight, v.normal) > 0.0;
        const int medium = normalSide == v.fromFront ? v.medium : v.otherMedium;
        const double alpha = ts.media->absorptionPerMm(medium, v.wavelength);
        return alpha > 0.0 ? std::exp(-alpha * distanceMm) : 1.0;
    };
    double sum = 0.0;
    // Light sampling: one direction per source, weighed by the balance heuristic against the
    // scatter sampling below (weight 1 for the delta kinds, which scatter sampling never hits).
    for (size_t si = 0; si < ts.sources.size(); ++si) {
        const Source& s = ts.sources[si];
        const double u1 = rng.uniform(), u2 = rng.uniform();
        const auto in = s.sampleIncident(v.positionMm, v.wavelength, u1, u2);
        if (!in) continue;
        const double fc = lobes.fluxCos(in->toSource);
        if (!(fc > 0.0)) continue;
        if (scene.closestHit({v.positionMm, in->toSource}, in->distanceMm, v.object, v.primitive))
            continue;  // blocked
        const double mis =
            in->pdfSr > 0.0 ? in->pdfSr / (in->pdfSr + lobes.pdf(in->toSource)) : 1.0;
        const double value = fc * in->value * kept(in->toSource, in->distanceMm) * mis;
        sum += value;
        book(si, in->toSource, value);
    }
    // Scatter sampling: one direction, checked against every source it reaches unblocked.
    const double u0 = rng.uniform(), u1 = rng.uniform(), u2 = rng.uniform();
    const auto sampled = lobes.sample(u0, u1, u2);
    const double pdf = sampled ? lobes.pdf(*sampled) : 0.0;
    const double fc = sampled ? lobes.fluxCos(*sampled) : 0.0;
    if (!(pdf > 0.0 && fc > 0.0)) return sum * v.weight;
    const Vec3 w = *sampled;
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
    return sum * v.weight;
}

std::vector<bool> followedLobes(const TransportView& ts, double belowRad) {
    std::vector<bool> out;
    for (const OpticalProperty& p : ts.properties)
        out.push_back(p.hasScatter() && lobeHalfWidthRad(p) < belowRad);
    return out;
}

std::vector<bool> splattedLobes(const TransportView& ts, double splatBelowRad,
                                double followBelowRad) {
    std::vector<bool> out;
    if (!(splatBelowRad > 0.0)) return out;
    const std::vector<bool> followed = followedLobes(ts, followBelowRad);
    for (size_t p = 0; p < ts.properties.size(); ++p)
        out.push_back(!followed[p] && ts.properties[p].hasScatter() &&
                      lobeHalfWidthRad(ts.properties[p]) < splatBelowRad);
    return out;
}

double lobeHalfWidthRad(const OpticalProperty& p) {
    return std::visit(
        [](const auto& m) -> double {
            using T = std::decay_t<decltype(m)>;
            if constexpr (std::is_same_v<T, GaussianScatter>) {
                return m.halfWidthDeg() * std::numbers::pi / 180.0;
            } else if constexpr (std::is_same_v<T, AbgScatter>) {
                // A / (B + r^g)^p halves at r = (2^(1/p) - 1)^(1/g) B^(1/g) (direction
                // cosines), the widest lobe of the two sides.
                double widest = 0.0;
                for (const bool transmit : {false, true})
                    for (const auto& lobe : m.lobes(transmit)) {
                        const AbgParams& q = lobe->params();
                        if (!(q.g > 0.0) || !(q.p > 0.0)) return std::numbers::pi / 2.0;
                        const double r = std::pow(std::pow(2.0, 1.0 / q.p) - 1.0, 1.0 / q.g) *
                                         std::pow(q.b, 1.0 / q.g);
                        widest = std::max(widest, std::asin(std::min(1.0, r)));
                    }
                return widest;
            } else {
                return std::numbers::pi / 2.0;
            }
        },
        p.scatter());
}

namespace {

// Narrow lobes followed along one backward path, at most (then the next one gathers).
constexpr int kMaxFollowedLobes = 4;

struct Branch {
    Ray ray;
    double weight = 0.0;
    int startObject = -1;
    int startPrimitive = -1;
    int medium = 0;
    int depth = 0;
    int node = 0;  // with criteria: its last event in the ray's EventTree
    int designed = DesignedPath::kOff;  // its step on the lens's designed path, from the detector
    int lobes = 0;          // narrow lobes followed between it and the detector (followLobe)
    bool leftLobe = false;  // its segment starts at a followed lobe: directAt counted its sources
    // Behind a followed lobe: the last lobe's point, object, the branch depth it left at and
    // the density per steradian of the direction drawn there (for the weight against the light
    // connected through the lens at that point: sourcesSeen).
    Vec3 lobePoint{0.0};
    int lobeObject = -1;
    int lobeDepth = 0;
    double lobePdf = 0.0;
};

// What one pixel ray brings back, by component.
struct RayLight {
    double visible = 0.0, direct = 0.0, caustic = 0.0, secondary = 0.0, image = 0.0;
};

// What the rays of one pixel produced, merged in pixel order afterwards.
struct PixelOutput {
    std::vector<double> visible;  // per ray, its visible-source flux
    std::vector<double> direct;   // per ray, its direct flux
    std::vector<double> imageForming;        // per ray, the part of `visible` on the designed path
    std::vector<double> caustic, secondary;  // per ray, through followed lobes
    std::vector<uint8_t> cell;    // per ray, its aperture cell (with a guide)
    static_assert(ApertureGuide::kCellCount <= 256, "a cell index must fit in uint8_t");
    std::vector<ViewPoint> viewPoints;
    std::vector<PathEvent> events;  // the view points' suffixes (firstEvent local to here)
    std::vector<double> visibleBy, directBy;  // [criterion]: the pixel's sums
    std::vector<double> causticBy, secondaryBy;
    uint64_t segments = 0;
    uint64_t connectionRays = 0;
    uint64_t pruned = 0;

    // As bytes, between ranks (tracer/runtime/ranks.h).
    void pack(ByteWriter& w) const {
        w.putVector(visible);
        w.putVector(direct);
        w.putVector(imageForming);
        w.putVector(caustic);
        w.putVector(secondary);
        w.putVector(cell);
        w.putVector(viewPoints);
        w.putVector(events);
        w.putVector(visibleBy);
        w.putVector(directBy);
        w.putVector(causticBy);
        w.putVector(secondaryBy);
        w.put(segments);
        w.put(connectionRays);
        w.put(pruned);
    }
    void unpack(ByteReader& r) {
        visible = r.getVector<double>();
        direct = r.getVector<double>();
        imageForming = r.getVector<double>();
        caustic = r.getVector<double>();
        secondary = r.getVector<double>();
        cell = r.getVector<uint8_t>();
        viewPoints = r.getVector<ViewPoint>();
        events = r.getVector<PathEvent>();
        visibleBy = r.getVector<double>();
        directBy = r.getVector<double>();
        causticBy = r.getVector<double>();
        secondaryBy = r.getVector<double>();
        segments = r.get<uint64_t>();
        connectionRays = r.get<uint64_t>();
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

// One pixel ray as traced: its sample of the aperture and the pixel, and what it carries.
struct PixelRaySample {
    CounterRng rng;
    int wavelength = 0;
    double wavelengthNm = 0.0;
    double start = 0.0;  // the importance it starts with
    uint32_t guideBin = 0;
};

// The rays of the pixels one thread traces: its scratch (branch stack, event tree, judge
// state) and the steps of a pixel ray.
class PixelTracer {
  public:
    PixelTracer(const TransportView& ts, const DetectorImage& detector,
                const ExitAperture& aperture, const BackwardOptions& options)
        : ts_(ts),
          detector_(detector),
          aperture_(aperture),
          o_(options),
          judge_(options.judge),
          prune_(options.judge && options.prune),
          detectorObject_(detector.geometry().object),
          state_(judge_ ? judge_->stateBytes() : 0),
          scratch_(judge_ ? judge_->stateBytes() : 0),
          perSourceSide_(2 * ts.sources.size()),
          designed_(*ts.scene) {
        followLobe_ = followedLobes(ts, options.followLobesBelowRad);
    }

    // Every ray of pixel p.
    void tracePixel(int p, PixelOutput& po);

  private:
    // Stratified pixel rays: the first m^2 rays take one cell each of an m x m grid over the
    // aperture disk's (equal-area) square and, in a shuffled order, one of another over the
    // pixel; the rest are independent. Each cell has the same measure, so the mean stays
    // unbiased; it varies less across the aperture view, where a pixel's light changes most.
    void shuffleStrata(int p, uint64_t m);
    // Ray k of pixel p: its uniforms (stratified, through the guide) and its pixel ray; false
    // when the ray carries nothing.
    bool sample(int p, uint64_t k, uint64_t m, PixelOutput& po, PixelRaySample& s,
                PixelRay& pr);
    // The ray's branches through the specular chain: the sources it sees and, at scattering
    // surfaces, view points with their direct light.
    void walk(int p, const PixelRay& pr, PixelRaySample& s, PixelOutput& po, RayLight& light);
    // Sources seen along a branch's segment (they block nothing), up to tHit, added to `seen`.
    void sourcesSeen(const Branch& br, double tHit, double alpha, const PixelRaySample& s,
                     PixelOutput& po, RayLight& light);
    // The weight of a source seen behind a followed lobe along `br` (its segment ending in the
    // source at x) against the light connected through the lens at the lobe's point: 1 unless
    // the connection there would have drawn the same path (multiple importance sampling, the
    // balance heuristic over the two densities of the direction at the lobe).
    double lobeWeight(const Branch& br, size_t source, const Vec3& x, const PixelRaySample& s,
                      PixelOutput& po) const;
    // A view point where the branch meets a scattering surface (view point roulette first),
    // and its direct light.
    void storeViewPoint(int p, const Branch& br, const SceneHit& hit, PixelRaySample& s,
                        PixelOutput& po, RayLight& light);
    // The view point a branch meets at hit, with weight `weight` (not stored).
    ViewPoint viewPointAt(int p, const Branch& br, const SceneHit& hit, const PixelRaySample& s,
                          double weight) const;
    // Next-event estimation at v, added to the direct light (or to the secondary light
    // behind a followed lobe: it has scattered twice).
    void directLight(const ViewPoint& v, const Branch& br, PixelRaySample& s, PixelOutput& po,
                     RayLight& light);
    // The light connected through the lens at v (BackwardOptions::connector), added to the
    // caustic light (secondary behind a followed lobe). At a followed lobe (`lobe` given) it
    // is weighed against the lobe's own sampled direction by multiple importance sampling;
    // at a view point it owns its chains' light outright (the photons leave it).
    void connectedLight(const ViewPoint& v, const Branch& br, PixelRaySample& s, PixelOutput& po,
                        RayLight& light, const ViewPointLobes* lobe = nullptr);
    // A narrow lobe (BackwardOptions::followLobesBelowRad): no view point; the direct light
    // there, then one direction drawn from the lobe, the branch going on along it.
    void followLobe(int p, const Branch& br, const SceneHit& hit, PixelRaySample& s,
                    PixelOutput& po, RayLight& light);
    // The specular children the walk continues with: every one (split) or one by weight.
    void pushChildren(const Branch& br, const SceneHit& hit, const Interaction& in,
                      double specular, PixelRaySample& s, PixelOutput& po);
    void push(const Branch& br, const SceneHit& hit, const InteractionChild& c, double weight,
              PixelOutput& po);
    // `next`, which leaves hit where `br` arrived, onto the stack, its event (of type e, in
    // light's order) in the event tree; unless no criterion can match it any more (prune).
    void pushWithEvent(Branch& next, const Branch& br, const SceneHit& hit, EventType e,
                       PixelOutput& po);
    // The criteria the path [Emit(source) chain head] + suffix matches.
    uint64_t judged(int source, int medium, const PathEvent* head,
                    std::span<const PathEvent> chain = {}) {
        judge_->reset(state_.data());
        judge_->push(state_.data(), pathEvent(EventType::Emit, source, 0, medium, medium));
        for (const PathEvent& e : chain) judge_->push(state_.data(), e);
        if (head) judge_->push(state_.data(), *head);
        return judge_->matches(state_.data(), suffix_, scratch_.data());
    }

    const TransportView& ts_;
    const DetectorImage& detector_;
    const ExitAperture& aperture_;
    const BackwardOptions& o_;
    const PathJudge* judge_;
    const bool prune_;
    const int detectorObject_;
    std::vector<Branch> stack_;
    EventTree tree_;
    std::vector<PathEvent> suffix_;
    std::vector<std::byte> state_, scratch_;
    std::vector<double> perSourceSide_;
    std::vector<PathEvent> chain_;  // a lens connection's events (with criteria)
    std::vector<uint64_t> strata_;
    const DesignedPath designed_;
    std::vector<bool> followLobe_;  // [property]: its lobe is followed, not gathered
};

void PixelTracer::tracePixel(int p, PixelOutput& po) {
    const uint64_t perPixel = o_.raysPerPixel;
    const size_t criteria = judge_ ? static_cast<size_t>(judge_->count()) : 0;
    po.visible.assign(perPixel, 0.0);
    po.direct.assign(perPixel, 0.0);
    po.imageForming.assign(perPixel, 0.0);
    po.caustic.assign(perPixel, 0.0);
    po.secondary.assign(perPixel, 0.0);
    if (o_.guide) po.cell.assign(perPixel, 0);
    po.visibleBy.assign(criteria, 0.0);
    po.directBy.assign(criteria, 0.0);
    po.causticBy.assign(criteria, 0.0);
    po.secondaryBy.assign(criteria, 0.0);
    const uint64_t m = static_cast<uint64_t>(std::sqrt(static_cast<double>(perPixel)));
    shuffleStrata(p, m);
    for (uint64_t k = 0; k < perPixel; ++k) {
        PixelRaySample s{CounterRng(o_.seed, static_cast<uint64_t>(p) * perPixel + k)};
        PixelRay pr;
        if (!sample(p, k, m, po, s, pr)) continue;
        RayLight light;
        walk(p, pr, s, po, light);
        po.visible[k] = light.visible;
        po.direct[k] = light.direct;
        po.imageForming[k] = light.image;
        po.caustic[k] = light.caustic;
        po.secondary[k] = light.secondary;
    }
}

void PixelTracer::shuffleStrata(int p, uint64_t m) {
    strata_.resize(m * m);
    for (uint64_t i = 0; i < m * m; ++i) strata_[i] = i;
    CounterRng shuffle(o_.seed ^ 0x5354524154554dull /* "STRATUM" */, static_cast<uint64_t>(p));
    for (uint64_t i = m * m; i > 1; --i)
        std::swap(strata_[i - 1],
                  strata_[std::min(i - 1, static_cast<uint64_t>(shuffle.uniform() * i))]);
}

bool PixelTracer::sample(int p, uint64_t k, uint64_t m, PixelOutput& po, PixelRaySample& s,
                         PixelRay& pr) {
    std::array<double, kPixelRayUniforms> uk;
    for (double& x : uk) x = s.rng.uniform();
    if (k < m * m) {
        const uint64_t st = strata_[k];
        uk[0] = (static_cast<double>(st % m) + uk[0]) / static_cast<double>(m);
        uk[1] = (static_cast<double>(st / m) + uk[1]) / static_cast<double>(m);
        uk[2] = (static_cast<double>(k % m) + uk[2]) / static_cast<double>(m);
        uk[3] = (static_cast<double>(k / m) + uk[3]) / static_cast<double>(m);
    }
    // The aperture point's uniforms (uk[2], uk[3]) through the guide.
    double density = 1.0;
    if (o_.guide) {
        const ApertureGuide::Warped g = o_.guide->warp(p, uk[2], uk[3]);
        uk[2] = g.u;
        uk[3] = g.v;
        density = g.density;
        po.cell[k] = static_cast<uint8_t>(g.cell);
        s.guideBin = static_cast<uint32_t>(o_.guide->bin(p, g.cell));
    }
    pr = samplePixelRay(detector_, p, aperture_, uk);
    const double u = s.rng.uniform();  // the wavelength
    if (!(pr.pdf > 0.0) || !(pr.importance > 0.0) || !(pr.cosPixel > 0.0)) return false;
    const MediaOptics& media = *ts_.media;
    const int wavelengths = media.wavelengthCount();
    s.wavelength = std::min(wavelengths - 1, static_cast<int>(u * wavelengths));
    s.wavelengthNm = media.wavelengthNm(s.wavelength);
    s.start = pr.importance * pr.cosPixel / (pr.pdf * density) /
              static_cast<double>(o_.raysPerPixel) * wavelengths;
    return true;
}

void PixelTracer::walk(int p, const PixelRay& pr, PixelRaySample& s, PixelOutput& po,
                       RayLight& light) {
    const int w = s.wavelength;
    stack_.clear();
    stack_.push_back({pr.ray, s.start, detectorObject_, -1, 0, 0, 0, designed_.steps()});
    if (judge_) tree_.start(pathEvent(EventType::DetectorHit, detectorObject_, 0, 0, 0));
    while (!stack_.empty()) {
        Branch br = stack_.back();
        stack_.pop_back();
        const auto hit = ts_.scene->closestHit(br.ray, kInfinity, br.startObject,
                                               br.startPrimitive, br.medium);
        const double tHit = hit ? hit->t : kInfinity;
        const double alpha = ts_.media->absorptionPerMm(br.medium, w);
        sourcesSeen(br, tHit, alpha, s, po, light);
        if (!hit) continue;
        ++po.segments;
        if (alpha > 0.0) br.weight *= std::exp(-alpha * hit->t);
        if (hit->object == detectorObject_ || ts_.detectorOfObject[hit->object] >= 0)
            continue;  // a detector absorbs
        const Interaction in = interact(ts_, *hit, br.ray.direction, w, s.wavelengthNm,
                                        TransportMode::Importance);
        bool scatters = false;
        double specular = 0.0;
        for (int c = 0; c < in.count; ++c) {
            scatters |= in.children[c].scatter;
            if (!in.children[c].scatter) specular += in.children[c].share;
        }
        if (scatters) {
            if (br.lobes < kMaxFollowedLobes &&
                followLobe_[static_cast<size_t>(ts_.propertyOfObject[hit->object])])
                followLobe(p, br, *hit, s, po, light);
            else
                storeViewPoint(p, br, *hit, s, po, light);
        }
        if (!(specular > 0.0) || br.depth >= o_.maxSpecularDepth) continue;
        pushChildren(br, *hit, in, specular, s, po);
    }
}

void PixelTracer::sourcesSeen(const Branch& br, double tHit, double alpha, const PixelRaySample& s,
                              PixelOutput& po, RayLight& light) {
    const int w = s.wavelength;
    // Behind a followed lobe every source counts (the photons count only the light of the sun
    // and the delta kinds that never scattered), except on the lobe's own segment, whose
    // sources the lobe's next-event estimation counted (by MIS with this very direction).
    if (br.leftLobe) return;
    const bool designed = designed_.completeBackward(br.designed);
    double& seen = br.lobes == 0 ? light.visible : br.lobes == 1 ? light.caustic : light.secondary;
    std::vector<double>& seenBy = br.lobes == 0   ? po.visibleBy
                                  : br.lobes == 1 ? po.causticBy
                                                  : po.secondaryBy;
    for (size_t si = 0; si < ts_.sources.size(); ++si) {
        if (br.lobes == 0 && !o_.visibleSources.empty() && !o_.visibleSources[si]) continue;
        const Source& src = ts_.sources[si];
        const auto t = src.crossing(br.ray, tHit);
        if (!t) continue;
        const Vec3 x = br.ray.origin + *t * br.ray.direction;
        const double radiance = src.emitted(x, -br.ray.direction, w);
        if (!(radiance > 0.0)) continue;
        const double value = br.weight * (alpha > 0.0 ? std::exp(-alpha * *t) : 1.0) * radiance *
                             lobeWeight(br, si, x, s, po);
        if (!judge_) {
            seen += value;
            if (designed) light.image += value;
            continue;
        }
        suffix_.clear();
        tree_.suffix(br.node, suffix_);
        const double kept =
            bookByCriteria(judged(static_cast<int>(si), br.medium, nullptr), prune_, value, seenBy);
        seen += kept;
        if (designed) light.image += kept;
    }
}

double PixelTracer::lobeWeight(const Branch& br, size_t source, const Vec3& x,
                               const PixelRaySample& s, PixelOutput& po) const {
    const LensConnector* lc = o_.connector;
    if (!lc || br.lobeObject < 0 || !(br.lobePdf > 0.0)) return 1.0;
    // The designed crossings since the lobe: one per specular event after its segment.
    const int steps = br.depth - br.lobeDepth;
    if (!lc->hasChain(source, br.lobeObject, steps)) return 1.0;
    LensConnector::Work work;
    const auto c = lc->found(source, s.wavelength, s.wavelengthNm, steps, br.lobePoint,
                             br.lobeObject, Ray{x, -br.ray.direction}, work);
    po.segments += work.rays;
    po.connectionRays += work.rays;
    if (!c) return 1.0;
    return br.lobePdf / (br.lobePdf + c->pdfSr);
}

ViewPoint PixelTracer::viewPointAt(int p, const Branch& br, const SceneHit& hit,
                                   const PixelRaySample& s, double weight) const {
    ViewPoint v;
    v.positionMm = hit.point;
    v.normal = hit.normal;
    v.toDetector = -br.ray.direction;
    v.object = hit.object;
    v.primitive = hit.primitive;
    v.pixel = p;
    v.wavelength = s.wavelength;
    v.medium = hit.mediumFrom;
    v.otherMedium = hit.mediumTo;
    v.fromFront = hit.fromFront;
    v.weight = weight;
    v.guideBin = s.guideBin;
    v.behindScatter = br.lobes > 0;
    return v;
}

void PixelTracer::directLight(const ViewPoint& v, const Branch& br, PixelRaySample& s,
                              PixelOutput& po, RayLight& light) {
    if (!o_.direct) return;
    double& into = br.lobes == 0 ? light.direct : light.secondary;
    if (!judge_) {
        into += directAt(ts_, v, s.wavelengthNm, s.rng);
        return;
    }
    std::vector<double>& by = br.lobes == 0 ? po.directBy : po.secondaryBy;
    std::fill(perSourceSide_.begin(), perSourceSide_.end(), 0.0);
    directAt(ts_, v, s.wavelengthNm, s.rng, perSourceSide_);
    for (size_t k = 0; k < perSourceSide_.size(); ++k) {
        if (perSourceSide_[k] == 0.0) continue;
        // The light's own scatter event: from its side of the surface.
        const bool crosses = k % 2 == 1;
        const PathEvent scatter =
            pathEvent(crosses ? EventType::ScatterTransmit : EventType::ScatterReflect, v.object,
                      v.primitive, crosses ? v.otherMedium : v.medium, v.medium);
        suffix_.clear();
        tree_.suffix(br.node, suffix_);
        into += bookByCriteria(judged(static_cast<int>(k / 2), scatter.mediumBefore, &scatter),
                               prune_, perSourceSide_[k], by);
    }
}

void PixelTracer::storeViewPoint(int p, const Branch& br, const SceneHit& hit, PixelRaySample& s,
                                 PixelOutput& po, RayLight& light) {
    bool store = true;
    double vpWeight = br.weight;
    if (o_.viewPointRelativeWeight > 0.0) {
        const double floor = o_.viewPointRelativeWeight * s.start;
        const double u = s.rng.uniform();  // drawn at every scattering hit
        if (vpWeight < floor) {
            store = u * floor < vpWeight;
            vpWeight = floor;
        }
    }
    if (!store) return;
    ViewPoint v = viewPointAt(p, br, hit, s, vpWeight);
    if (judge_) {
        v.firstEvent = static_cast<uint32_t>(po.events.size());
        suffix_.clear();
        tree_.suffix(br.node, suffix_);
        v.eventCount = static_cast<uint32_t>(suffix_.size());
        po.events.insert(po.events.end(), suffix_.begin(), suffix_.end());
    }
    directLight(v, br, s, po, light);
    connectedLight(v, br, s, po, light);
    po.viewPoints.push_back(v);
}

void PixelTracer::connectedLight(const ViewPoint& v, const Branch& br, PixelRaySample& s,
                                 PixelOutput& po, RayLight& light, const ViewPointLobes* lobe) {
    const LensConnector* lc = o_.connector;
    if (!lc || !lc->any()) return;
    double& into = br.lobes == 0 ? light.caustic : light.secondary;
    std::vector<double>& by = br.lobes == 0 ? po.causticBy : po.secondaryBy;
    std::optional<ViewPointLobes> lobes;
    for (size_t si = 0; si < ts_.sources.size(); ++si) {
        // The designed chains, then (but at a followed lobe, whose own sampled direction
        // weighs only the designed chains against its light) the ghost routes'.
        const uint64_t designed = lc->chains(si, v.object);
        const std::vector<int>& ghosts = lc->ghostChains(si, v.object);
        const size_t count =
            static_cast<size_t>(std::popcount(designed)) + (lobe ? 0 : ghosts.size());
        uint64_t bits = designed;
        for (size_t chain = 0; chain < count; ++chain) {
            int steps = 0;
            if (bits != 0) {
                steps = std::countr_zero(bits) + 1;
                bits &= bits - 1;
            } else {
                steps = ghosts[chain - static_cast<size_t>(std::popcount(designed))];
            }
            // Two uniforms per chain, drawn whether or not it reaches the point.
            const double u1 = s.rng.uniform(), u2 = s.rng.uniform();
            // Light the parts traced to the sensor own (not behind or at a followed lobe).
            if (o_.parts && !lobe && br.lobes == 0 &&
                o_.parts->owns(si, v.object, steps, br.designed))
                continue;
            LensConnector::Work work;
            const auto c = lc->connect(si, v.wavelength, s.wavelengthNm, steps, v.positionMm,
                                       v.object, u1, u2, work, judge_ ? &chain_ : nullptr);
            po.segments += work.rays;
            po.connectionRays += work.rays;
            if (!c) continue;
            if (!lobe && !lobes) lobes.emplace(ts_, v, s.wavelengthNm);
            const ViewPointLobes& at = lobe ? *lobe : *lobes;
            const double fc = at.fluxCos(c->toLight);
            if (!(fc > 0.0)) continue;
            double value = fc * c->value * v.weight;
            // At a followed lobe the lobe's sampled direction can reach the source through the
            // same chain (sourcesSeen, lobeWeight): the balance heuristic.
            if (lobe && c->pdfSr > 0.0) value *= c->pdfSr / (c->pdfSr + lobe->pdf(c->toLight));
            if (!judge_) {
                into += value;
                continue;
            }
            // The light's own scatter event, from its side of the surface.
            const bool crosses =
                glm::dot(c->toLight, v.normal) * glm::dot(v.toDetector, v.normal) < 0.0;
            const PathEvent scatter =
                pathEvent(crosses ? EventType::ScatterTransmit : EventType::ScatterReflect,
                          v.object, v.primitive, crosses ? v.otherMedium : v.medium, v.medium);
            suffix_.clear();
            tree_.suffix(br.node, suffix_);
            into += bookByCriteria(judged(static_cast<int>(si), 0, &scatter, chain_), prune_, value,
                                   by);
        }
    }
}

void PixelTracer::followLobe(int p, const Branch& br, const SceneHit& hit, PixelRaySample& s,
                             PixelOutput& po, RayLight& light) {
    const ViewPoint v = viewPointAt(p, br, hit, s, br.weight);
    directLight(v, br, s, po, light);
    const ViewPointLobes lobes(ts_, v, s.wavelengthNm);
    connectedLight(v, br, s, po, light, &lobes);
    // One direction from the scatter lobes as seen from the detector's side, weighted by
    // f cos / pdf of the light that arrives along it and leaves toward the detector.
    const double u0 = s.rng.uniform(), u1 = s.rng.uniform(), u2 = s.rng.uniform();
    const auto sampled = lobes.sample(u0, u1, u2);
    if (!sampled) return;
    const Vec3 w = *sampled;
    const bool wTransmits = glm::dot(w, lobes.walk().normal) < 0.0;
    const double pdf = lobes.pdf(w);
    if (!(pdf > 0.0)) return;
    const double f = lobes.fluxCos(w);
    if (!(f > 0.0)) return;
    Branch next;
    next.ray = {hit.point, w};
    next.weight = br.weight * f / pdf;
    next.startObject = hit.object;
    next.startPrimitive = hit.primitive;
    next.medium = wTransmits ? hit.mediumTo : hit.mediumFrom;
    next.depth = br.depth + 1;
    next.designed = DesignedPath::kOff;
    next.lobes = br.lobes + 1;
    next.leftLobe = true;
    next.lobePoint = hit.point;
    next.lobeObject = hit.object;
    next.lobeDepth = next.depth;
    next.lobePdf = pdf;
    // Forward, the light arrives from w's side and leaves toward the detector.
    pushWithEvent(next, br, hit,
                  wTransmits ? EventType::ScatterTransmit : EventType::ScatterReflect, po);
}

void PixelTracer::push(const Branch& br, const SceneHit& hit, const InteractionChild& c,
                       double weight, PixelOutput& po) {
    Branch next;
    next.ray = {hit.point, c.direction};
    next.weight = weight;
    next.startObject = hit.object;
    next.startPrimitive = hit.primitive;
    next.medium = c.medium;
    next.depth = br.depth + 1;
    next.designed = designed_.backward(br.designed, hit.object, c.event);
    next.lobes = br.lobes;
    next.lobePoint = br.lobePoint;
    next.lobeObject = br.lobeObject;
    next.lobeDepth = br.lobeDepth;
    next.lobePdf = br.lobePdf;
    pushWithEvent(next, br, hit, c.event, po);
}

void PixelTracer::pushWithEvent(Branch& next, const Branch& br, const SceneHit& hit, EventType e,
                                PixelOutput& po) {
    if (judge_) {
        // Forward, light comes from the new branch's side and leaves into ours.
        next.node =
            tree_.add(pathEvent(e, hit.object, hit.primitive, next.medium, br.medium), br.node);
        if (prune_) {
            suffix_.clear();
            tree_.suffix(next.node, suffix_);
            if (judge_->suffixMayMatch(suffix_) == 0) {
                ++po.pruned;
                return;
            }
        }
    }
    stack_.push_back(next);
}

void PixelTracer::pushChildren(const Branch& br, const SceneHit& hit, const Interaction& in,
                               double specular, PixelRaySample& s, PixelOutput& po) {
    if (o_.split) {
        for (int c = 0; c < in.count; ++c) {
            const InteractionChild& child = in.children[c];
            if (child.scatter || !(child.share > 0.0)) continue;
            const double weight = br.weight * child.share;
            if (weight < o_.minRelativeWeight * s.start) continue;
            push(br, hit, child, weight, po);
        }
        return;
    }
    // One specular child, chosen by weight, carries their sum.
    const double x = s.rng.uniform() * specular;
    double sum = 0.0;
    int chosen = -1;
    for (int c = 0; c < in.count; ++c) {
        if (in.children[c].scatter) continue;
        chosen = c;
        sum += in.children[c].share;
        if (x < sum) break;
    }
    push(br, hit, in.children[chosen], br.weight * specular, po);
}

// Blocks of 64 pixels; across ranks, block b on rank b mod K (local block j is j K + rank).
constexpr int kPixelBlock = 64;

// Every rank's pixels of a range of `count` (out[i] its i-th, blocks of kPixelBlock counted
// from its first) to every rank: the photons of each need all view points.
void sharePixels(const Ranks& ranks, int count, std::vector<PixelOutput>& out) {
    const int blocks = (count + kPixelBlock - 1) / kPixelBlock;
    ByteWriter w;
    for (int b = ranks.rank(); b < blocks; b += ranks.size())
        for (int i = b * kPixelBlock; i < std::min(count, (b + 1) * kPixelBlock); ++i)
            out[static_cast<size_t>(i)].pack(w);
    const std::vector<Bytes> all = ranks.gatherAll(w.take());
    for (int q = 0; q < ranks.size(); ++q) {
        if (q == ranks.rank()) continue;
        ByteReader in(all[static_cast<size_t>(q)]);
        for (int b = q; b < blocks; b += ranks.size())
            for (int i = b * kPixelBlock; i < std::min(count, (b + 1) * kPixelBlock); ++i)
                out[static_cast<size_t>(i)].unpack(in);
        if (!in.done()) throw std::runtime_error("the pixels of another rank are damaged");
    }
}

// The view points of one pixel into the result, their identical suffixes (the same specular
// path to the detector) stored once, so the photon pass judges each once per gathering hit
// (tracer/render/photon_pass.cpp).
void internViewPoints(PixelOutput& po, BackwardResult& result,
                      std::unordered_map<uint64_t, std::vector<uint32_t>>& interned) {
    for (ViewPoint& v : po.viewPoints) {
        const auto first = po.events.begin() + v.firstEvent;
        const auto last = first + v.eventCount;
        uint64_t h = 1469598103934665603ull ^ v.eventCount;
        for (auto e = first; e != last; ++e) {
            const uint64_t parts[] = {uint64_t(e->type), uint64_t(uint32_t(e->object)),
                                      uint64_t(uint32_t(e->face)),
                                      uint64_t(uint16_t(e->mediumBefore)),
                                      uint64_t(uint16_t(e->mediumAfter))};
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
}

// The images a pass's pixels add to, empty.
void startResult(const DetectorImage& detector, const BackwardOptions& options,
                 BackwardResult& result) {
    const int pixels = detector.pixelCount();
    const size_t criteria = options.judge ? static_cast<size_t>(options.judge->count()) : 0;
    result = BackwardResult{};
    result.visible = DetectorImage(detector.geometry());
    result.direct = DetectorImage(detector.geometry());
    result.imageForming = DetectorImage(detector.geometry());
    result.caustic = DetectorImage(detector.geometry());
    result.secondary = DetectorImage(detector.geometry());
    result.visibleByCriterion.assign(criteria, std::vector<double>(static_cast<size_t>(pixels)));
    result.directByCriterion.assign(criteria, std::vector<double>(static_cast<size_t>(pixels)));
    result.causticByCriterion.assign(criteria, std::vector<double>(static_cast<size_t>(pixels)));
    result.secondaryByCriterion.assign(criteria, std::vector<double>(static_cast<size_t>(pixels)));
    if (options.guide) result.learned.assign(options.guide->bins(), 0.0);
}

// The outputs of pixels [first, first + out.size()) merged in pixel order into `result`, whose
// view points and events become theirs.
void mergePixels(const BackwardOptions& options, int first, std::vector<PixelOutput>& out,
                 BackwardResult& result) {
    const uint64_t perPixel = options.raysPerPixel;
    const size_t criteria = options.judge ? static_cast<size_t>(options.judge->count()) : 0;
    result.viewPoints.clear();
    result.events.clear();
    std::unordered_map<uint64_t, std::vector<uint32_t>> interned;  // suffix hash -> offsets
    for (size_t i = 0; i < out.size(); ++i) {
        const int p = first + static_cast<int>(i);
        PixelOutput& po = out[i];
        if (options.guide)
            for (uint64_t k = 0; k < perPixel; ++k)
                result.learned[options.guide->bin(p, po.cell[k])] +=
                    po.visible[k] + po.direct[k] + po.caustic[k] + po.secondary[k];
        for (uint64_t k = 0; k < perPixel; ++k) {
            const double c = std::max(
                po.visible[k] + po.direct[k] + po.caustic[k] + po.secondary[k] - po.imageForming[k],
                0.0);
            result.raySum += c;
            result.raySquares += c * c;
        }
        for (double v : po.visible)
            if (v != 0.0) result.visible.add(p, v);
        for (double v : po.direct)
            if (v != 0.0) result.direct.add(p, v);
        for (double v : po.imageForming)
            if (v != 0.0) result.imageForming.add(p, v);
        for (double v : po.caustic)
            if (v != 0.0) result.caustic.add(p, v);
        for (double v : po.secondary)
            if (v != 0.0) result.secondary.add(p, v);
        internViewPoints(po, result, interned);
        for (size_t k = 0; k < criteria; ++k) {
            result.visibleByCriterion[k][static_cast<size_t>(p)] = po.visibleBy[k];
            result.directByCriterion[k][static_cast<size_t>(p)] = po.directBy[k];
            result.causticByCriterion[k][static_cast<size_t>(p)] = po.causticBy[k];
            result.secondaryByCriterion[k][static_cast<size_t>(p)] = po.secondaryBy[k];
        }
        result.segments += po.segments;
        result.connectionRays += po.connectionRays;
        result.prunedBranches += po.pruned;
    }
    result.rays += static_cast<uint64_t>(out.size()) * perPixel;
}

}  // namespace

BackwardResult traceBackward(const TransportView& ts, const DetectorImage& detector,
                             const ExitAperture& aperture, const BackwardOptions& options) {
    BackwardResult result;
    traceBackward(ts, detector, aperture, options, 0, detector.pixelCount(), result);
    return result;
}

void traceBackward(const TransportView& ts, const DetectorImage& detector,
                   const ExitAperture& aperture, const BackwardOptions& options, int firstPixel,
                   int endPixel, BackwardResult& into) {
    if (options.raysPerPixel == 0)
        throw std::invalid_argument("traceBackward: raysPerPixel must be at least 1");
    if (!(aperture.radiusMm > 0.0))
        throw std::invalid_argument("traceBackward: the exit aperture has no area");
    if (firstPixel < 0 || endPixel < firstPixel || endPixel > detector.pixelCount())
        throw std::invalid_argument("traceBackward: pixels [" + std::to_string(firstPixel) + ", " +
                                    std::to_string(endPixel) + ") outside the detector's " +
                                    std::to_string(detector.pixelCount()));
    if (firstPixel == 0) startResult(detector, options, into);
    const int count = endPixel - firstPixel;
    std::vector<PixelOutput> out(static_cast<size_t>(count));
    const Ranks& ranks = options.ranks;
    const int blocks = (count + kPixelBlock - 1) / kPixelBlock;
    const int myBlocks = static_cast<int>(ranks.ownedCount(static_cast<uint64_t>(blocks)));
    tbb::parallel_for(tbb::blocked_range<int>(0, myBlocks, 1), [&](const tbb::blocked_range<int>& r) {
        PixelTracer tracer(ts, detector, aperture, options);
        for (int j = r.begin(); j != r.end(); ++j) {
            options.deadline.check();
            const int b = j * ranks.size() + ranks.rank();
            for (int i = b * kPixelBlock; i < std::min(count, (b + 1) * kPixelBlock); ++i)
                tracer.tracePixel(firstPixel + i, out[static_cast<size_t>(i)]);
        }
    });
    if (!ranks.single()) sharePixels(ranks, count, out);
    mergePixels(options, firstPixel, out, into);
}

}  // namespace veil
