#pragma once
// A scene prepared once per command and shared, read-only, by all its passes and threads.
//
//   scene.toml / lens.zmx --readSceneFile--> SceneFile (sized prescription and its one
//       sequential model, mechanics and mesh specs, sources, detectors, properties)
//     (a command may edit the SceneFile here: the default ghost scene, --field, --pixels)
//   --PreparedScene::build--> file + setup (the committed Scene, mechanical parts, placed
//       detectors, import notes) + trace (media at the system wavelengths, the property of
//       every object, detector images, sources)
//
// One owner for all of it. The transport's pointers (to the scene and to the media) point
// into this same object, which is neither copied nor moved (it lives behind a unique_ptr), so
// nothing can outlive what it points to. The transport part exists only for scenes with
// sources: a layout or an export needs none, and asking a source-less scene for it is the
// ModelError "the scene has no [[source]] to trace", naming the file.

#include <filesystem>
#include <memory>
#include <optional>

#include "tracer/scene/scene_setup.h"
#include "tracer/scene/trace_setup.h"

namespace veil {

class PreparedScene {
  public:
    // Builds the scene of an already read (and possibly edited) scene file.
    static std::unique_ptr<PreparedScene> build(SceneFile file, const GlassCatalog& catalog,
                                                const SceneOptions& options = {});
    // readSceneFile() and build().
    static std::unique_ptr<PreparedScene> read(const std::filesystem::path& path,
                                               const GlassCatalog& catalog,
                                               const SceneOptions& options = {});

    PreparedScene(const PreparedScene&) = delete;
    PreparedScene& operator=(const PreparedScene&) = delete;
    PreparedScene(PreparedScene&&) = delete;
    PreparedScene& operator=(PreparedScene&&) = delete;

    const SceneFile& file() const { return file_; }
    const SceneSetup& setup() const { return setup_; }
    const Scene& scene() const { return setup_.scene; }
    const SequentialModel& model() const { return *setup_.model; }
    bool hasSources() const { return trace_.has_value(); }
    // The transport's inputs; throws the ModelError above when the scene has no source.
    const TraceSetup& trace() const;
    // For what-if edits of the transport's properties or sources before a run (the ghost
    // analysis's coatings); the scene itself stays as built.
    TraceSetup& trace();
    // Another reading of the same scene file whose edits change only what the transport
    // reads (optical properties, [[assign]], sources: veil sweep's property-only variants):
    // the file and the transport are replaced, the geometry is kept, not rebuilt. The caller
    // vouches that `file` describes the same geometry.
    void replaceTransport(SceneFile file, const GlassCatalog& catalog);

  private:
    PreparedScene() = default;
    SceneFile file_;
    SceneSetup setup_;
    std::optional<TraceSetup> trace_;
};

}  // namespace veil
