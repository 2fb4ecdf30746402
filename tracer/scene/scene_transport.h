#pragma once
// The transport part of a prepared scene (prepared_scene.h): everything the Monte Carlo
// passes need, resolved from the spec and the geometry once: media at the system wavelengths,
// the optical property of every object, which objects are detectors, the sources, and the
// detectors' grids. `view` is what the passes read (tracer/transport/interaction.h).

#include <memory>
#include <vector>

#include "tracer/scene/scene_geometry.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

struct SceneTransport {
    std::unique_ptr<MediaOptics> media;
    TransportView view;  // points into the SceneGeometry and into media
    // One template per detector (DetectorImage::grid: no memory for sums, so a big detector
    // is paid for once per run, by the accumulator a copy makes, not twice).
    std::vector<DetectorImage> images;
};

// The SceneGeometry must outlive the result. Throws ModelError when the scene has no source.
SceneTransport prepareTransport(const SceneSpec& spec, const SceneGeometry& geometry,
                                const GlassCatalog& catalog);

}  // namespace veil
