#include "analysis/criteria/criterion_names.h"

#include <algorithm>

#include "geometry/scene.h"
#include "tracer/transport/interaction.h"

namespace veil {

NameTable criterionNames(const Scene& scene, const TransportView& transport) {
    NameTable t;
    for (const SceneObject& o : scene.objects()) {
        NameTable::Object n;
        n.name = o.name;
        n.aliases = o.aliases;
        if (o.id < static_cast<int>(transport.propertyOfObject.size()))
            n.property = transport.properties[transport.propertyOfObject[o.id]].name();
        n.detector = o.id < static_cast<int>(transport.detectorOfObject.size()) &&
                     transport.detectorOfObject[o.id] >= 0;
        // A detector's own name ([detector] name = "sensor_image") names its object too.
        // Every detector on the object: an object may carry several.
        for (int d = n.detector ? transport.detectorOfObject[o.id] : -1; d >= 0;
             d = nextDetectorOf(transport.nextDetector, d)) {
            if (d < static_cast<int>(transport.detectorNames.size())) {
                const std::string& dn = transport.detectorNames[d];
                if (!dn.empty() && dn != n.name &&
                    std::find(n.aliases.begin(), n.aliases.end(), dn) == n.aliases.end())
                    n.aliases.push_back(dn);
            }
        }
        t.objects.push_back(std::move(n));
    }
    for (const Medium& m : scene.media()) t.media.push_back(m.name);
    for (const Source& s : transport.sources) t.sources.push_back(s.name());
    return t;
}

}  // namespace veil
