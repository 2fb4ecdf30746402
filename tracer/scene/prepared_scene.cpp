#include "tracer/scene/prepared_scene.h"

namespace veil {

std::unique_ptr<PreparedScene> PreparedScene::build(SceneFile file, const GlassCatalog& catalog,
                                                    const SceneOptions& options) {
    // The constructor is private, so no make_unique.
    std::unique_ptr<PreparedScene> s(new PreparedScene());
    s->file_ = std::move(file);
    s->setup_ = buildScene(s->file_, catalog, options);
    if (!s->file_.sources.empty()) s->trace_ = prepareTrace(s->file_, s->setup_, catalog);
    return s;
}

std::unique_ptr<PreparedScene> PreparedScene::read(const std::filesystem::path& path,
                                                   const GlassCatalog& catalog,
                                                   const SceneOptions& options) {
    return build(readSceneFile(path, catalog), catalog, options);
}

void PreparedScene::replaceTransport(SceneFile file, const GlassCatalog& catalog) {
    trace_.reset();
    file_ = std::move(file);
    if (!file_.sources.empty()) trace_ = prepareTrace(file_, setup_, catalog);
}

const TraceSetup& PreparedScene::trace() const {
    if (!trace_) throw ModelError(file_.path.string(), "the scene has no [[source]] to trace");
    return *trace_;
}

TraceSetup& PreparedScene::trace() {
    if (!trace_) throw ModelError(file_.path.string(), "the scene has no [[source]] to trace");
    return *trace_;
}

}  // namespace veil
