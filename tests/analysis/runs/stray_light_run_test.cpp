// A stray light run as a value: spec in, result out. The report's rows are the images' totals,
// the criterion layers add up to the detector's total, and a bad spec fails before anything
// is traced or opened.

#include "analysis/runs/stray_light_run.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "lensdata/glass_catalog.h"
#include "tracer/records/path_history.h"
#include "tracer/scene/prepared_scene.h"

namespace veil {
namespace {

const PreparedScene& sun() {
    static const std::unique_ptr<PreparedScene> s = PreparedScene::read(
        VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml", GlassCatalog::builtIn());
    return *s;
}

TEST(StrayLightRun, ReportRowsAreTheImagesAndTheLayersAddUp) {
    StrayLightSpec spec;
    spec.raysPerSource = 300;
    spec.transport.seed = 4;
    spec.where = {"fresnel{2} and not scatter", "scatter"};
    int opened = 0;
    std::atomic<uint64_t> seen{0};
    spec.openConsumer = [&]() -> RayCallback {
        ++opened;
        return [&seen](uint64_t, const PathHistory&) { ++seen; };  // from worker threads
    };
    const StrayLightResult r = runStrayLight(sun(), spec);
    EXPECT_EQ(opened, 1);
    EXPECT_EQ(seen.load(), 300u);
    EXPECT_EQ(r.emittedRays, 300u);
    EXPECT_EQ(r.fluxUnit, "W");
    EXPECT_LT(std::abs(r.budget.imbalance()), 1e-12 * r.budget.emitted);
    const std::vector<StrayLightRow> rows = r.report();
    ASSERT_EQ(rows.size(), 4u);  // the total, where1, where2, rest
    EXPECT_EQ(rows[0].layer, "");
    EXPECT_EQ(rows[0].flux, r.images[0].totalFlux());
    EXPECT_NEAR(rows[0].flux, r.budget.detected, 1e-12);
    EXPECT_EQ(rows[1].layer, "where1");
    EXPECT_EQ(rows[1].criterion, "fresnel{2} and not scatter");
    EXPECT_EQ(rows[3].layer, "rest");
    // The two criteria are disjoint and "rest" is none of them: the layers partition the
    // detector's flux.
    EXPECT_NEAR(rows[1].flux + rows[2].flux + rows[3].flux, rows[0].flux, 1e-12 * rows[0].flux);
    EXPECT_GT(rows[1].flux, 0.0);
    EXPECT_GT(rows[2].flux, 0.0);
    for (const StrayLightRow& row : rows) EXPECT_GT(row.relativeError, 0.0) << row.layer;
}

// Any number of detectors on one object, each recording every hit (the first of two had
// recorded nothing, "0 W (no hits)"): the Sun example's sensor carries its own 256 x 256
// detector, the same again under another name, and a coarse 32 x 32 one of half the size.
// The copy is the first image bit for bit; the coarse one holds the light of its half of the
// sensor, summed over its bigger pixels; the flux budget counts each ray once.
TEST(StrayLightRun, SeveralDetectorsOnOneObjectEachRecord) {
    std::ifstream in(VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml");
    std::stringstream text;
    text << in.rdbuf();
    std::string scene = text.str();
    const std::string lens = "lens = \"../lenses/longfocus_360mm.toml\"";
    scene.replace(scene.find(lens), lens.size(),
                  "lens = \"" VEIL_SOURCE_DIR "/examples/lenses/longfocus_360mm.toml\"");
    scene.replace(scene.find("[detector]"), 10, "[[detector]]");
    scene +=
        "\n[[detector]]\nname = \"copy\"\nobject = \"sensor\"\nsize_mm = [64.0, 64.0]\n"
        "pixels = [256, 256]\n\n[[detector]]\nname = \"coarse\"\nobject = \"sensor\"\n"
        "size_mm = [32.0, 32.0]\npixels = [32, 32]\n";
    const std::filesystem::path path =
        std::filesystem::temp_directory_path() / "veil_two_detectors_scene.toml";
    std::ofstream(path) << scene;
    const auto three = PreparedScene::read(path, GlassCatalog::builtIn());
    StrayLightSpec spec;
    spec.raysPerSource = 2000;
    spec.transport.seed = 7;
    spec.where = {"scatter"};
    const StrayLightResult r = runStrayLight(*three, spec);
    const StrayLightResult one = runStrayLight(sun(), spec);
    ASSERT_EQ(r.images.size(), 3u);
    ASSERT_EQ(one.images.size(), 1u);
    EXPECT_GT(one.images[0].totalFlux(), 0.0);
    EXPECT_TRUE(r.images[0].sameSums(one.images[0]));
    EXPECT_TRUE(r.images[1].sameSums(one.images[0]));
    EXPECT_EQ(r.budget.detected, one.budget.detected);
    EXPECT_LT(std::abs(r.budget.imbalance()), 1e-12 * r.budget.emitted);
    // The coarse detector: the central 32 x 32 mm of the fine one, 8 x 8 fine pixels each.
    const DetectorImage& fine = one.images[0];
    const DetectorImage& coarse = r.images[2];
    double inside = 0.0;
    for (int y = 64; y < 192; ++y)
        for (int x = 64; x < 192; ++x) inside += fine.flux(y * 256 + x);
    EXPECT_GT(inside, 0.0);
    EXPECT_NEAR(coarse.totalFlux(), inside, 1e-9 * inside);
    // The criterion layers exist per detector too: where1 on the copy is where1 on the first.
    const std::vector<StrayLightRow> rows = r.report();
    const std::vector<StrayLightRow> rowsOne = one.report();
    double firstWhere = -1.0, copyWhere = -2.0;
    for (const StrayLightRow& row : rows) {
        if (row.layer != "where1") continue;
        if (row.detector == "sensor_image") firstWhere = row.flux;
        if (row.detector == "copy") copyWhere = row.flux;
    }
    EXPECT_EQ(firstWhere, copyWhere);
    EXPECT_GT(firstWhere, 0.0);
}

TEST(StrayLightRun, BadSpecFailsBeforeTracingOrOpeningAnything) {
    StrayLightSpec spec;
    spec.raysPerSource = 100;
    bool opened = false;
    spec.openConsumer = [&]() -> RayCallback {
        opened = true;
        return {};
    };
    spec.where = {"hit(no_such_object)"};
    EXPECT_THROW(runStrayLight(sun(), spec), ParseError);
    spec.where = {};
    spec.prune = true;
    EXPECT_THROW(runStrayLight(sun(), spec), ModelError);
    EXPECT_FALSE(opened);
}

}  // namespace
}  // namespace veil
