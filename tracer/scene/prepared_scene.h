#pragma once
// The third stage of a scene: prepared once per command and shared, read-only, by all its
// passes and threads. The stages, each with one name (docs/architecture.md):
//
//   file      scene.toml / lens.zmx / lens.seq on disk
//     --readSceneFile--> (scene_spec.h)
//   spec      SceneSpec: what the file says, checked and sized (the prescription with every
//             semi-diameter and its one sequential model, mechanics and mesh specs, sources,
//             detectors, properties); a command may edit it here (the default ghost scene,
//             --field, --pixels)
//     --PreparedScene::build-->
//   prepared  PreparedScene: spec() + geometry() (SceneGeometry, scene_geometry.h: the
//             committed Scene, mechanical parts, placed detectors, import notes) +
//             transport() (SceneTransport, scene_transport.h: media at the system
//             wavelengths, the property of every object, detector images, sources, and the
//             TransportView every pass reads)
//
// One owner for all of it. The transport's pointers (to the scene and to the media) point
// into this same object, which is neither copied nor moved (it lives behind a unique_ptr), so
// nothing can outlive what it points to. The transport part exists only for scenes with
// sources: a layout or an export needs none, and asking a source-less scene for it is the
// ModelError "the scene has no [[source]] to trace", naming the file.

#include <filesystem>
#include <memory>
#include <optional>

#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_transport.h"

namespace veil {

class PreparedScene {
  public:
    // Prepares the scene of an already read (and possibly edited) spec.
    static std::unique_ptr<PreparedScene> build(SceneSpec spec, const GlassCatalog& catalog,
                                                const SceneOptions& options = {});
    // readSceneFile() and build().
    static std::unique_ptr<PreparedScene> read(const std::filesystem::path& path,
                                               const GlassCatalog& catalog,
                                               const SceneOptions& options = {});

    PreparedScene(const PreparedScene&) = delete;
    PreparedScene& operator=(const PreparedScene&) = delete;
    PreparedScene(PreparedScene&&) = delete;
    PreparedScene& operator=(PreparedScene&&) = delete;

    const SceneSpec& spec() const { return spec_; }
    const SceneGeometry& geometry() const { return geometry_; }
    const Scene& scene() const { return geometry_.scene; }
    const SequentialModel& model() const { return *geometry_.model; }
    bool hasSources() const { return transport_.has_value(); }
    // The transport's inputs; throws the ModelError above when the scene has no source.
    const SceneTransport& transport() const;
    // For what-if edits of the transport's properties or sources before a run (the ghost
    // analysis's coatings); the scene itself stays as built.
    SceneTransport& transport();
    // Another spec of the same scene whose edits change only what the transport reads
    // (optical properties, [[assign]], sources: veil sweep's property-only variants): the spec
    // and the transport are replaced, the geometry is kept, not rebuilt. The caller vouches
    // that `spec` describes the same geometry.
    void replaceTransport(SceneSpec spec, const GlassCatalog& catalog);

  private:
    PreparedScene() = default;
    SceneSpec spec_;
    SceneGeometry geometry_;
    std::optional<SceneTransport> transport_;
};

}  // namespace veil
