// libFuzzer target: a scene TOML file (tracer/scene/scene_spec.h, readSceneFile), read and checked
// as `veil trace` reads it before building anything. The scene sits in a scratch folder
// beside copies of examples/lenses and examples/zmx, so `lens = "../lenses/..."` resolves.
#include <filesystem>

#include "fuzz/fuzz_common.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/scene_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::filesystem::path path = veil::fuzz::sceneFolder() / "scene.toml";
    veil::fuzz::writeScratch("scenes/scene.toml", veil::fuzz::asText(data, size));
    veil::fuzz::expectCleanRejection(
        [&] { veil::readSceneFile(path, veil::GlassCatalog::builtIn()); });
    return 0;
}
