#pragma once
// Analyses re-run from a ray database, without tracing again: event counts by type and the
// flux each object received as a detector hit (equal to the traced detector totals up to
// the float32 rounding of stored fluxes).

#include <array>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/criteria/criteria.h"
#include "tracer/records/path_history.h"
#include "tracer/records/ray_database.h"

namespace veil {

struct RayStatistics {
    uint64_t rays = 0;
    uint64_t paths = 0;   // complete (root-to-leaf) paths
    uint64_t events = 0;  // events stored, Emit included
    std::array<uint64_t, kEventTypeCount> eventsByType{};
    std::map<std::string, double> detectedFlux;  // detector object name -> flux
};

RayStatistics rayStatistics(RayDatabaseReader& reader);

// What criteria may name in a ray database: its objects (detectors are the objects of kind
// Detector), media and sources.
NameTable criterionNames(const RayDatabaseInfo& info);

// The detector flux of the paths each criterion holds for, re-evaluated on the saved
// histories (the same split as `veil trace --where`, up to the float32 rounding of stored
// fluxes), plus the rest (paths no criterion holds for). Errors name "--where K" and the
// column, before any record is read.
struct CriterionFlux {
    std::string criterion;                        // the text; "" for the rest
    uint64_t paths = 0;                           // complete paths it holds for, wherever they end
    std::map<std::string, double> detectedFlux;   // detector object name -> flux
    std::map<std::string, double> relativeError;  // its standard error over the flux
};
std::vector<CriterionFlux> criterionFluxes(RayDatabaseReader& reader,
                                           const std::vector<std::string>& where);

// What veil rays prints and writes as JSON: the counts, the detected flux and its split by
// criteria (`split`: criterionFluxes(), empty without criteria).
nlohmann::json rayStatisticsJson(const RayDatabaseInfo& info, const RayStatistics& s,
                                 const std::vector<CriterionFlux>& split);
std::string rayStatisticsText(const std::string& path, const RayDatabaseInfo& info,
                              const RayStatistics& s, const std::vector<CriterionFlux>& split);

}  // namespace veil
