#include "analysis/pictures/path_picture.h"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <iomanip>
#include <map>
#include <mutex>
#include <sstream>

#include "analysis/criteria/criterion_names.h"
#include "analysis/reports/image_output.h"  // falseColour
#include "tracer/records/detector.h"
#include "tracer/records/path_history.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/transport/interaction.h"

namespace veil {

// Names
std::ostream& operator<<(std::ostream& os, const SelectedPath& p) {
    os << "SelectedPath{ray " << p.ray << ", leaf " << p.leaf << ", " << p.segmentCount()
       << " segments:";
    for (const PathEvent& e : p.events) os << " " << e.type << "@" << e.object;
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const PathSelection& s) {
    return os << "PathSelection{\"" << s.criterion << "\", " << s.rays.size() << " of "
              << s.requested << " rays kept (" << s.pathCount() << " paths), " << s.pathsMatched
              << " of " << s.pathsEvaluated << " paths matched in " << s.raysTraced << " rays}";
}

std::ostream& operator<<(std::ostream& os, PathColouring c) {
    return os << (c == PathColouring::LogFlux ? "log_flux" : "event_type");
}

// Selection
SelectedPath SelectedRay::path(size_t k) const {
    SelectedPath p;
    p.ray = ray;
    p.leaf = leafNodes.at(k);
    std::vector<int> chain;
    for (int n = leaves.at(k); n >= 0; n = parent[n]) chain.push_back(n);
    for (auto it = chain.rbegin(); it != chain.rend(); ++it) {
        p.points.push_back(points[*it]);
        p.flux.push_back(flux[*it]);
        p.events.push_back(events[*it]);
    }
    return p;
}

size_t PathSelection::pathCount() const {
    size_t n = 0;
    for (const SelectedRay& r : rays) n += r.leaves.size();
    return n;
}

std::vector<SelectedPath> PathSelection::paths() const {
    std::vector<SelectedPath> out;
    for (const SelectedRay& r : rays)
        for (size_t k = 0; k < r.leaves.size(); ++k) out.push_back(r.path(k));
    return out;
}

namespace {

// The first `count` rays with a match seen so far, by ray index.
class FirstRays {
  public:
    explicit FirstRays(size_t count) : count_(count) {}

    // Whether ray `ray` could still be among the first (cheap pre-check; add() decides).
    bool wanted(uint64_t ray) {
        std::lock_guard lock(mutex_);
        return byRay_.size() < count_ || ray < byRay_.rbegin()->first;
    }
    void add(SelectedRay&& r) {
        std::lock_guard lock(mutex_);
        if (byRay_.size() >= count_ && r.ray > byRay_.rbegin()->first) return;
        const uint64_t key = r.ray;
        byRay_[key] = std::move(r);
        if (byRay_.size() > count_) byRay_.erase(std::prev(byRay_.end()));
    }
    size_t stored() {
        std::lock_guard lock(mutex_);
        return byRay_.size();
    }
    std::vector<SelectedRay> take() {
        std::vector<SelectedRay> out;
        for (auto& [ray, r] : byRay_) out.push_back(std::move(r));
        return out;
    }

  private:
    size_t count_;
    std::map<uint64_t, SelectedRay> byRay_;
    std::mutex mutex_;
};

}  // namespace

PathSelection selectPaths(const TransportView& ts, const std::vector<DetectorImage>& detectors,
                          const PathSelectionOptions& options) {
    const CompiledCriterion compiled =
        compileCriterion(options.where, criterionNames(*ts.scene, ts), options.whereSource);
    PathSelection result;
    result.criterion = options.where;
    result.requested = options.count;
    if (!ts.sources.empty()) result.fluxUnit = unitSymbol(ts.sources.front().unit());
    if (options.count == 0 || ts.sources.empty()) return result;

    const uint64_t sources = ts.sources.size();
    const uint64_t batch = std::max<uint64_t>(1, options.batchRays);
    FirstRays first(options.count);
    std::atomic<uint64_t> evaluated{0}, matched{0};
    tbb::enumerable_thread_specific<StreamingEvaluator> evaluators(
        [&] { return StreamingEvaluator(compiled); });

    for (uint64_t b = 0; result.raysTraced < options.maxRays; ++b) {
        const uint64_t left = options.maxRays - result.raysTraced;
        const uint64_t perSource = std::max<uint64_t>(1, std::min(batch, left / sources));
        const uint64_t offset = result.raysTraced;
        TransportOptions to = options.transport;
        to.recordHistories = true;
        to.seed = options.transport.seed + b;
        RayCallback onRay = [&](uint64_t i, const PathHistory& h) {
            const uint64_t ray = offset + i;
            StreamingEvaluator& ev = evaluators.local();
            SelectedRay kept;
            kept.ray = ray;
            std::vector<int> local;  // history node -> kept node, -1 = not kept yet
            uint64_t paths = 0, hits = 0;
            const bool wanted = first.wanted(ray);
            h.forEachPath([&](const PathView& p) {
                ++paths;
                ev.reset();
                for (size_t k = 0; k < p.size() && !ev.decided(); ++k) ev.push(p.event(k));
                if (ev.finish() != CriterionState::True) return;
                ++hits;
                if (!wanted) return;
                if (local.empty()) local.assign(h.nodes().size(), -1);
                int parent = -1;
                for (size_t k = 0; k < p.size(); ++k) {
                    const NodeIndex n = p.node(k);
                    if (local[n] < 0) {
                        const PathNode& node = h.node(n);
                        local[n] = static_cast<int>(kept.points.size());
                        kept.points.push_back(node.position);
                        kept.flux.push_back(node.flux);
                        kept.events.push_back(p.event(k));
                        kept.parent.push_back(parent);
                    }
                    parent = local[n];
                }
                kept.leaves.push_back(parent);
                kept.leafNodes.push_back(p.leaf());
            });
            evaluated += paths;
            matched += hits;
            if (!kept.leaves.empty()) first.add(std::move(kept));
        };
        // Progress within the batch too: a batch of rays with histories can take seconds.
        std::function<void(uint64_t)> within;
        if (options.progress)
            within = [&](uint64_t done) {
                options.progress({options.task, offset + done, options.maxRays});
            };
        traceNonsequential(ts, detectors, perSource, to, within, onRay);
        result.raysTraced += perSource * sources;
        if (options.progress) options.progress({options.task, result.raysTraced, options.maxRays});
        if (first.stored() >= options.count) break;
    }
    result.rays = first.take();
    result.pathsEvaluated = evaluated;
    result.pathsMatched = matched;
    return result;
}

// Pictures
Color eventColour(EventType t) {
    switch (t) {
        case EventType::Refract:
            return Color::hex(0x1f5fd0);
        case EventType::SpecularReflect:
        case EventType::FresnelReflect:
            return Color::hex(0xd62020);
        case EventType::TotalInternalReflection:
            return Color::hex(0xff8c00);
        case EventType::ScatterReflect:
        case EventType::ScatterTransmit:
            return Color::hex(0x1a9e2a);
        case EventType::DetectorHit:
            return Color::hex(0x000000);
        default:
            return Color::hex(0x909090);  // emit, absorb, exit, culled
    }
}

const std::vector<std::pair<const char*, EventType>>& eventLegend() {
    static const std::vector<std::pair<const char*, EventType>> keys = {
        {"refract", EventType::Refract},
        {"reflect (Fresnel, specular)", EventType::FresnelReflect},
        {"TIR", EventType::TotalInternalReflection},
        {"scatter", EventType::ScatterReflect},
        {"absorb / exit", EventType::Exit},
        {"detector", EventType::DetectorHit}};
    return keys;
}

double maxSegmentFlux(const PathSelection& selection) {
    double maxFlux = 0.0;
    for (const SelectedRay& r : selection.rays)
        for (size_t k = 1; k < r.flux.size(); ++k) maxFlux = std::max(maxFlux, r.flux[k]);
    return maxFlux;
}

Color segmentFluxColour(double flux, double maxFlux, double decades) {
    if (!(flux > 0.0) || !(maxFlux > 0.0)) return falseColour(0.0);
    return falseColour(1.0 + std::log10(flux / maxFlux) / decades);
}

Picture drawPaths(const Picture& base, const PathSelection& selection,
                  const PathPictureOptions& options) {
    Picture pic = base;
    const double maxFlux = maxSegmentFlux(selection);
    const double decades = std::max(options.decades, 1e-3);
    // Weak segments first so the strong ones stay on top.
    struct Line {
        Vec2 a, b;
        double flux;
        EventType event;
    };
    const std::array<double, 4> frame =
        options.clipZY ? *options.clipZY
                       : std::array<double, 4>{base.zMin(), base.zMax(), base.yMin(), base.yMax()};
    std::vector<Line> lines;
    for (const SelectedRay& r : selection.rays) {
        for (size_t k = 1; k < r.points.size(); ++k) {
            const Vec3& from = r.points[r.parent[k]];
            Vec2 a(from.z, from.y), b(r.points[k].z, r.points[k].y);
            if (!clipSegment(a, b, frame[0], frame[1], frame[2], frame[3])) continue;
            lines.push_back({a, b, r.flux[k], r.events[k].type});
        }
    }
    if (options.colouring == PathColouring::LogFlux)
        std::stable_sort(lines.begin(), lines.end(),
                         [](const Line& x, const Line& y) { return x.flux < y.flux; });
    for (const Line& l : lines) {
        const Color c = options.colouring == PathColouring::LogFlux
                            ? segmentFluxColour(l.flux, maxFlux, decades)
                            : eventColour(l.event);
        pic.polyline({l.a, l.b}, c, options.lineWidthPt);
    }

    // Legend, in output points below the title (pages are 1000 pt wide).
    const double x = pic.marginPt, y = 42.0;
    std::ostringstream head;
    const size_t paths = selection.pathCount();
    head << selection.criterion << "   (first " << selection.rays.size() << " ray"
         << (selection.rays.size() == 1 ? "" : "s") << " of " << selection.raysTraced
         << " traced, with " << paths << " matching path" << (paths == 1 ? "" : "s") << ")";
    pic.overlayText(x, y, head.str(), Color::hex(0x000000), 11.0);
    const double ky = y + 16.0;
    if (options.colouring == PathColouring::EventType) {
        double kx = x;
        for (const auto& [label, t] : eventLegend()) {
            pic.overlayLine(kx, ky - 3.5, kx + 18.0, ky - 3.5, eventColour(t), 2.0);
            pic.overlayText(kx + 22.0, ky, label, Color::hex(0x000000), 10.0);
            kx += 22.0 + Picture::textWidthPt(label, 10.0) + 16.0;
        }
    } else {
        // Colour bar from max 10^-decades (left) to max (right), its ends in the unit.
        const int steps = 60;
        const double w = 180.0;
        const std::string unit = selection.fluxUnit;
        const std::string what = "segment flux, " + unit + " per traced ray (log):";
        pic.overlayText(x, ky, what, Color::hex(0x000000), 10.0);
        auto number = [&](double v) {
            std::ostringstream os;
            os << std::scientific << std::setprecision(1) << v << " " << unit;
            return os.str();
        };
        const std::string lo = number(maxFlux * std::pow(10.0, -decades));
        double bx = x + Picture::textWidthPt(what, 10.0) + 10.0;
        pic.overlayText(bx, ky, lo, Color::hex(0x000000), 10.0);
        bx += Picture::textWidthPt(lo, 10.0) + 6.0;
        for (int i = 0; i < steps; ++i)
            pic.overlayRect(bx + w * i / steps, ky - 8.0, w / steps + 0.3, 9.0,
                            falseColour((i + 0.5) / steps));
        pic.overlayText(bx + w + 6.0, ky, number(maxFlux), Color::hex(0x000000), 10.0);
    }
    return pic;
}

}  // namespace veil
