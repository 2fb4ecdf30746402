#pragma once
// The second stage of a scene: its geometry, built from the spec (scene_spec.h) once per
// command. Clear semi-diameters the file leaves open are computed from real rays
// (tracer/sequential/auto_apertures.h), lens solids are added with their exact faces,
// mechanics are built and checked with CGAL, meshes are imported, and the image surface
// becomes the detector `sensor` (alias `image`).

#include <memory>
#include <vector>

#include "geometry/mechanics.h"
#include "geometry/scene.h"
#include "tracer/records/detector.h"
#include "tracer/scene/scene_spec.h"

namespace veil {

class GlassCatalog;
class SequentialModel;

struct SceneOptions {
    bool mechanics = true;  // build the [mechanics] section when present
    bool meshes = true;     // import the [[mesh]] entries
};

struct SceneGeometry {
    Prescription prescription;                     // with automatic semi-diameters filled in
    std::shared_ptr<const SequentialModel> model;  // the SceneSpec's, not rebuilt
    Scene scene;                                   // committed
    std::vector<MechanicalPart> mechanicalParts;
    std::vector<DetectorGeometry> detectors;  // placed; their objects are in the scene
    std::vector<ImportNote> notes;            // import report, parts left out, mesh warnings
};

// Uses file.model (builds one when a hand-made SceneSpec has none).
SceneGeometry buildSceneGeometry(const SceneSpec& spec, const GlassCatalog& catalog,
                                 const SceneOptions& options = {});

}  // namespace veil
