#include "tracer/scene/prepared_scene.h"

#include "lensdata/glass_catalog.h"

namespace veil {

std::unique_ptr<PreparedScene> PreparedScene::build(SceneSpec spec, const GlassCatalog& catalog,
                                                    const SceneOptions& options) {
    // The constructor is private, so no make_unique.
    std::unique_ptr<PreparedScene> s(new PreparedScene());
    s->spec_ = std::move(spec);
    s->geometry_ = buildSceneGeometry(s->spec_, catalog, options);
    if (!s->spec_.sources.empty())
        s->transport_ = prepareTransport(s->spec_, s->geometry_, catalog);
    return s;
}

std::unique_ptr<PreparedScene> PreparedScene::read(const std::filesystem::path& path,
                                                   const GlassCatalog& catalog,
                                                   const SceneOptions& options) {
    return build(readSceneFile(path, catalog), catalog, options);
}

void PreparedScene::replaceTransport(SceneSpec spec, const GlassCatalog& catalog) {
    transport_.reset();
    spec_ = std::move(spec);
    if (!spec_.sources.empty()) transport_ = prepareTransport(spec_, geometry_, catalog);
}

const SceneTransport& PreparedScene::transport() const {
    if (!transport_) throw ModelError(spec_.path.string(), "the scene has no [[source]] to trace");
    return *transport_;
}

SceneTransport& PreparedScene::transport() {
    if (!transport_) throw ModelError(spec_.path.string(), "the scene has no [[source]] to trace");
    return *transport_;
}

}  // namespace veil
