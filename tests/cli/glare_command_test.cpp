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
    for (const char* f : {"glare.md", "glare.csv", "glare.json", "glare.png", "gsf.csv", "gsf.png",
                          "veil-run.json"})
        EXPECT_TRUE(fs::exists(fs::path(dir) / f)) << f;
    EXPECT_FALSE(veil_test::hasNonFinite(readText(dir + "/glare.csv")));
    EXPECT_FALSE(veil_test::hasNonFinite(readText(dir + "/gsf.csv")));
    // The GSF on axis only (the default), with the disc's field (the singlet's largest
    // field, 5 deg) rendered as its check; the GSF integrates to 1 over the disc.
    const nlohmann::json& g = j.at("fields")[0].at("gsf");
    EXPECT_FALSE(j.at("fields")[1].contains("gsf"));
    EXPECT_NEAR(g.at("field_deg").get<double>(), 5.0, 1e-6);
    EXPECT_TRUE(g.at("direct_vgi").contains("error"));
    const auto edges = g.at("edges_mm").get<std::vector<double>>();
    const auto gsf = g.at("gsf").get<std::vector<double>>();
    ASSERT_EQ(edges.size(), gsf.size() + 1);
    EXPECT_EQ(edges.back(), g.at("radius_mm").get<double>());
    double integral = 0.0;
    for (size_t a = 0; a < gsf.size(); ++a)
        integral += gsf[a] * M_PI * (edges[a + 1] * edges[a + 1] - edges[a] * edges[a]);
    EXPECT_NEAR(integral, 1.0, 0.02);
    EXPECT_NE(readText(dir + "/glare.md").find("VGI from GSF"), std::string::npos);
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
    r = runVeil("glare examples/lenses/singlet.toml --gsf some -o " + dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
    // A GSF disc inside the fine detector's reach (3.8 spot image radii, 1.66 mm here).
    r = runVeil("glare examples/lenses/singlet.toml --gsf-radius-mm 1 -o " + dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("--gsf-radius-mm: the GSF's disc (1 mm) must reach past"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(dir));
}

}  // namespace
