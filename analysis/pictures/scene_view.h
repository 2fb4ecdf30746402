#pragma once
// A 3D view of a scene as one self-contained HTML page (`veil view`): the lens solids,
// mechanics, detectors and sources, and optionally the ray paths a criterion selected,
// coloured by log flux or by event, in a WebGL viewer with orbit controls, per-object
// visibility and names on hover.
//
//   Scene + Sources + PathSelection ──sceneViewData──> JSON (meshes as base64 float32/uint32)
//   JSON + the viewer page (analysis/pictures/scene_view.html, compiled in) + three.js (Debian's
//   libjs-three, read at export time) ──writeSceneView──> scene.html
//
// Nothing is fetched when the page is viewed: three.js and OrbitControls are inlined. Every
// scene object is drawn under its own name (L4.back, barrel, sensor: the names criteria use)
// and grouped by its part (L4, barrel) in the page's list.

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "analysis/pictures/path_picture.h"
#include "tracer/light/source.h"
#include "tracer/records/detector.h"

namespace veil {

class Scene;

struct SceneViewOptions {
    std::string title;
    double chordToleranceMm = 0.05;  // tessellation of the exact faces
    // Paths to draw (null: none) and how to colour them.
    const PathSelection* paths = nullptr;
    PathColouring colouring = PathColouring::LogFlux;
    double decades = 6.0;  // LogFlux: the ramp spans [max 10^-decades, max]
    // The detectors' pixel grids (SceneGeometry::detectors): each drawn as its rectangle, the
    // area that records light, over its sensor surface, which is then drawn pale.
    std::vector<DetectorGeometry> detectors;
};

// The page's data. Throws std::invalid_argument for a chord tolerance or decades <= 0.
nlohmann::json sceneViewData(const Scene& scene, const std::vector<Source>& sources,
                             const SceneViewOptions& options);

// Where three.js comes from: $VEIL_THREE_JS_DIR when set, else Debian's libjs-three
// (/usr/share/javascript/three). Throws std::runtime_error naming the folder, the file missing
// and the package when three.min.js or OrbitControls.js is not there.
struct ThreeJs {
    std::string three;          // build/three.min.js
    std::string orbitControls;  // examples/js/controls/OrbitControls.js
};
ThreeJs loadThreeJs();

// The page: the viewer with three.js and the data inlined, written through a temporary (never
// half-written). std::runtime_error naming the path when it cannot be written.
void writeSceneView(const std::filesystem::path& path, const nlohmann::json& data,
                    const ThreeJs& three);

// Standard base64 (RFC 4648, padded) of raw bytes: how meshes travel in the page.
std::string base64(const void* data, size_t bytes);

}  // namespace veil
