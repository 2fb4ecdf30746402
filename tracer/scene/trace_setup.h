#pragma once
// Everything the nonsequential transport needs, resolved from a scene: media at the system
// wavelengths, the optical property of every object, which objects are detectors, the
// sources, and the detectors' grids.

#include <memory>
#include <vector>

#include "tracer/scene/scene_setup.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

struct TraceSetup {
    std::unique_ptr<MediaOptics> media;
    TransportScene transport;  // points into the SceneSetup and into media
    // One template per detector (DetectorImage::grid: no memory for sums, so a big detector
    // is paid for once per run, by the accumulator a copy makes, not twice).
    std::vector<DetectorImage> images;
};

// The SceneSetup must outlive the result. Throws ModelError when the scene has no source.
TraceSetup prepareTrace(const SceneFile& file, const SceneSetup& setup,
                        const GlassCatalog& catalog);

}  // namespace veil
