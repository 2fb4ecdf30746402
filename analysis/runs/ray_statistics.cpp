#include "analysis/runs/ray_statistics.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "analysis/reports/format.h"
#include "tracer/records/path_history.h"

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
    const std::vector<CompiledCriterion> compiled = compileWhereList(where, names);
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

nlohmann::json rayStatisticsJson(const RayDatabaseInfo& info, const RayStatistics& s,
                                 const std::vector<CriterionFlux>& split) {
    nlohmann::json j;
    j["scene"] = info.sceneName;
    j["seed"] = info.seed;
    j["unit"] = info.fluxUnit;
    j["rays"] = s.rays;
    j["paths"] = s.paths;
    j["events"] = s.events;
    j["geometry"] = info.encoding.positions;
    for (int t = 0; t < kEventTypeCount; ++t)
        j["events_by_type"][std::string(toString(static_cast<EventType>(t)))] =
            s.eventsByType[t];
    for (const auto& [name, flux] : s.detectedFlux) j["detected_flux"][name] = flux;
    if (!split.empty()) {
        j["by_criterion"] = nlohmann::json::array();
        for (size_t k = 0; k < split.size(); ++k) {
            nlohmann::json c{{"layer", k + 1 < split.size() ? "where" + std::to_string(k + 1)
                                                            : std::string("rest")},
                             {"criterion", split[k].criterion},
                             {"paths", split[k].paths},
                             {"detected_flux", nlohmann::json::object()},
                             {"relative_error", nlohmann::json::object()}};
            for (const auto& [name, flux] : split[k].detectedFlux) {
                c["detected_flux"][name] = flux;
                c["relative_error"][name] = split[k].relativeError.at(name);
            }
            j["by_criterion"].push_back(c);
        }
    }
    return j;
}

std::string rayStatisticsText(const std::string& path, const RayDatabaseInfo& info,
                              const RayStatistics& s, const std::vector<CriterionFlux>& split) {
    std::ostringstream os;
    os << path << ": scene " << info.sceneName << ", seed " << info.seed << "\n  "
              << s.rays << " rays, " << s.paths << " paths, " << s.events << " events"
              << (info.encoding.positions ? "" : " (events only, no geometry)") << "\n";
    for (int t = 0; t < kEventTypeCount; ++t)
        if (s.eventsByType[t])
            os << "  " << std::left << std::setw(18) << toString(static_cast<EventType>(t))
                      << std::right << std::setw(12) << s.eventsByType[t] << "\n";
    for (const auto& [name, flux] : s.detectedFlux)
        os << "  detected on " << name << ": " << std::scientific << std::setprecision(6)
                  << flux << " " << info.fluxUnit << "\n";
    for (size_t k = 0; k < split.size(); ++k) {
        const bool rest = k + 1 == split.size();
        os << "  " << std::left << std::setw(8)
                  << (rest ? std::string("rest") : "where" + std::to_string(k + 1)) << std::right
                  << split[k].paths << " paths  "
                  << (rest ? std::string("none of the above") : split[k].criterion) << "\n";
        for (const auto& [name, flux] : split[k].detectedFlux)
            os << "      on " << name << ": "
                      << formatFlux(flux, split[k].relativeError.at(name), info.fluxUnit) << "\n";
    }
    return os.str();
}

}  // namespace veil
