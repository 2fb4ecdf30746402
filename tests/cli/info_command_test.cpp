// `veil info` run as a user runs it: text, JSON on standard output, exit codes and messages.

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "run_veil.h"

namespace {

TEST(VeilInfo, JsonHasFirstOrderKeysForTheZemaxDoubleGauss) {
    const VeilRun r = runVeil("info tests/data/zmx/US00583336-2-scaled.zmx --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    // EFL derived by hand (y-nu at the d line, N-BAK1 1.57250, N-BALF4 1.57956): 49.389 mm.
    EXPECT_NEAR(j["efl_mm"].get<double>(), 49.389, 0.001);
    EXPECT_NEAR(j["f_number"].get<double>(), 4.5, 1e-9);
    EXPECT_NEAR(j["entrance_pupil_diameter_mm"].get<double>(), 49.389 / 4.5, 0.001);
    EXPECT_TRUE(j.contains("bfl_mm"));
    EXPECT_TRUE(j.contains("ffl_mm"));
    ASSERT_EQ(j["wavelengths"].size(), 3u);
    EXPECT_NEAR(j["primary_wavelength_nm"].get<double>(), 587.5618, 1e-9);
    // The F line focuses shorter than C for this uncorrected pair of crowns.
    EXPECT_LT(j["wavelengths"][0]["efl_mm"].get<double>(),
              j["wavelengths"][2]["efl_mm"].get<double>());
    EXPECT_EQ(j["surfaces"].size(), 14u);
    EXPECT_EQ(j["elements"].size(), 6u);
    EXPECT_EQ(j["spots"].size(), 9u);  // 3 fields x 3 wavelengths
    EXPECT_FALSE(j["import_report"].empty());
}

TEST(VeilInfo, TextOutputNamesTheSystemAndItsFocalLength) {
    const VeilRun r = runVeil("info tests/data/zmx/HoO-V2C18Ex27.zmx");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("effective focal length"), std::string::npos);
    EXPECT_NE(r.out.find("24.6087"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("M1"), std::string::npos);
}

TEST(VeilInfo, MissingFileIsAnErrorWithExitCode1) {
    const VeilRun r = runVeil("info no/such/lens.toml");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("no/such/lens.toml"), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty());
}

TEST(VeilInfo, MalformedZmxNamesFileLineAndColumn) {
    const VeilRun r = runVeil("info tests/data/zmx/malformed_number.zmx");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("malformed_number.zmx:"), std::string::npos) << r.err;
    EXPECT_TRUE(r.out.empty());
}

TEST(VeilInfo, UnknownTomlKeyNamesItsPosition) {
    const std::string path = ::testing::TempDir() + "veil_cli_typo.toml";
    FILE* f = fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    fputs(
        "[system]\naperture = { epd_mm = 10 }\nsurfaces = [\n  { r = 50, t = 5, glass = \"N-BK7\", "
        "stop = true },\n  { r = -50, t = 45, thikness = 3 },\n]\n",
        f);
    fclose(f);
    const VeilRun r = runVeil("info " + path);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("veil_cli_typo.toml:5:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("thikness"), std::string::npos) << r.err;
}

// info builds the scene trace would build: what was fitted is a table, in JSON too.
TEST(VeilInfo, SaysWhetherTheLensBuildsAndWhatWasFittedToBuildIt) {
    const VeilRun r = runVeil("info tests/data/codev/lens_reflection_test.seq");
    EXPECT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("Scene build: the lens builds"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("Sized to fit: the file's sizes do not build"), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("L1       L1.front      0.875 -> 0.7"), std::string::npos) << r.out;
    const VeilRun j = runVeil("info tests/data/codev/lens_reflection_test.seq --json");
    ASSERT_EQ(j.exitCode, 0) << j.err;
    const nlohmann::json b = nlohmann::json::parse(j.out)["scene_build"];
    EXPECT_TRUE(b["built"].get<bool>());
    ASSERT_EQ(b["size_changes"].size(), 1u);
    EXPECT_EQ(b["size_changes"][0]["element"], "L1");
    EXPECT_EQ(b["size_changes"][0]["outer_radius_mm_file"], 0.875);
}

// A lens whose light needs glass that cannot be there: first-order data still print, and
// the exit code says it does not build, with what fits.
TEST(VeilInfo, ALensThatCannotBeBuiltExitsWith1AndSaysWhatFits) {
    const std::string path = ::testing::TempDir() + "veil_info_crossing.toml";
    {
        std::ofstream out(path);
        // R +-50, 1 mm thick: the edge closes at r = 7.05 mm, and the f/3 beam needs 8.
        out << "[system]\nname = \"too thin\"\nwavelengths_nm = [587.5618]\n"
               "aperture = { epd_mm = 16.0 }\nfields_deg = [0.0]\nsurfaces = [\n"
               "  { stop = true, t = 1.0 },\n  { r = 50.0, t = 1.0, glass = \"N-BK7\", sd = 10 },\n"
               "  { r = -50.0, t = 48.0, sd = 10 },\n]\n";
    }
    const VeilRun r = runVeil("info " + path);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.out.find("effective focal length"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("Scene build: FAILED: L1.front: its faces L1.front and L1.back cross "
                         "inside the light"),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.err.find("the largest semi-diameter that fits is 7.05"), std::string::npos)
        << r.err;
    std::filesystem::remove(path);
}

TEST(VeilInfo, BadCommandLineExitsWith2) {
    EXPECT_EQ(runVeil("info").exitCode, 2);
    EXPECT_EQ(runVeil("frobnicate x").exitCode, 2);
}

}  // namespace

namespace {

// Every example lens runs through `veil info --json` and reports a finite focal length.
TEST(VeilInfo, EveryExampleLensRuns) {
    for (const char* name :
         {"singlet", "achromat", "cooke_triplet", "double_gauss_50mm", "longfocus_360mm",
          "catadioptric_2000mm", "newtonian_500mm", "anamorphic_cylinders"}) {
        const VeilRun r = runVeil(std::string("info examples/lenses/") + name + ".toml --json");
        ASSERT_EQ(r.exitCode, 0) << name << ": " << r.err;
        const nlohmann::json j = nlohmann::json::parse(r.out);
        EXPECT_TRUE(j["efl_mm"].is_number()) << name;
        EXPECT_TRUE(j["import_report"].empty()) << name << ": " << j["import_report"].dump();
        for (const auto& s : j["spots"]) EXPECT_GT(s["rays_landed"].get<int>(), 0) << name;
    }
    // The Newtonian's fold: its two breaks, as the file gives them.
    const nlohmann::json j =
        nlohmann::json::parse(runVeil("info examples/lenses/newtonian_500mm.toml --json").out);
    int breaks = 0;
    for (const auto& s : j["surfaces"])
        if (s.contains("coordinate_break")) {
            ++breaks;
            EXPECT_EQ(s["coordinate_break"]["tilt_deg"][0].get<double>(), 45.0);
        }
    EXPECT_EQ(breaks, 2);
}

}  // namespace

namespace {

// A lens using a glass only a user catalog has: unknown without the catalog, found with
// --glass-catalog FILE or with VEIL_GLASS_PATH.
TEST(VeilInfo, UserGlassCatalogFromOptionAndEnvironment) {
    const std::string lens = ::testing::TempDir() + "veil_cli_userglass.toml";
    FILE* f = fopen(lens.c_str(), "w");
    ASSERT_TRUE(f);
    fputs(
        "[system]\naperture = { epd_mm = 10 }\nsurfaces = [\n"
        "  { r = 50, t = 5, glass = \"TESTSELL\", stop = true },\n  { r = -50, t = 45 },\n]\n",
        f);
    fclose(f);
    const VeilRun without = runVeil("info " + lens + " --json");
    EXPECT_EQ(without.exitCode, 1);
    EXPECT_NE(without.err.find("TESTSELL"), std::string::npos) << without.err;
    // The error points at the glass in the file and at the fix.
    EXPECT_NE(without.err.find(lens + ":4:"), std::string::npos) << without.err;
    EXPECT_NE(without.err.find("--glass-catalog"), std::string::npos) << without.err;
    EXPECT_NE(without.err.find("VEIL_GLASS_PATH"), std::string::npos) << without.err;

    const VeilRun option =
        runVeil("--glass-catalog tests/data/glass/sample.agf info " + lens + " --json");
    ASSERT_EQ(option.exitCode, 0) << option.err;
    const VeilRun env =
        runVeil("info " + lens + " --json", "VEIL_GLASS_PATH=tests/data/glass/sample.agf");
    ASSERT_EQ(env.exitCode, 0) << env.err;
    // The option works after the command too.
    const VeilRun after =
        runVeil("info " + lens + " --json --glass-catalog tests/data/glass/sample.agf");
    ASSERT_EQ(after.exitCode, 0) << after.err;
    EXPECT_EQ(after.out, option.out);
    // Same glass, same answer; and it is TESTSELL's nd 1.62004 at work: a thick lens
    // R = +-50, t = 5 has f = 1 / ((n-1)(2/50 - (n-1) 5 / (n 2500))).
    const double n = 1.62004;
    const double fExpected = 1.0 / ((n - 1.0) * (2.0 / 50.0 - (n - 1.0) * 5.0 / (n * 2500.0)));
    const double efl = nlohmann::json::parse(option.out)["efl_mm"].get<double>();
    EXPECT_NEAR(efl, fExpected, 1e-4);
    EXPECT_EQ(efl, nlohmann::json::parse(env.out)["efl_mm"].get<double>());
}

// A .zmx glass that no loaded catalog has, with no nd/Vd to fall back on: the error names
// the file, line and column of its GLAS line and the two ways to supply a catalog.
TEST(VeilInfo, UnknownZmxGlassNamesItsLineAndTheFix) {
    const VeilRun r = runVeil("info tests/data/zmx/unknown_glass.zmx");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("tests/data/zmx/unknown_glass.zmx:26:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("unknown glass 'UNOBTAINIUM'"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("--glass-catalog"), std::string::npos) << r.err;
}

// An anamorphic lens: `veil info` gives both sections' first-order data (the test file's
// hand computation: 100 mm in y, 50 mm in x, both focused on the image) and traces the
// spots; it traces in 3D, and [mechanics] stops before any work, naming the surface.
TEST(VeilInfo, AnamorphicLensHasBothSections) {
    const VeilRun r = runVeil("info --json tests/data/toml/crossed_cylinders.toml");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_NEAR(j["efl_mm"].get<double>(), 100.0, 1e-9);
    EXPECT_NEAR(j["x_section"]["efl_mm"].get<double>(), 50.0, 1e-9);
    EXPECT_NEAR(j["paraxial_image_from_image_surface_mm"].get<double>(), 0.0, 1e-9);
    EXPECT_NEAR(j["x_section"]["paraxial_image_from_image_surface_mm"].get<double>(), 0.0, 1e-9);
    EXPECT_TRUE(j["surfaces"][1]["toroidal"]["x_radius_mm"].is_null());  // infinite
    EXPECT_EQ(j["surfaces"][3]["toroidal"]["x_radius_mm"].get<double>(), 25.0);
    EXPECT_EQ(j["spots"][0]["rays_landed"], j["spots"][0]["rays_traced"]);

    const VeilRun text = runVeil("info tests/data/toml/crossed_cylinders.toml");
    EXPECT_NE(text.out.find("TOROIDAL x_r=25"), std::string::npos) << text.out;
    EXPECT_NE(text.out.find("x-z section"), std::string::npos) << text.out;

    const std::string dir = ::testing::TempDir() + "veil_anamorphic_trace";
    const VeilRun trace =
        runVeil("trace tests/data/toml/crossed_cylinders.toml --rays 10 --quiet -o " + dir);
    EXPECT_EQ(trace.exitCode, 0) << trace.err;
    // The mount generator stops before any work, naming the surface.
    std::ifstream in(std::string(VEIL_SOURCE_DIR) + "/examples/lenses/anamorphic_cylinders.toml");
    std::ofstream(dir + "/mounted.toml") << in.rdbuf() << "\n[mechanics]\n";
    const VeilRun mounted = runVeil("trace " + dir + "/mounted.toml --rays 10 -o " + dir + "/m");
    EXPECT_EQ(mounted.exitCode, 1);
    EXPECT_NE(mounted.err.find("mechanics: the mount generator seats lenses on rims of "
                               "revolution, and L1.front is toroidal"),
              std::string::npos)
        << mounted.err;
    EXPECT_FALSE(std::filesystem::exists(dir + "/m/summary.json"));
}

// A spot that no ray reaches has no centroid and no size: "n/a" with the reason in the text,
// null in the JSON, never a 0.000000 that reads as a perfect focus.
TEST(VeilInfo, SpotWithoutRaysIsNotAvailable) {
    const std::string dir = ::testing::TempDir() + "veil_spot_na";
    std::filesystem::create_directories(dir);
    std::ifstream in(std::string(VEIL_SOURCE_DIR) + "/examples/lenses/singlet.toml");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // The image surface vignettes at 1 mm: the 3.5 and 5 degree fields land nowhere.
    text.replace(text.rfind("]"), 1, "  { image = true, sd = 1.0 },\n]");
    std::ofstream(dir + "/vignetted.toml") << text;
    const VeilRun r = runVeil("info " + dir + "/vignetted.toml");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("0/217                         n/a             n/a"), std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("n/a: no ray of the bundle landed on the image surface"),
              std::string::npos);
    EXPECT_EQ(r.out.find("nan"), std::string::npos);
    const nlohmann::json j =
        nlohmann::json::parse(runVeil("info --json " + dir + "/vignetted.toml").out);
    const nlohmann::json& s = j["spots"].back();
    EXPECT_EQ(s["rays_landed"].get<int>(), 0);
    EXPECT_TRUE(s["rms_radius_mm"].is_null());
    EXPECT_TRUE(s["centroid_x_mm"].is_null());
    EXPECT_GT(j["spots"][0]["rms_radius_mm"].get<double>(), 0.0);
}

// A surface type veil does not model is an error that stops the command (exit 1) before
// anything is built, named at its line, with every other error of the import after it.
TEST(VeilInfo, UnsupportedSurfaceTypesStopWithEveryErrorNamed) {
    const VeilRun r = runVeil("info tests/data/zmx/unsupported.zmx");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("tests/data/zmx/unsupported.zmx:28:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("surface type IRREGULA"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("tests/data/zmx/unsupported.zmx:38:"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("surface type SZERNSAG"), std::string::npos) << r.err;
    EXPECT_EQ(r.out, "");
}

}  // namespace

namespace {

// `veil layout` writes an SVG and a PNG; `veil export` writes OBJ groups named after the
// scene's objects; nothing is left behind under a temporary name.
TEST(VeilLayout, WritesSvgAndPngOfASceneWithMechanics) {
    const std::string dir = ::testing::TempDir() + "veil_layout_test";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const VeilRun r =
        runVeil("layout examples/scenes/double_gauss_50mm.toml -o " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("wrote 2 files in " + dir + ": layout.svg, layout.png"), std::string::npos)
        << r.out;
    std::ifstream svg(dir + "/layout.svg");
    const std::string text((std::istreambuf_iterator<char>(svg)), std::istreambuf_iterator<char>());
    EXPECT_NE(text.find("<svg"), std::string::npos);
    std::ifstream png(dir + "/layout.png", std::ios::binary);
    char magic[8] = {};
    png.read(magic, 8);
    EXPECT_EQ(std::string(magic + 1, 3), "PNG");
    // Written under a temporary name and renamed: nothing else is left in the folder but
    // the run's manifest.
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
        const std::string ext = e.path().extension().string();
        EXPECT_TRUE(ext == ".png" || ext == ".svg" || e.path().filename() == "veil-run.json")
            << e.path();
    }
}

TEST(VeilExport, WritesObjGroupsForEveryObject) {
    const std::string out = ::testing::TempDir() + "veil_export_test.obj";
    const VeilRun r = runVeil("export examples/scenes/longfocus_360mm.toml -o " + out);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    std::ifstream obj(out);
    const std::string text((std::istreambuf_iterator<char>(obj)), std::istreambuf_iterator<char>());
    for (const char* name : {"g L4.front", "g L4.back", "g L4.edge", "g stop.edge", "g barrel",
                             "g spacer", "g sensor"})
        EXPECT_NE(text.find(name), std::string::npos) << name;
}

TEST(VeilLayout, CollidingMechanicsNameBothParts) {
    const std::string path = ::testing::TempDir() + "veil_collide.toml";
    FILE* f = fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    fprintf(f,
            "lens = \"%s/examples/lenses/double_gauss_50mm.toml\"\n[mechanics]\n"
            "barrel = { clearance_mm = 0.001 }\n",
            VEIL_SOURCE_DIR);
    fclose(f);
    const VeilRun r = runVeil("layout " + path + " -o " + ::testing::TempDir() + "collide");
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("barrel: collides with L"), std::string::npos) << r.err;
}

}  // namespace

namespace {

// The Sun example scene runs end to end with a small ray budget: images, summary, budget.
TEST(VeilTrace, SunSceneWritesImagesAndABalancedBudget) {
    const std::string dir = ::testing::TempDir() + "veil_trace_test";
    std::filesystem::remove_all(dir);
    const VeilRun r = runVeil(
        "trace examples/scenes/longfocus_360mm_sun.toml -n 300 --threads 1 "
        "--quiet -o " +
        dir + " --save-rays " + dir + "/rays.vrdb");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(std::filesystem::exists(dir + "/sensor_image.exr"));
    EXPECT_TRUE(std::filesystem::exists(dir + "/sensor_image.png"));
    std::ifstream js(dir + "/summary.json");
    const nlohmann::json j = nlohmann::json::parse(js);
    const double emitted = j["budget"]["emitted"].get<double>();
    EXPECT_GT(emitted, 0.9);
    EXPECT_LT(std::abs(j["budget"]["imbalance"].get<double>()), 1e-12 * emitted);
    const double detected = j["detectors"][0]["flux"].get<double>();
    EXPECT_GT(detected, 0.0);  // stray light reaches the sensor although the Sun is off field
    EXPECT_LT(detected, 0.05 * emitted);
    // The saved histories give the same detector flux back.
    const VeilRun rays = runVeil("rays --json " + dir + "/rays.vrdb");
    ASSERT_EQ(rays.exitCode, 0) << rays.err;
    const nlohmann::json s = nlohmann::json::parse(rays.out);
    EXPECT_EQ(s["rays"].get<int>(), 300);
    EXPECT_NEAR(s["detected_flux"]["sensor"].get<double>(), detected, 1e-6 * detected);
}

// --where splits the detector flux by criterion; the layers and the rest add up to the whole.
TEST(VeilTrace, WhereSplitsTheDetectorFluxByCriterion) {
    const std::string dir = ::testing::TempDir() + "veil_where_test";
    std::filesystem::remove_all(dir);
    const VeilRun r =
        runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 300 --quiet -o " + dir +
                " --where 'seq(fresnel, fresnel, hit(sensor))' --where 'scatter(stop.edge)'");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    std::ifstream js(dir + "/summary.json");
    const nlohmann::json j = nlohmann::json::parse(js);
    const auto& d = j["detectors"][0];
    ASSERT_EQ(d["by_criterion"].size(), 3u);
    double sum = 0.0;
    for (const auto& c : d["by_criterion"]) sum += c["flux"].get<double>();
    // Criteria may overlap: their sum is at least the whole, and equal when they do not.
    EXPECT_GE(sum, d["flux"].get<double>() * (1.0 - 1e-12));
    EXPECT_TRUE(std::filesystem::exists(dir + "/sensor_image.where1.png"));
    // A criterion naming an unknown object fails before tracing, with its column.
    const VeilRun bad = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 10 --quiet -o " +
                                dir + " --where 'hit(L9.front)'");
    EXPECT_EQ(bad.exitCode, 2);
    EXPECT_NE(bad.err.find("--where 1:1:5"), std::string::npos) << bad.err;
    EXPECT_NE(bad.err.find("the scene's objects are L1.front, L1.flat1"), std::string::npos)
        << bad.err;
    // The detector's own name ([detector] name = "sensor_image") names its object, as the
    // report shows it; the same flux as by the object's name.
    const VeilRun byDetector = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 100 "
                                       "--json --where 'detector(sensor_image)'");
    const VeilRun byObject = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 100 "
                                     "--json --where 'detector(sensor)'");
    ASSERT_EQ(byDetector.exitCode, 0) << byDetector.err;
    ASSERT_EQ(byObject.exitCode, 0) << byObject.err;
    const auto flux = [](const VeilRun& run) {
        return nlohmann::json::parse(run.out)["detectors"][0]["by_criterion"][0]["flux"]
            .get<double>();
    };
    EXPECT_GT(flux(byDetector), 0.0);
    EXPECT_EQ(flux(byDetector), flux(byObject));
}

// --prune says how many branches it stopped, and warns when it stopped none (a criterion
// that can only fail when a path ends prunes nothing and costs the same).
TEST(VeilTrace, PruneSaysWhatItPruned) {
    const VeilRun none = runVeil(
        "trace examples/scenes/longfocus_360mm_sun.toml -n 100 --json --prune "
        "--where 'seq(fresnel(L4.back), fresnel(L4.front), hit(sensor))'");
    ASSERT_EQ(none.exitCode, 0) << none.err;
    EXPECT_EQ(nlohmann::json::parse(none.out)["budget"]["pruned_branches"].get<int>(), 0);
    EXPECT_NE(none.err.find("warning: --prune stopped no branch"), std::string::npos) << none.err;
    const VeilRun some = runVeil(
        "trace examples/scenes/longfocus_360mm_sun.toml -n 100 --json --prune "
        "--where 'fresnel{2} and not scatter'");
    ASSERT_EQ(some.exitCode, 0) << some.err;
    EXPECT_GT(nlohmann::json::parse(some.out)["budget"]["pruned_branches"].get<int>(), 100);
    EXPECT_EQ(some.err.find("--prune stopped no branch"), std::string::npos) << some.err;
}

// Input that once crashed or never finished stops at once with exit 1 and a message that
// names the option or the file position: an unbounded split tree, nan options, seeds that
// would wrap, an object id past size_t, criteria nested thousands deep, a dotted key of
// 30000 parts, sources 1e19 mm away. Nothing is written.
TEST(VeilTrace, HostileInputStopsBeforeTracing) {
    const std::string dir = ::testing::TempDir() + "veil_hostile";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::string lens = " examples/lenses/singlet.toml -n 10 --quiet -o " + dir + "/out";
    auto expectStop = [&](const std::string& args, const std::string& fragment) {
        SCOPED_TRACE(args);
        const VeilRun r = runVeil(args);
        EXPECT_NE(r.exitCode, 0);
        EXPECT_NE(r.err.find(fragment), std::string::npos) << r.err;
        EXPECT_FALSE(std::filesystem::exists(dir + "/out/summary.json"));
    };
    expectStop("trace" + lens + " --min-flux 0", "--min-flux: 0 in split mode");
    expectStop("trace" + lens + " --min-flux nan", "--min-flux: value nan not in range");
    expectStop("trace" + lens + " --roulette nan", "--roulette: value nan not in range");
    expectStop("trace" + lens + " --min-flux 0.01 --rescue-flux 0.001",
               "--rescue-flux: must be at least --min-flux (0.01)");
    expectStop("trace" + lens + " --seed -1", "--seed -1 is not a whole number");
    expectStop("trace" + lens + " --seed 99999999999999999999", "is not a whole number");
    expectStop("trace" + lens + " --where 'hit(#18446744073709551617)'",
               "'#18446744073709551617' matches no object");
    expectStop("trace" + lens + " --where '" + std::string(6000, '(') + "hit(L1.front)" +
                   std::string(6000, ')') + "'",
               "--where 1:1:201: the criterion nests groups");
    // Still bounded: roulette alone, or a shallow tree.
    EXPECT_EQ(runVeil("trace" + lens + " --min-flux 0 --roulette 0.01").exitCode, 0);
    EXPECT_EQ(runVeil("trace" + lens + " --min-flux 0 --max-split-depth 8").exitCode, 0);
    std::filesystem::remove_all(dir + "/out");

    std::string key = "k";
    for (int i = 1; i < 30000; ++i) key += ".k";
    std::ofstream(dir + "/deep.toml") << key << " = 1\n";
    expectStop("info " + dir + "/deep.toml", dir + "/deep.toml:1:256: a dotted key of more than");

    std::ifstream in(std::string(VEIL_SOURCE_DIR) + "/examples/lenses/singlet.toml");
    std::ofstream(dir + "/far.toml")
        << in.rdbuf() << "\n[[source]]\nkind = \"point\"\nposition_mm = [0, 0, -1e19]\n";
    expectStop("trace " + dir + "/far.toml -n 10 -o " + dir + "/out",
               "far.toml:39:22: source[1].position_mm[3] must be between -1e+09 and 1e+09");

    // Outputs that could only fail after the trace are checked first: -o naming a file,
    // --save-rays naming a folder, a folder in which nothing can be created, and a detector
    // whose pixels OpenEXR would refuse (24 x 1e-7 mm).
    std::ofstream(dir + "/a_file") << "x";
    expectStop("trace examples/lenses/singlet.toml -n 10 -o " + dir + "/a_file",
               "-o " + dir + "/a_file: is a file, not a folder");
    expectStop("trace" + lens + " --save-rays " + dir, "--save-rays " + dir + ": is a folder");
    expectStop("trace examples/lenses/singlet.toml -n 10 -o /proc/veil_out",
               "-o /proc/veil_out: veil cannot create files in /proc");
    std::ifstream in2(std::string(VEIL_SOURCE_DIR) + "/examples/lenses/singlet.toml");
    std::ofstream(dir + "/thin.toml") << in2.rdbuf()
                                      << "\n[[detector]]\nname = \"thin\"\nz_mm = 100\n"
                                         "size_mm = [24, 1e-7]\n";
    expectStop("trace " + dir + "/thin.toml -n 10 -o " + dir + "/out",
               "thin.toml:37:1: detector 'thin': its pixels are 0.09375 x 1e-07 mm");
}

// A Cassegrain file (tests/data/README.md) gives no hole in its primary: a sequential trace
// passes it. The scene opens one where the light comes back, says so, and the on-axis beam
// (filling surface 1, radius 10.291 mm) reaches the image through the annulus of the
// primary (10.031 mm) outside the secondary's shadow (3.3367 mm): (10.031^2 - 3.3367^2) /
// 10.291^2 of it, within 4 binomial sigmas.
TEST(VeilTrace, ACassegrainGetsTheHoleItsLightComesBackThrough) {
    const std::string out = ::testing::TempDir() + "veil_cassegrain_hole";
    const VeilRun r = runVeil(
        "trace tests/data/zmx/HoO-V2C18Ex03.zmx -n 20000 --field 0,0 "
        "--seed 3 --json -o " +
        out);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("M1: a central hole of 2.1"), std::string::npos) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    const double detected = j["detectors"][0]["flux"].get<double>();
    const double emitted = j["budget"]["emitted"].get<double>();
    const double expected = (10.031 * 10.031 - 3.3367 * 3.3367) / (10.291 * 10.291);
    const double sigma = std::sqrt(expected * (1.0 - expected) / 20000.0);
    EXPECT_NEAR(detected / emitted, expected, 4.0 * sigma);
    std::filesystem::remove_all(out);
}

// Studies that build their scenes themselves show the lens's import warnings, --quiet keeps
// the results (it drops progress and the list of files), and a sweep none of whose variants
// could be run exits 1.
TEST(VeilStudies, WarningsShowQuietKeepsResultsAndASweepThatRanNothingFails) {
    const std::string out = ::testing::TempDir() + "veil_studies_warnings";
    const VeilRun pst = runVeil(
        "pst tests/data/codev/lens_reflection_test.seq --angles 5 -n 50 "
        "--quiet -o " +
        out + "/pst");
    ASSERT_EQ(pst.exitCode, 0) << pst.err;
    EXPECT_NE(pst.err.find("warning: sized to fit: L1: "), std::string::npos) << pst.err;
    EXPECT_NE(pst.out.find("| angle (deg) | in field | PST total"), std::string::npos) << pst.out;
    EXPECT_EQ(pst.out.find("wrote "), std::string::npos) << pst.out;
    const VeilRun sweep = runVeil(
        "sweep examples/lenses/singlet.toml --vary system.surfaces[2].r=59.26,60 -n 20 "
        "--where 'hit(nothing)' --quiet -o " +
        out + "/sweep");
    EXPECT_EQ(sweep.exitCode, 1);
    EXPECT_NE(sweep.out.find("2 could not be run"), std::string::npos) << sweep.out;
    EXPECT_NE(sweep.err.find("veil: error: no variant could be run; the first one's error: "
                             "--where 1:1:5: object pattern 'nothing' matches no object"),
              std::string::npos)
        << sweep.err;
    std::filesystem::remove_all(out);
}

// A scene without [[source]] is traced with one beam per system field, and says so.
TEST(VeilTrace, SceneWithoutSourceTracesTheSystemFields) {
    const VeilRun r = runVeil("trace examples/scenes/double_gauss_50mm.toml -n 20 --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("has no [[source]]: tracing one collimated beam per system field "
                         "(0,0; 0,10; 0,15; 0,22 deg"),
              std::string::npos)
        << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_GT(j["detectors"][0]["flux"].get<double>(), 0.0);
    // --field replaces them, without the note.
    const VeilRun f =
        runVeil("trace examples/scenes/double_gauss_50mm.toml -n 20 --json --field 0,5");
    ASSERT_EQ(f.exitCode, 0) << f.err;
    EXPECT_EQ(f.err.find("no [[source]]"), std::string::npos) << f.err;
    const double one = nlohmann::json::parse(f.out)["budget"]["emitted"].get<double>();
    EXPECT_LT(one, 0.5 * j["budget"]["emitted"].get<double>());
}

}  // namespace

namespace {

// An imported lens as veil's own lens file: export-lens writes it, and it is the same lens
// (veil info gives the same EFL and F/# to the last digit); --set edits an imported lens
// through the same text, with its errors named "FILE as TOML".
TEST(VeilExportLens, AnImportedLensIsWrittenAsTomlAndEditedWithSet) {
    const std::string dir = ::testing::TempDir() + "veil_export_lens";
    std::filesystem::remove_all(dir);
    for (const std::string file :
         {"tests/data/zmx/US00583336-2-scaled.zmx", "tests/data/codev/double_gauss_50mm.seq"}) {
        const std::string out = dir + "/" + std::filesystem::path(file).stem().string() + ".toml";
        const VeilRun w = runVeil("export-lens " + file + " -o " + out);
        ASSERT_EQ(w.exitCode, 0) << w.err;
        EXPECT_NE(w.out.find("written as a veil lens file"), std::string::npos) << w.out;
        const VeilRun a = runVeil("info " + file + " --json");
        const VeilRun b = runVeil("info " + out + " --json");
        ASSERT_EQ(a.exitCode, 0) << a.err;
        ASSERT_EQ(b.exitCode, 0) << b.err;
        const nlohmann::json ja = nlohmann::json::parse(a.out), jb = nlohmann::json::parse(b.out);
        EXPECT_EQ(ja["efl_mm"].get<double>(), jb["efl_mm"].get<double>()) << file;
        EXPECT_EQ(ja["f_number"].get<double>(), jb["f_number"].get<double>()) << file;
        EXPECT_EQ(ja["surfaces"].size(), jb["surfaces"].size()) << file;
        // Without -o, the text on standard output.
        const VeilRun s = runVeil("export-lens " + file);
        ASSERT_EQ(s.exitCode, 0) << s.err;
        EXPECT_EQ(s.out, readText(out));
    }
    const std::string zmx = "tests/data/zmx/US00583336-2-scaled.zmx";
    const VeilRun f2 = runVeil("info " + zmx + " --set system.aperture.f_number=2 --json");
    ASSERT_EQ(f2.exitCode, 0) << f2.err;
    EXPECT_EQ(nlohmann::json::parse(f2.out)["f_number"].get<double>(), 2.0);
    // The second row's thickness (L1's glass) changes the focal length.
    const VeilRun t = runVeil("info " + zmx + " --set 'system.surfaces[2].t=2.0' --json");
    ASSERT_EQ(t.exitCode, 0) << t.err;
    const VeilRun base = runVeil("info " + zmx + " --json");
    EXPECT_NE(nlohmann::json::parse(t.out)["efl_mm"].get<double>(),
              nlohmann::json::parse(base.out)["efl_mm"].get<double>());
    const VeilRun typo = runVeil("info " + zmx + " --set 'system.surfacez[1].t=2'");
    EXPECT_NE(typo.exitCode, 0);
    EXPECT_NE(typo.err.find("no 'surfacez' in [system] of " + zmx +
                            " as TOML (did you mean 'surfaces'?)"),
              std::string::npos)
        << typo.err;
    std::filesystem::remove_all(dir);
}

}  // namespace
