#pragma once
// The coating what-if of veil ghosts (--coating GLOB=PROPERTY): other properties on the
// named faces, applied to a prepared scene's transport before the ghosts are ranked again.

#include <string>
#include <vector>

namespace veil {

class PropertyTable;
class Scene;
struct SceneTransport;

// Coating what-if: "glob=property" overrides applied to the resolved transport scene (before
// any [[assign]] rule and any surface's own coating). Returns one line per changed object,
// "L3.front: uncoated -> ideal_ar". Throws ParseError for a malformed override, a glob that
// matches no object, or an unknown property.
std::vector<std::string> applyCoatingOverrides(SceneTransport& transport, const Scene& scene,
                                               const PropertyTable& properties,
                                               const std::vector<std::string>& overrides);

}  // namespace veil
