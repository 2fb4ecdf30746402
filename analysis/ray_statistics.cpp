#include "analysis/ray_statistics.h"

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

}  // namespace veil
