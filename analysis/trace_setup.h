#pragma once
// Everything the nonsequential transport needs, resolved from a scene: media at the system
// wavelengths, the optical property of every object, which objects are detectors, the
// sources, and empty detector images.

#include <memory>
#include <vector>

#include "analysis/criteria.h"
#include "analysis/scene_setup.h"
#include "tracer/nonsequential.h"

namespace veil {

struct TraceSetup {
    std::unique_ptr<MediaOptics> media;
    TransportScene transport;  // points into the SceneSetup and into media
    std::vector<DetectorImage> images;
};

// What criteria may name in this scene: objects (with aliases, resolved optical property and
// whether they are detectors), media and sources, indexed as in the path histories.
NameTable criterionNames(const Scene& scene, const TransportScene& transport);

// The SceneSetup must outlive the result. Throws ModelError when the scene has no source.
TraceSetup prepareTrace(const SceneFile& file, const SceneSetup& setup,
                        const GlassCatalog& catalog);

}  // namespace veil
