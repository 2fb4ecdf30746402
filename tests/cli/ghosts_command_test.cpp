// `veil ghosts` run as a user runs it: the default scene of a bare lens, the tables and files
// it writes, --json, --coating and the errors for bad input.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "run_veil.h"

namespace {

std::string outDir(const std::string& name) {
    const std::filesystem::path p = std::filesystem::path(::testing::TempDir()) / name;
    std::filesystem::remove_all(p);
    return p.string();
}

[[maybe_unused]] std::string readText(const std::filesystem::path& p) {
    std::ifstream f(p);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
}

TEST(VeilGhosts, BareZemaxLensGetsTheDefaultSceneAndEveryFormat) {
    const std::string out = outDir("ghosts_zmx");
    const VeilRun r = runVeil(
        "ghosts tests/data/zmx/US00583336-2-scaled.zmx -n 300 "
        "--top 2 --paths 20 --quiet -o " +
        out);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("default scene"), std::string::npos) << r.out;
    const nlohmann::json j = nlohmann::json::parse(readText(out + "/ghosts.json"));
    EXPECT_TRUE(j["default_scene"].get<bool>());
    const size_t n = j["ghost_surfaces"].size();
    ASSERT_GE(n, 2u);
    EXPECT_EQ(j["ghosts"].size(), n * (n - 1) / 2);
    // Ranked by peak irradiance, brightest first; every row carries its criterion.
    for (size_t k = 1; k < j["ghosts"].size(); ++k)
        EXPECT_GE(j["ghosts"][k - 1]["peak_irradiance"].get<double>(),
                  j["ghosts"][k]["peak_irradiance"].get<double>());
    EXPECT_NE(j["ghosts"][0]["criterion"].get<std::string>().find("seq(fresnel("),
              std::string::npos);
    // CSV: header plus one line per ghost. Markdown: the table and the criteria list.
    const std::string csv = readText(out + "/ghosts.csv");
    EXPECT_EQ(static_cast<size_t>(std::count(csv.begin(), csv.end(), '\n')), n * (n - 1) / 2 + 1);
    EXPECT_NE(readText(out + "/ghosts.md").find("| rank | ghost |"), std::string::npos);
    for (const char* f :
         {"/images/ghost_01.exr", "/images/ghost_01.png", "/ghosts_all.exr", "/ghosts_all.png",
          "/nominal.png", "/paths/ghost_01.svg", "/paths/ghost_02.png", "/paths/all_ghosts.png"})
        EXPECT_TRUE(std::filesystem::exists(out + f)) << f;
    EXPECT_FALSE(std::filesystem::exists(out + "/paths/ghost_03.svg"));
    for (const auto& e : std::filesystem::recursive_directory_iterator(out))
        EXPECT_NE(e.path().extension(), ".tmp") << e.path();
}

TEST(VeilGhosts, JsonOnStandardOutputAndTheCoatingWhatIf) {
    const std::string out = outDir("ghosts_json");
    const VeilRun r = runVeil(
        "ghosts examples/lenses/double_gauss_50mm.toml --field 0,0 "
        "-n 0 --grid 16 --no-images --json --coating 'L1.front=ideal_ar' -o " +
        out);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["ghosts"].size(), 45u);
    ASSERT_EQ(j["coating_changes"].size(), 1u);
    EXPECT_EQ(j["coating_changes"][0], "L1.front: uncoated -> ideal_ar");
    for (const auto& g : j["ghosts"]) {
        EXPECT_TRUE(g.contains("baseline_rank"));
        if (g["ghost"].get<std::string>().find("L1.front") != std::string::npos) {
            EXPECT_EQ(g["flux"].get<double>(), 0.0) << g["ghost"];
        }
    }
    EXPECT_EQ(j["sources"].size(), 1u);
}

TEST(VeilGhosts, BadInputNamesTheOptionAndExitsWithOne) {
    const std::string out = outDir("ghosts_bad");
    VeilRun r =
        runVeil("ghosts examples/lenses/singlet.toml -n 0 --coating 'L1.front' -o " + out);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("--coating 1"), std::string::npos) << r.err;
    r = runVeil("ghosts examples/lenses/singlet.toml -n 0 --coating 'L7.*=ideal_ar' -o " +
                out);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("matches no object"), std::string::npos) << r.err;
    r = runVeil("ghosts examples/lenses/singlet.toml -n 0 --field 3 -o " + out);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("--field 1"), std::string::npos) << r.err;
    r = runVeil("ghosts examples/scenes/catadioptric_2000mm_window.toml -n 0 -o " + out);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("window"), std::string::npos) << r.err;
    r = runVeil("ghosts examples/lenses/singlet.toml --order 3 -o " + out);
    EXPECT_EQ(r.exitCode, 2);
    // Nothing written by the failed runs.
    EXPECT_FALSE(std::filesystem::exists(out + "/ghosts.json"));
}

}  // namespace
