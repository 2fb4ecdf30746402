#pragma once
// From a file on disk to a scene ready to trace.
//
// A scene file is a veil TOML file holding a lens, either inline ([system] with its
// surfaces) or by reference (`lens = "path/to/lens.toml"` or a .zmx file, relative to the
// scene file), plus optional [mechanics] and [[mesh]] sections (later: sources, detector,
// optical properties). A bare lens file (.toml or .zmx) is a scene without mechanics.
//
// Building the scene: clear semi-diameters the file leaves open are computed from real rays
// (tracer/sequential/auto_apertures.h), lens solids are added with their exact faces, mechanics are
// built and checked with CGAL, meshes are imported, and the image surface becomes the
// detector `sensor` (alias `image`).

#include <filesystem>
#include <memory>
#include <optional>
#include <vector>

#include "geometry/lens_fit.h"
#include "geometry/mechanics.h"
#include "geometry/mesh_io.h"
#include "geometry/scene.h"
#include "lensdata/errors.h"
#include "tracer/light/source.h"
#include "tracer/records/detector.h"
#include "tracer/surfaces/property_table.h"

namespace veil {

class GlassCatalog;
class SequentialModel;

struct SceneSpec {
    std::filesystem::path path;
    // The lens with every clear semi-diameter set (automatic ones traced, see
    // tracer/sequential/auto_apertures.h): the sizes sources, solids and mechanics are built from.
    Prescription prescription;
    // The sequential model of `prescription`, built once here and shared by everything that
    // needs it (sources, the scene, the ghost tracer); whoever edits the prescription (the
    // default ghost scene moves the image) builds it anew.
    std::shared_ptr<const SequentialModel> model;
    // Where the file's sizes did not build (elements overlapping or too thin), the lens was
    // fitted (geometry/lens_fit.h): what changed, per element, also in prescription.report.
    std::vector<LensSizeChange> sizeChanges;
    // A lens that cannot be built at any size: thrown by buildSceneGeometry(), so that what
    // needs no solids (first-order data) still works.
    std::optional<ModelError> sizeError;
    // Per surface, a central hole the scene's mirror gets because the light comes back
    // through its place (returningLightHoles, tracer/sequential/auto_apertures.h); 0 = none.
    // The sequential model keeps the file's mirror (its rays never meet it twice).
    std::vector<double> mirrorHoles;
    std::optional<MechanicsSpec> mechanics;
    std::vector<MeshImportSpec> meshes;
    std::vector<Source> sources;          // [[source]]
    std::vector<DetectorSpec> detectors;  // [detector] / [[detector]]; empty: the default one
    PropertyTable properties;             // built-ins + [properties.*] + [[assign]]
};

// A what-if edit of the scene file (`veil sweep --vary`): the value at `key` replaced by
// `value` as TomlDocument::set() does; `origin` ("--vary KEY=VALUE") names the edit in every
// message about it. Keys under `system` go to the lens file when the scene names one
// (`lens = "lens.toml"`).
struct SceneEdit {
    std::string key;
    std::string value;
    std::string origin;
};

// Reads and checks every section (unknown keys are a ParseError at file:line:col), after the
// edits. Edits need TOML files: an edit of a .zmx lens is a ParseError at the edit.
SceneSpec readSceneFile(const std::filesystem::path& path, const GlassCatalog& catalog,
                        const std::vector<SceneEdit>& edits = {});
// Applies the edits to the scene's (and its lens file's) TOML documents and nothing more:
// a key that names nothing or a value of the wrong type is a ParseError at the edit, found
// before anything is built. Values are checked by readSceneFile().
void checkSceneEdits(const std::filesystem::path& path, const std::vector<SceneEdit>& edits);
// Whether an edit of this key changes only what the transport reads (optical properties,
// [[assign]], sources), not the geometry: PreparedScene::replaceTransport() suffices.
bool editsTransportOnly(const std::string& key);

}  // namespace veil
