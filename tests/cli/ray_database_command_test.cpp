// The ray database from the command line: its size said before tracing, an events-only
// database a quarter of the size with the same fluxes, and criteria re-evaluated on the
// saved histories giving the split `veil trace --where` gives.

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>

#include "tests/cli/run_veil.h"

namespace {

TEST(VeilRays, WhereOnSavedHistoriesMatchesTheTrace) {
    const std::string dir = ::testing::TempDir() + "veil_rays_where";
    std::filesystem::remove_all(dir);
    const std::string where = " --where 'seq(fresnel, fresnel, hit(sensor))'";
    const VeilRun full = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 300 --json -o " +
                                 dir + " --save-rays " + dir + "/full.vrdb" + where);
    ASSERT_EQ(full.exitCode, 0) << full.err;
    EXPECT_NE(full.err.find("veil: --save-rays: about "), std::string::npos) << full.err;
    const VeilRun events =
        runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 300 --quiet --json -o " + dir +
                "/e --save-rays " + dir + "/events.vrdb --events-only");
    ASSERT_EQ(events.exitCode, 0) << events.err;
    EXPECT_EQ(events.err.find("--save-rays: about"), std::string::npos) << "--quiet";
    // A quarter of the size, or less.
    const auto fullBytes = std::filesystem::file_size(dir + "/full.vrdb");
    const auto eventBytes = std::filesystem::file_size(dir + "/events.vrdb");
    EXPECT_LT(eventBytes, fullBytes / 3);

    const nlohmann::json trace = nlohmann::json::parse(full.out);
    const auto& split = trace["detectors"].at(0)["by_criterion"];
    for (const char* db : {"/full.vrdb", "/events.vrdb"}) {
        SCOPED_TRACE(db);
        // The detector's own name works on saved rays as in the trace.
        const VeilRun r = runVeil("rays " + dir + db + " --json" + where +
                                  " --where 'detector(sensor_image)'");
        ASSERT_EQ(r.exitCode, 0) << r.err;
        const nlohmann::json j = nlohmann::json::parse(r.out);
        ASSERT_EQ(j["by_criterion"].size(), 3u);
        // where1 as traced (float32 fluxes in the file).
        const double traced = split.at(0)["flux"].get<double>();
        const double saved = j["by_criterion"].at(0)["detected_flux"]["sensor"].get<double>();
        EXPECT_NEAR(saved, traced, 1e-6 * traced);
        EXPECT_NEAR(j["by_criterion"].at(0)["relative_error"]["sensor"].get<double>(),
                    split.at(0)["relative_error"].get<double>(), 1e-3);
        // Every path ending on the detector holds for where2: the rest has no detector flux.
        EXPECT_TRUE(j["by_criterion"].at(2)["detected_flux"].empty());
        // detector(sensor_image) holds for every path ending on it: the whole detected flux.
        EXPECT_NEAR(j["by_criterion"].at(1)["detected_flux"]["sensor"].get<double>(),
                    trace["detectors"].at(0)["flux"].get<double>(),
                    1e-6 * trace["detectors"].at(0)["flux"].get<double>());
    }
    // A bad criterion names its option and column, before reading.
    const VeilRun bad = runVeil("rays " + dir + "/events.vrdb --where 'hit(L9.front)'");
    EXPECT_EQ(bad.exitCode, 2);
    EXPECT_NE(bad.err.find("--where 1:1:5"), std::string::npos) << bad.err;
    // --events-only alone is a usage mistake.
    const VeilRun alone =
        runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 10 --events-only --json");
    EXPECT_EQ(alone.exitCode, 2);
    EXPECT_NE(alone.err.find("--events-only needs --save-rays"), std::string::npos) << alone.err;
}

}  // namespace
