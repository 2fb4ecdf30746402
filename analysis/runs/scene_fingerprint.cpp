#include "analysis/runs/scene_fingerprint.h"

#include <iomanip>

#include "geometry/scene.h"
#include "tracer/transport/interaction.h"

namespace veil {

void putSceneFingerprint(std::ostream& os, const TransportView& ts) {
    os << std::setprecision(17);
    for (const SceneObject& obj : ts.scene->objects()) os << obj << "\n";
    os << ts.scene->bounds() << "\n";
    for (const OpticalProperty& p : ts.properties) os << p << "\n";
    for (int p : ts.propertyOfObject) os << p << ",";
    for (const Source& s : ts.sources) os << s << "\n";
}

}  // namespace veil
