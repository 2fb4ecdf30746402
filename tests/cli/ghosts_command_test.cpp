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

// Drawing the path pictures shows progress, ghost by ghost, and each one's search is bounded
// by what the Monte Carlo found (at most 4x the rays its hit rate says the picture takes).
TEST(VeilGhosts, PathPicturesShowProgressAndCostBoundedRays) {
    const std::string out = outDir("ghosts_progress");
    const VeilRun r = runVeil(
        "ghosts tests/data/zmx/US00583336-2-scaled.zmx -n 300 --top 2 "
        "--paths 20 --threads 1 -o " +
        out);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    for (const char* said : {"path picture 1 of 3: done, ", "path picture 2 of 3: done, ",
                             "path picture 3 of 3 (all ghosts): done, "})
        EXPECT_NE(r.err.find(said), std::string::npos) << said << "\n" << r.err;
    // The first ghost's search ends by 4 x 20 / (its hit rate) rays.
    const nlohmann::json j = nlohmann::json::parse(readText(out + "/ghosts.json"));
    const double relErr = j["ghosts"][0]["mc_relative_error"].get<double>();
    const double emitted = j["monte_carlo"]["emitted_rays"].get<double>();
    const double bound = std::max(2000.0, 4.0 * 20.0 * emitted * relErr * relErr);
    const size_t at = r.err.find("path picture 1 of 3: done, ");
    ASSERT_NE(at, std::string::npos);
    const double rays =
        std::stod(r.err.substr(at + std::string("path picture 1 of 3: done, ").size()));
    EXPECT_LE(rays, bound + 2000.0) << r.err;
}

// A toroidal face swept about its own centre of curvature is that sphere: its lens, built
// with the anamorphic code (faces to the edge, an edge cylinder ending on the curved rims,
// sags by interval enclosures), gives the spherical lens's ghost table.
TEST(VeilGhosts, ToroidSweptAboutItsCentreGivesTheSphericalLensGhosts) {
    const std::string dir = outDir("ghosts_toroid_sphere");
    std::filesystem::create_directories(dir);
    const std::string lens =
        "[system]\nwavelengths_nm = [587.5618]\naperture = { epd_mm = 10.0 }\n"
        "fields_deg = [0.0]\nsurfaces = [\n"
        "  { stop = true, r = 50.0, t = 5.0, glass = { nd = 1.5, vd = 0.0 }, sd = 7.0%s },\n"
        "  { r = inf, t = 46.7, sd = 7.0 },\n"
        "  { r = -80.0, t = 5.0, glass = { nd = 1.6, vd = 0.0 }, sd = 7.0%s },\n"
        "  { r = inf, t = 40.0, sd = 7.0 },\n]\n";
    auto write = [&](const std::string& name, const std::string& a, const std::string& b) {
        std::string text = lens;
        text.replace(text.find("%s"), 2, a);
        text.replace(text.find("%s"), 2, b);
        std::ofstream(dir + "/" + name) << text;
        return dir + "/" + name;
    };
    const std::string toroid =
        write("toroid.toml", ", toroidal = { x_r = 50.0 }", ", biconic = { x_r = -80.0 }");
    const std::string sphere = write("sphere.toml", "", "");
    auto ghosts = [&](const std::string& file) {
        const VeilRun r = runVeil("ghosts " + file + " -n 0 --no-images --json -o " + dir + "/out");
        EXPECT_EQ(r.exitCode, 0) << r.err;
        return nlohmann::json::parse(r.out)["ghosts"];
    };
    const nlohmann::json a = ghosts(toroid), b = ghosts(sphere);
    ASSERT_EQ(a.size(), 6u);
    ASSERT_EQ(a.size(), b.size());
    // On axis only: an oblique beam is widened by the first face's z range, which for the
    // toroid is an interval enclosure and for the sphere its samples, so its grid differs.
    for (size_t k = 0; k < a.size(); ++k) {
        EXPECT_EQ(a[k]["ghost"], b[k]["ghost"]);
        EXPECT_NEAR(a[k]["flux"].get<double>(), b[k]["flux"].get<double>(),
                    1e-9 * b[k]["flux"].get<double>())
            << a[k]["ghost"];
    }
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

// An option's bad value is a bad command line: exit 2 (docs/cli.md); the model's, 1.
TEST(VeilGhosts, BadInputNamesTheOptionAndExitsWithTwo) {
    const std::string out = outDir("ghosts_bad");
    VeilRun r =
        runVeil("ghosts examples/lenses/singlet.toml -n 0 --coating 'L1.front' -o " + out);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--coating 1"), std::string::npos) << r.err;
    r = runVeil("ghosts examples/lenses/singlet.toml -n 0 --coating 'L7.*=ideal_ar' -o " +
                out);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("matches no object"), std::string::npos) << r.err;
    r = runVeil("ghosts examples/lenses/singlet.toml -n 0 --field 3 -o " + out);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--field 1"), std::string::npos) << r.err;
    r = runVeil("ghosts examples/scenes/catadioptric_2000mm_window.toml -n 0 -o " + out);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("window"), std::string::npos) << r.err;
    r = runVeil("ghosts examples/lenses/singlet.toml --order 3 -o " + out);
    EXPECT_EQ(r.exitCode, 2);
    // A --pixels past the detectors' limit names the option; the Monte Carlo check's images
    // (one per ghost, the nominal path, all ghosts and the rest) are sized before any is taken.
    r = runVeil("ghosts examples/lenses/singlet.toml --pixels 7000 -o " + out);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--pixels: 7000 makes the detector 7000 x 7000 pixels, more than "
                         "33554432 in all"),
              std::string::npos)
        << r.err;
    r = runVeil("ghosts examples/lenses/cooke_triplet.toml --pixels 4096 --max-memory 1G -o " +
                out);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("the Monte Carlo check needs about 7."), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(18 images of 16777216 pixels: one per ghost"), std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("lower --pixels, or give -n 0 for the sequential estimate alone, or "
                         "raise --max-memory"),
              std::string::npos)
        << r.err;
    // Nothing written by the failed runs.
    EXPECT_FALSE(std::filesystem::exists(out + "/ghosts.json"));
}

}  // namespace
