// libFuzzer target: a scene TOML file (tracer/scene_setup.h, readSceneFile), read and checked
// as `veil trace` reads it before building anything. The scene sits in a scratch folder
// beside copies of examples/lenses and examples/zmx, so `lens = "../lenses/..."` resolves.
#include <filesystem>

#include "fuzz/fuzz_common.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene_setup.h"

namespace {

const std::filesystem::path& sceneFolder() {
    static const std::filesystem::path folder = [] {
        const auto root = veil::fuzz::scratchFolder();
        for (const char* sub : {"lenses", "zmx"}) {
            std::filesystem::create_directories(root / sub);
            std::filesystem::copy(std::filesystem::path(VEIL_SOURCE_DIR) / "examples" / sub,
                                  root / sub,
                                  std::filesystem::copy_options::overwrite_existing |
                                      std::filesystem::copy_options::recursive);
        }
        std::filesystem::create_directories(root / "scenes");
        return root / "scenes";
    }();
    return folder;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    const std::filesystem::path path = sceneFolder() / "scene.toml";
    veil::fuzz::writeScratch("scenes/scene.toml", veil::fuzz::asText(data, size));
    veil::fuzz::expectCleanRejection(
        [&] { veil::readSceneFile(path, veil::GlassCatalog::builtIn()); });
    return 0;
}
