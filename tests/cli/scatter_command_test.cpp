// veil scatter as a user runs it, on the scene whose mounts use the bundled material library:
// every scattering property an object carries, their TIS against the published values they
// come from, plots and tables written, a written .bsdf read back by a scene, bad names refused.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "lensdata/zemax_bsdf.h"
#include "tests/cli/run_veil.h"

namespace {

namespace fs = std::filesystem;

const std::string kScene = "examples/scenes/double_gauss_50mm_painted.toml";

std::string dirFor(const std::string& what) {
    const std::string d = ::testing::TempDir() + "veil_scatter_" + what;
    fs::remove_all(d);
    return d;
}

const nlohmann::json& property(const nlohmann::json& j, const std::string& name) {
    for (const nlohmann::json& p : j.at("properties"))
        if (p.at("name") == name) return p;
    ADD_FAILURE() << "no property " << name << " in " << j.dump();
    static const nlohmann::json none;
    return none;
}

TEST(ScatterCommand, ReportsTheSceneMaterialsAndWritesTheirPlots) {
    const std::string dir = dirFor("scene");
    const VeilRun r = runVeil("scatter " + kScene + " --json -o " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j.at("wavelengths_nm").size(), 3u);  // the lens's
    ASSERT_EQ(j.at("properties").size(), 3u) << r.out;
    const nlohmann::json& paint = property(j, "black_polyurethane_paint");
    EXPECT_TRUE(paint.at("opaque_only").get<bool>());
    EXPECT_FALSE(paint.contains("transmit_tis"));
    for (const auto& row : paint.at("reflect_tis"))
        for (const auto& v : row) EXPECT_NEAR(v.get<double>(), 0.05, 1e-12);
    bool barrel = false;
    for (const auto& o : paint.at("objects")) barrel |= o == "barrel";
    EXPECT_TRUE(barrel);
    EXPECT_NEAR(property(j, "flat_black_paint_2pct").at("reflect_tis")[0][0].get<double>(), 0.02,
                1e-12);
    // The ground lens edges scatter both ways.
    EXPECT_NEAR(property(j, "ground_glass").at("transmit_tis")[0][0].get<double>(), 0.5, 1e-12);
    for (const char* f :
         {"scatter.md", "scatter.csv", "scatter.json", "tis_588nm.png",
          "brdf_black_polyurethane_paint.png", "btdf_ground_glass.png", "veil-run.json"})
        EXPECT_TRUE(fs::exists(fs::path(dir) / f)) << f;
}

// The library's models against the published numbers they come from.
TEST(ScatterCommand, LibraryMaterialsMatchTheirSources) {
    const VeilRun r = runVeil("scatter " + kScene +
                              " --property polished_mirror_kc_3nm --property "
                              "diamond_turned_al_6nm_650nm --wavelength 300 --wavelength 650 "
                              "--json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    // The K-correlation worked example: TIS 0.017 at 300 nm (the smooth-surface formula with
    // the band-limited 3.11 nm), on a mirror of reflectance 0.95. veil integrates
    // Rayleigh-Rice, whose cos(s) factor takes a few percent off that formula here.
    const double kc = property(j, "polished_mirror_kc_3nm").at("reflect_tis")[0][0];
    EXPECT_NEAR(kc, 0.95 * 0.017, 0.05 * 0.95 * 0.017) << kc;
    // The diamond-turned fit at 650 nm against Rayleigh-Rice for its 6 nm RMS.
    const double dt = property(j, "diamond_turned_al_6nm_650nm").at("reflect_tis")[0][1];
    const double rr = std::pow(4.0 * M_PI * 6.0 / 650.0, 2);
    EXPECT_NEAR(dt, rr, 0.06 * rr) << dt;
}

TEST(ScatterCommand, WrittenTablesReadBackAsTheModel) {
    const std::string dir = dirFor("bsdf");
    const VeilRun r =
        runVeil("scatter " + kScene +
                " --property dust_0p1pct_650nm --wavelength 650 --bsdf --quiet -o " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::string table = (fs::path(dir) / "dust_0p1pct_650nm.brdf.bsdf").string();
    const veil::ZemaxBsdf d = veil::readZemaxBsdf(table);
    EXPECT_FALSE(d.transmission);
    EXPECT_EQ(d.blocks.size(), 11u);
    // The bundled table is this file: written by this command from the same model.
    EXPECT_EQ(readText(table), readText(std::string(VEIL_SOURCE_DIR) +
                                        "/examples/materials/dust_0p1pct_650nm.brdf.bsdf"));
    // Read back through a scene, its TIS is the analytic model's within the grid's
    // interpolation error.
    const VeilRun back = runVeil("scatter " + kScene +
                                 " --property dust_0p1pct_650nm --property "
                                 "dust_0p1pct_650nm_table --wavelength 650 --json");
    ASSERT_EQ(back.exitCode, 0) << back.err;
    const nlohmann::json j = nlohmann::json::parse(back.out);
    const auto& a = property(j, "dust_0p1pct_650nm").at("reflect_tis");
    const auto& t = property(j, "dust_0p1pct_650nm_table").at("reflect_tis");
    for (size_t i = 0; i < a.size(); ++i)
        EXPECT_NEAR(t[i][0].get<double>(), a[i][0].get<double>(), 0.05 * a[i][0].get<double>())
            << "incidence row " << i;
}

TEST(ScatterCommand, UnknownOrNonScatteringPropertyIsAnError) {
    const std::string dir = dirFor("bad");
    VeilRun r = runVeil("scatter " + kScene + " --property black_paint -o " + dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("black_paint: no property of this name"), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir));
    r = runVeil("scatter " + kScene + " --property uncoated -o " + dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("uncoated: this property does not scatter"), std::string::npos) << r.err;
    r = runVeil("scatter " + kScene + " --wavelength 5 -o " + dir);
    EXPECT_EQ(r.exitCode, 2) << r.err;
}

}  // namespace
