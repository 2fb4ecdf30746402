#include "analysis/runs/ray_statistics.h"

#include <algorithm>
#include <cmath>

namespace veil {

RayStatistics rayStatistics(RayDatabaseReader& reader) {
    RayStatistics s;
    const RayDatabaseInfo& info = reader.info();
    RayRecord rec;
    reader.rewind();
    while (reader.next(rec)) {
        ++s.rays;
        const PathHistory& h = rec.history;
        s.events += h.size();
        s.paths += h.pathCount();
        for (size_t i = 0; i < h.size(); ++i) {
            const PathNode& n = h.node(static_cast<NodeIndex>(i));
            ++s.eventsByType[static_cast<size_t>(n.type)];
            if (n.type == EventType::DetectorHit) {
                const std::string name =
                    n.object >= 0 && n.object < static_cast<int>(info.objects.size())
                        ? info.objects[n.object].name
                        : "object " + std::to_string(n.object);
                s.detectedFlux[name] += n.flux;
            }
        }
    }
    return s;
}

NameTable criterionNames(const RayDatabaseInfo& info) {
    NameTable t;
    for (const RayDatabaseObject& o : info.objects) {
        NameTable::Object n;
        n.name = o.name;
        n.aliases = o.aliases;
        n.property = o.property;
        n.detector = o.kind == ObjectKind::Detector;
        t.objects.push_back(std::move(n));
    }
    t.media = info.media;
    t.sources = info.sources;
    return t;
}

std::vector<CriterionFlux> criterionFluxes(RayDatabaseReader& reader,
                                           const std::vector<std::string>& where) {
    const RayDatabaseInfo& info = reader.info();
    const NameTable names = criterionNames(info);
    std::vector<CompiledCriterion> compiled;
    for (size_t k = 0; k < where.size(); ++k)
        compiled.push_back(compileCriterion(where[k], names, "--where " + std::to_string(k + 1)));
    std::vector<StreamingEvaluator> evaluators;
    for (const CompiledCriterion& c : compiled) evaluators.emplace_back(c);

    const size_t n = where.size() + 1;  // the criteria and the rest
    std::vector<CriterionFlux> out(n);
    for (size_t k = 0; k < where.size(); ++k) out[k].criterion = where[k];
    // Per criterion and detector: the sum over rays of the flux and of its square.
    std::vector<std::map<std::string, std::pair<double, double>>> sums(n);
    std::vector<std::map<std::string, double>> ray(n);
    auto nameOf = [&](int object) {
        return object >= 0 && object < static_cast<int>(info.objects.size())
                   ? info.objects[object].name
                   : "object " + std::to_string(object);
    };
    RayRecord rec;
    reader.rewind();
    std::vector<bool> holds(where.size());
    while (reader.next(rec)) {
        for (auto& r : ray) r.clear();
        rec.history.forEachPath([&](const PathView& p) {
            bool any = false;
            for (size_t k = 0; k < where.size(); ++k) {
                StreamingEvaluator& ev = evaluators[k];
                ev.reset();
                for (size_t e = 0; e < p.size() && !ev.decided(); ++e) ev.push(p.event(e));
                holds[k] = ev.finish() == CriterionState::True;
                any |= holds[k];
            }
            const PathNode& leaf = rec.history.node(p.leaf());
            for (size_t k = 0; k < n; ++k) {
                const bool counts = k < where.size() ? holds[k] : !any;
                if (!counts) continue;
                ++out[k].paths;
                if (leaf.type == EventType::DetectorHit) ray[k][nameOf(leaf.object)] += leaf.flux;
            }
        });
        for (size_t k = 0; k < n; ++k)
            for (const auto& [name, flux] : ray[k]) {
                sums[k][name].first += flux;
                sums[k][name].second += flux * flux;
            }
    }
    // Rays not stored (emitted but rejected) count as zeros.
    const double rays = static_cast<double>(
        std::max<uint64_t>(reader.summary().emittedRays, reader.summary().storedRays));
    for (size_t k = 0; k < n; ++k)
        for (const auto& [name, s] : sums[k]) {
            out[k].detectedFlux[name] = s.first;
            const double mean = s.first / rays;
            const double variance =
                rays > 1 ? std::max(0.0, (s.second / rays - mean * mean) * rays / (rays - 1)) : 0.0;
            out[k].relativeError[name] = s.first > 0.0 ? std::sqrt(rays * variance) / s.first : 0.0;
        }
    return out;
}

}  // namespace veil
