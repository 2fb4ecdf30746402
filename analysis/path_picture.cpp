#include "analysis/path_picture.h"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <iomanip>
#include <map>
#include <mutex>
#include <sstream>

#include "analysis/criterion_names.h"
#include "analysis/image_output.h"  // falseColour
#include "tracer/trace_setup.h"

namespace veil {

// Names
std::ostream& operator<<(std::ostream& os, const SelectedPath& p) {
    os << "SelectedPath{ray " << p.ray << ", leaf " << p.leaf << ", " << p.segmentCount()
       << " segments:";
    for (const PathEvent& e : p.events) os << " " << e.type << "@" << e.object;
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const PathSelection& s) {
    return os << "PathSelection{\"" << s.criterion << "\", " << s.paths.size() << " of "
              << s.requested << " paths kept, " << s.pathsMatched << " of " << s.pathsEvaluated
              << " paths matched in " << s.raysTraced << " rays}";
}

std::ostream& operator<<(std::ostream& os, PathColouring c) {
    return os << (c == PathColouring::LogFlux ? "log_flux" : "event_type");
}

// Selection
namespace {

// The matches of all rays seen so far that can still be among the first `count`: the map is
// trimmed so that removing its last ray would leave fewer than `count` paths.
class FirstMatches {
  public:
    explicit FirstMatches(size_t count) : count_(count) {}

    // Whether ray `ray` could still contribute (cheap pre-check; add() decides for real).
    bool wanted(uint64_t ray) {
        std::lock_guard lock(mutex_);
        return stored_ < count_ || byRay_.empty() || ray < byRay_.rbegin()->first;
    }
    void add(uint64_t ray, std::vector<SelectedPath>&& paths) {
        if (paths.empty()) return;
        std::lock_guard lock(mutex_);
        if (stored_ >= count_ && !byRay_.empty() && ray > byRay_.rbegin()->first) return;
        stored_ += paths.size();
        byRay_[ray] = std::move(paths);
        while (!byRay_.empty()) {
            const size_t last = byRay_.rbegin()->second.size();
            if (stored_ - last < count_) break;
            stored_ -= last;
            byRay_.erase(std::prev(byRay_.end()));
        }
    }
    size_t stored() const { return stored_; }
    // Ray order, then leaf order (paths of one ray are added in increasing leaf order).
    std::vector<SelectedPath> take() {
        std::vector<SelectedPath> out;
        for (auto& [ray, paths] : byRay_)
            for (SelectedPath& p : paths)
                if (out.size() < count_) out.push_back(std::move(p));
        return out;
    }

  private:
    size_t count_;
    size_t stored_ = 0;
    std::map<uint64_t, std::vector<SelectedPath>> byRay_;
    std::mutex mutex_;
};

}  // namespace

PathSelection selectPaths(const TransportScene& ts, const std::vector<DetectorImage>& detectors,
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
    FirstMatches first(options.count);
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
            std::vector<SelectedPath> found;
            uint64_t paths = 0, hits = 0;
            h.forEachPath([&](const PathView& p) {
                ++paths;
                ev.reset();
                for (size_t k = 0; k < p.size() && !ev.decided(); ++k) ev.push(p.event(k));
                if (ev.finish() != CriterionState::True) return;
                ++hits;
                SelectedPath s;
                s.ray = ray;
                s.leaf = p.leaf();
                for (size_t k = 0; k < p.size(); ++k) {
                    const PathNode& n = h.node(p.node(k));
                    s.points.push_back(n.position);
                    s.flux.push_back(n.flux);
                    s.events.push_back(p.event(k));
                }
                found.push_back(std::move(s));
            });
            evaluated += paths;
            matched += hits;
            if (!found.empty() && first.wanted(ray)) first.add(ray, std::move(found));
        };
        traceNonsequential(ts, detectors, perSource, to, {}, onRay);
        result.raysTraced += perSource * sources;
        if (options.progress) options.progress(result.raysTraced);
        if (first.stored() >= options.count) break;
    }
    result.paths = first.take();
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

Picture drawPaths(const Picture& base, const PathSelection& selection,
                  const PathPictureOptions& options) {
    Picture pic = base;
    double maxFlux = 0.0;
    for (const SelectedPath& p : selection.paths)
        for (size_t k = 1; k < p.flux.size(); ++k) maxFlux = std::max(maxFlux, p.flux[k]);
    const double decades = std::max(options.decades, 1e-3);
    auto fluxColour = [&](double f) {
        if (!(f > 0.0) || !(maxFlux > 0.0)) return falseColour(0.0);
        return falseColour(1.0 + std::log10(f / maxFlux) / decades);
    };
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
    for (const SelectedPath& p : selection.paths) {
        for (size_t k = 1; k < p.points.size(); ++k) {
            Vec2 a(p.points[k - 1].z, p.points[k - 1].y), b(p.points[k].z, p.points[k].y);
            if (!clipSegment(a, b, frame[0], frame[1], frame[2], frame[3])) continue;
            lines.push_back({a, b, p.flux[k], p.events[k].type});
        }
    }
    if (options.colouring == PathColouring::LogFlux)
        std::stable_sort(lines.begin(), lines.end(),
                         [](const Line& x, const Line& y) { return x.flux < y.flux; });
    for (const Line& l : lines) {
        const Color c =
            options.colouring == PathColouring::LogFlux ? fluxColour(l.flux) : eventColour(l.event);
        pic.polyline({l.a, l.b}, c, options.lineWidthPt);
    }

    // Legend, in output points below the title (pages are 1000 pt wide).
    const double x = pic.marginPt, y = 42.0;
    std::ostringstream head;
    head << selection.criterion << "   (" << selection.paths.size() << " path"
         << (selection.paths.size() == 1 ? "" : "s") << ", first in ray order of "
         << selection.raysTraced << " rays)";
    pic.overlayText(x, y, head.str(), Color::hex(0x000000), 11.0);
    const double ky = y + 16.0;
    if (options.colouring == PathColouring::EventType) {
        const std::pair<const char*, EventType> keys[] = {
            {"refract", EventType::Refract},
            {"reflect (Fresnel, specular)", EventType::FresnelReflect},
            {"TIR", EventType::TotalInternalReflection},
            {"scatter", EventType::ScatterReflect},
            {"absorb / exit", EventType::Exit},
            {"detector", EventType::DetectorHit}};
        double kx = x;
        for (const auto& [label, t] : keys) {
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
