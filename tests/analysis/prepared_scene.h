#pragma once
// Scenes written by tests and prepared for tracing: the scene file, its built scene and the
// transport's inputs, kept together (the trace setup points into the scene).

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <memory>
#include <string>

#include "lensdata/glass_catalog.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/scene/scene_transport.h"

namespace veil::test {

// Writes `text` as <temp>/<name>.toml; lens paths inside must be absolute.
inline std::filesystem::path writeScene(const std::string& name, const std::string& text) {
    const std::filesystem::path p = std::filesystem::path(::testing::TempDir()) / (name + ".toml");
    std::ofstream(p) << text;
    return p;
}

struct Prepared {
    SceneSpec file;
    std::unique_ptr<SceneGeometry> setup;
    SceneTransport trace;
};

inline Prepared prepare(const std::filesystem::path& path) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    Prepared r;
    r.file = readSceneFile(path, catalog);
    r.setup = std::make_unique<SceneGeometry>(buildSceneGeometry(r.file, catalog));
    r.trace = prepareTransport(r.file, *r.setup, catalog);
    return r;
}

}  // namespace veil::test
