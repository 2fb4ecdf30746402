#include "analysis/ghosts/coating_whatif.h"

#include "analysis/reports/format.h"
#include "geometry/scene.h"
#include "lensdata/errors.h"
#include "lensdata/toml_document.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/surfaces/property_table.h"

namespace veil {

std::vector<std::string> applyCoatingOverrides(SceneTransport& trace, const Scene& scene,
                                               const PropertyTable& properties,
                                               const std::vector<std::string>& overrides) {
    std::vector<std::string> changes;
    for (size_t k = 0; k < overrides.size(); ++k) {
        const std::string& o = overrides[k];
        const std::string where = "--coating " + std::to_string(k + 1);
        const size_t eq = o.find('=');
        if (eq == std::string::npos || eq == 0 || eq + 1 == o.size())
            throw ParseError({where, 1, 1},
                             "expected GLOB=PROPERTY (for example 'L3.*=ideal_ar'), "
                             "got '" +
                                 o + "'");
        const std::string glob = o.substr(0, eq), name = o.substr(eq + 1);
        int index = -1;
        for (size_t p = 0; p < trace.view.properties.size(); ++p)
            if (trace.view.properties[p].name() == name) index = static_cast<int>(p);
        if (index < 0) {
            const int t = properties.find(name);
            if (t < 0) {
                std::vector<std::string> known;
                for (const OpticalProperty& p : properties.properties()) known.push_back(p.name());
                throw ParseError(
                    {where, 1, static_cast<int>(eq + 2)},
                    "unknown optical property '" + name + "' (known: " + join(known, ", ") + ")");
            }
            trace.view.properties.push_back(properties.property(t));
            index = static_cast<int>(trace.view.properties.size()) - 1;
        }
        bool any = false;
        for (const SceneObject& obj : scene.objects()) {
            bool match = globMatch(glob, obj.name);
            for (const std::string& a : obj.aliases) match = match || globMatch(glob, a);
            if (!match) continue;
            any = true;
            // A wildcard coats optical faces: not butt ends, flats or cemented interfaces.
            if (!coatingPatternReaches(glob, obj)) continue;
            int& cur = trace.view.propertyOfObject[obj.id];
            if (cur == index) continue;
            std::string change =
                obj.name + ": " + trace.view.properties[cur].name() + " -> " + name;
            if (isCementedFace(obj))
                change +=
                    " (warning: a cemented interface, glass on both sides: a coating "
                    "designed for air there reflects far more than the bare glass pair)";
            changes.push_back(change);
            cur = index;
        }
        if (!any) {
            const std::string guess = closestSpelling(glob, namesAndAliases(scene.objects()));
            throw ParseError({where, 1, 1},
                             "object pattern '" + glob + "' matches no object" +
                                 (guess.empty() ? "" : " (did you mean '" + guess + "'?)"));
        }
    }
    return changes;
}

}  // namespace veil
