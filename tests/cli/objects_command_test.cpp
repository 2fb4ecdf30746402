// veil objects from the command line: the table and the files on a good run, a clear error
// and nothing written on a bad name.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "run_veil.h"

namespace {

TEST(ObjectsCommand, WritesTheRankingAndItsPicture) {
    const std::string dir = ::testing::TempDir() + "veil_objects_cli";
    std::filesystem::remove_all(dir);
    const VeilRun r =
        runVeil("objects examples/scenes/longfocus_360mm_sun.toml -n 2k --quiet -o " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const char* f :
         {"objects.csv", "objects.md", "objects.json", "objects.png", "objects.svg"})
        EXPECT_TRUE(std::filesystem::exists(dir + "/" + f)) << f;
    std::ifstream in(dir + "/objects.json");
    const nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_EQ(j["ranked_by"], "product");
    // The Sun 7 degrees off axis lights the bore of spacer4b, between the stop and L5, and
    // the detector sees it: lit x seen 1.3e-4, twenty times the barrel's (which is lit and
    // seen on different sides), so it ranks first even with 2000 rays.
    EXPECT_EQ(j["objects"][0]["object"], "spacer4b");
    EXPECT_EQ(j["objects"][0]["rank"], 1);
    EXPECT_GT(j["objects"][0]["product"].get<double>(), 0.0);
    std::filesystem::remove_all(dir);
}

TEST(ObjectsCommand, AnUnknownSourceIsAnErrorBeforeAnyFile) {
    const std::string dir = ::testing::TempDir() + "veil_objects_cli_bad";
    std::filesystem::remove_all(dir);
    const VeilRun r =
        runVeil("objects examples/scenes/longfocus_360mm_sun.toml --source moon -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--source moon: no source 'moon' (the scene has sun)"), std::string::npos)
        << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
    const VeilRun rank =
        runVeil("objects examples/scenes/longfocus_360mm_sun.toml --rank area -o " + dir);
    EXPECT_EQ(rank.exitCode, 2);
    EXPECT_FALSE(std::filesystem::exists(dir));
}

}  // namespace
