// A stray light run as a value: spec in, result out. The report's rows are the images' totals,
// the criterion layers add up to the detector's total, and a bad spec fails before anything
// is traced or opened.

#include "analysis/runs/stray_light_run.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>

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
