#pragma once
// Everything the nonsequential transport needs, resolved from a scene: media at the system
// wavelengths, the optical property of every object, which objects are detectors, the
// sources, and empty detector images.

#include <memory>
#include <vector>

#include "tracer/nonsequential.h"
#include "tracer/scene_setup.h"

namespace veil {

struct TraceSetup {
    std::unique_ptr<MediaOptics> media;
    TransportScene transport;  // points into the SceneSetup and into media
    std::vector<DetectorImage> images;
};

// The SceneSetup must outlive the result. Throws ModelError when the scene has no source.
TraceSetup prepareTrace(const SceneFile& file, const SceneSetup& setup,
                        const GlassCatalog& catalog);

}  // namespace veil
