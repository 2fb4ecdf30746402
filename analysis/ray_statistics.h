#pragma once
// Analyses re-run from a ray database, without tracing again: event counts by type and the
// flux each object received as a detector hit (equal to the traced detector totals up to
// the float32 rounding of stored fluxes).

#include <array>
#include <filesystem>
#include <map>
#include <string>

#include "tracer/path_history.h"
#include "tracer/ray_database.h"

namespace veil {

struct RayStatistics {
    uint64_t rays = 0;
    uint64_t paths = 0;   // complete (root-to-leaf) paths
    uint64_t events = 0;  // events stored, Emit included
    std::array<uint64_t, kEventTypeCount> eventsByType{};
    std::map<std::string, double> detectedFlux;  // detector object name -> flux
};

RayStatistics rayStatistics(RayDatabaseReader& reader);

}  // namespace veil
