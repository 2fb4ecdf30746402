// veil glare as a user runs it: the report and its files, the spot's position and the
// parts adding up; positions the bench cannot measure refused before any render.

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/cli/run_veil.h"
#include "tests/text_checks.h"

namespace {

namespace fs = std::filesystem;

std::string dirFor(const std::string& what) {
    const std::string d = ::testing::TempDir() + "veil_glare_" + what;
    fs::remove_all(d);
    return d;
}

TEST(GlareCommand, ReportsEachPositionWithItsParts) {
    const std::string dir = dirFor("singlet");
    const VeilRun r = runVeil(
        "glare examples/lenses/singlet.toml --field 0,0 --field 0,3.5 --passes 3 --photons 5k "
        "--rays-per-pixel 16 --json -o " +
        dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    ASSERT_EQ(j.at("fields").size(), 2u);
    EXPECT_EQ(j.at("unit"), "lm");
    EXPECT_NE(j.at("spectrum").get<std::string>().find("V(lambda)"), std::string::npos);
    for (const auto& f : j.at("fields")) {
        const double vgi = f.at("vgi").at("value"), s = f.at("specular").at("value"),
                     d = f.at("diffuse").at("value");
        EXPECT_GT(vgi, 0.0);
        EXPECT_LT(vgi, 1.0);
        EXPECT_NEAR(vgi, s + d, 1e-12 * vgi);
        EXPECT_GT(f.at("white").at("value").get<double>(), 0.0);
    }
    EXPECT_NEAR(j.at("fields")[1].at("image_mm")[1].get<double>(), 6.1, 0.1);
    for (const char* f : {"glare.md", "glare.csv", "glare.json", "glare.png", "veil-run.json"})
        EXPECT_TRUE(fs::exists(fs::path(dir) / f)) << f;
    EXPECT_FALSE(veil_test::hasNonFinite(readText(dir + "/glare.csv")));
}

TEST(GlareCommand, PositionsItCannotMeasureAreRefusedFirst) {
    const std::string dir = dirFor("bad");
    VeilRun r = runVeil("glare examples/lenses/singlet.toml --field 0,85 -o " + dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("field 0,85: the black spot reaches past the bright field"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(dir));
    r = runVeil("glare examples/lenses/singlet.toml --spot-deg 0 -o " + dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    r = runVeil("glare examples/lenses/singlet.toml --field-deg 95 -o " + dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
}

}  // namespace
