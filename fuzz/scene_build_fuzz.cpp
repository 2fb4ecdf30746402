// libFuzzer target: a scene TOML file read, built and traced as `veil trace -n 4` does:
// readSceneFile, PreparedScene::build (lens solids, mechanics, meshes, the Embree scene,
// detectors, sources) and runStrayLight with 4 rays per source on one thread. What the
// reader accepts must build within bounded work or be refused as a ModelError naming the
// object, and its rays must trace without a crash, whatever the numbers. The scene sits in
// the same scratch layout as scene_toml's (copies of examples/lenses and examples/zmx beside
// it).
//
// The harness caps each detector at 256 x 256 pixels and the scene at 64 sources (the edits
// `--pixels` and a smaller scene make): 32 Mpx detectors are a limit veil accepts on purpose,
// and their memory is not what this target looks for.
#include <tbb/global_control.h>

#include <algorithm>
#include <filesystem>

#include "analysis/runs/stray_light_run.h"
#include "fuzz/fuzz_common.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    static tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
    const std::filesystem::path path = veil::fuzz::sceneFolder() / "scene.toml";
    veil::fuzz::writeScratch("scenes/scene.toml", veil::fuzz::asText(data, size));
    veil::fuzz::expectCleanRejection([&] {
        veil::SceneSpec file = veil::readSceneFile(path, veil::GlassCatalog::builtIn());
        for (veil::DetectorSpec& d : file.detectors) {
            d.pixelsX = std::min(d.pixelsX, 256);
            d.pixelsY = std::min(d.pixelsY, 256);
        }
        if (file.sources.size() > 64)
            file.sources.erase(file.sources.begin() + 64, file.sources.end());
        const auto scene =
            veil::PreparedScene::build(std::move(file), veil::GlassCatalog::builtIn());
        if (!scene->hasSources()) return;
        veil::StrayLightSpec spec;
        spec.raysPerSource = 4;
        veil::runStrayLight(*scene, spec);
    });
    return 0;
}
