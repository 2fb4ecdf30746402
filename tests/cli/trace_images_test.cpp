// The EXR images `veil trace` writes, read back with readDetectorExr(): the scaled channels
// (analysis/reports/image_output.h) come back in physical units and add up to summary.json's flux.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <numeric>
#include <string>
#include <utility>
#include <vector>

#include "analysis/reports/image_output.h"
#include "run_veil.h"

namespace {

TEST(VeilTrace, ExrImagesReadBackToTheSummaryFlux) {
    const std::filesystem::path dir =
        std::filesystem::path(::testing::TempDir()) / "veil_trace_images";
    std::filesystem::remove_all(dir);
    const VeilRun r = runVeil(
        "trace examples/scenes/longfocus_360mm_sun.toml -n 400 "
        "--threads 1 --quiet -o " +
        dir.string());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    std::ifstream js(dir / "summary.json");
    const nlohmann::json j = nlohmann::json::parse(js);
    ASSERT_EQ(j["detectors"].size(), 1u);
    const std::string name = j["detectors"][0]["name"].get<std::string>();
    const double summaryFlux = j["detectors"][0]["flux"].get<double>();
    ASSERT_GT(summaryFlux, 0.0);

    const veil::DetectorExr e = veil::readDetectorExr(dir / (name + ".exr"));
    ASSERT_EQ(e.layers.size(), 1u) << e;
    const veil::ExrLayer& l = e.layers[0];
    EXPECT_EQ(e.fluxUnit, "W");
    EXPECT_EQ(e.emittedRays, 400.0);
    EXPECT_DOUBLE_EQ(l.totalFlux, summaryFlux);
    // Each pixel is off by float rounding (2^-24 relative) at most, so the sum is too.
    const double sum = std::accumulate(l.value.begin(), l.value.end(), 0.0);
    EXPECT_NEAR(sum, summaryFlux, summaryFlux * std::numeric_limits<float>::epsilon());
    const double areaMm2 = e.pixelSizeMm.x * e.pixelSizeMm.y;
    for (size_t p = 0; p < l.value.size(); ++p) {
        EXPECT_NEAR(l.irradiance[p] * areaMm2, l.value[p], 1e-6 * l.value[p]) << p;
        if (l.count[p] > 0) {
            EXPECT_GT(l.value[p], 0.0) << p;
            EXPECT_GT(l.variance[p], 0.0) << p;
        }
    }
    // The stored value channel peaks in [0.5, 1): the file holds value / valueScale.
    int exponent = 0;
    EXPECT_EQ(std::frexp(l.valueScale, &exponent), 0.5) << l.valueScale;
    const double peak = *std::max_element(l.value.begin(), l.value.end());
    EXPECT_GE(peak / l.valueScale, 0.5);
    EXPECT_LT(peak / l.valueScale, 1.0);
}

}  // namespace

// The previews' colour scale: --range and --decades are checked before any ray is traced,
// and a good one is used.
TEST(VeilTrace, PreviewScaleOptionsAreCheckedAndUsed) {
    const std::filesystem::path dir =
        std::filesystem::path(::testing::TempDir()) / "veil_trace_preview_scale";
    std::filesystem::remove_all(dir);
    const std::string run =
        "trace examples/scenes/longfocus_360mm_sun.toml -n 400 --threads 1 --quiet -o " +
        dir.string();
    for (const auto& [args, says] : std::vector<std::pair<std::string, std::string>>{
             {"--range 3:1", "0 < LO < HI"},
             {"--range 0:1", "0 < LO < HI"},
             {"--range 1e-9", "LO:HI"},
             {"--range a:b", "LO:HI"},
             {"--decades 0", "--decades 0"},
             {"--decades -2", "--decades"},
             {"--decades 3 --range 1e-9:1e-3", "excludes"}}) {
        const VeilRun r = runVeil(run + " " + args);
        EXPECT_NE(r.exitCode, 0) << args;
        EXPECT_NE(r.err.find(says), std::string::npos) << args << ": " << r.err;
        EXPECT_FALSE(std::filesystem::exists(dir / "summary.json")) << args;
    }
    for (const std::string args : {"--range 1e-9:1e-3", "--decades 2.5"}) {
        const VeilRun r = runVeil(run + " " + args);
        ASSERT_EQ(r.exitCode, 0) << args << ": " << r.err;
        EXPECT_TRUE(std::filesystem::exists(dir / "sensor_image.png")) << args;
    }
}

// Faces are uncoated by default: every command that builds the scene names the lens faces in
// air left so, and says nothing of a cemented interface or once every face is coated.
TEST(VeilTrace, TheUncoatedLensFacesAreNamed) {
    const std::filesystem::path dir =
        std::filesystem::path(::testing::TempDir()) / "veil_trace_uncoated";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const VeilRun bare =
        runVeil("trace examples/lenses/achromat.toml -n 200 --threads 1 --quiet -o " +
                (dir / "bare").string());
    ASSERT_EQ(bare.exitCode, 0) << bare.err;
    EXPECT_NE(bare.err.find("note: 2 of 2 lens faces in air are uncoated"), std::string::npos)
        << bare.err;
    EXPECT_NE(bare.err.find("L1.front, L2.back."), std::string::npos) << bare.err;
    EXPECT_EQ(bare.err.find("L1.back"), std::string::npos) << bare.err;  // cemented

    const std::filesystem::path scene = dir / "coated.toml";
    std::ofstream(scene)
        << "lens = \""
        << (std::filesystem::path(VEIL_SOURCE_DIR) / "examples/lenses/achromat.toml").string()
        << "\"\n[[assign]]\nobjects = [\"L1.front\"]\nproperty = \"ideal_ar\"\n";
    const VeilRun one =
        runVeil("objects " + scene.string() + " -n 200 --quiet -o " + (dir / "one").string());
    ASSERT_EQ(one.exitCode, 0) << one.err;
    EXPECT_NE(one.err.find("note: 1 of 2 lens faces in air are uncoated"), std::string::npos)
        << one.err;
    EXPECT_NE(one.err.find("uncoated (bare Fresnel, about 4 % reflected at n = 1.5): L2.back."),
              std::string::npos)
        << one.err;
    std::ofstream(scene, std::ios::app)
        << "[[assign]]\nobjects = [\"L2.back\"]\nproperty = \"ideal_ar\"\n";
    const VeilRun both = runVeil("trace " + scene.string() + " -n 200 --threads 1 --quiet -o " +
                                 (dir / "both").string());
    ASSERT_EQ(both.exitCode, 0) << both.err;
    EXPECT_EQ(both.err.find("are uncoated"), std::string::npos) << both.err;
}

// A command prints the import report once, grouped: the glasses first in file order (the
// catalog a glass was not found in, a legacy name taken as the glass it denotes, an unknown
// glass replaced by the file's nd/Vd), then the other warnings, then the commands veil does
// not read on one line.
TEST(VeilTrace, ImportWarningsAreGroupedWithTheGlassesFirst) {
    const std::filesystem::path dir =
        std::filesystem::path(::testing::TempDir()) / "veil_trace_grouped_warnings";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    const std::filesystem::path lens = dir / "w.zmx";
    std::ofstream(lens) << "GCAT LIGHTPATH SCHOTT\nENPD 10\nSURF 0\n DISZ INFINITY\n SSID 0\n"
                           "SURF 1\n STOP\n SSID 1\n CURV 0.02\n DISZ 2\n GLAS BK7\nSURF 2\n"
                           " DISZ 1\nSURF 3\n CURV 0.01\n DISZ 3\n"
                           " GLAS MYSTERY 0 0 1.6 40 0 0 0 0 0 0\nSURF 4\n DISZ 40\nSURF 5\n"
                           "FROB 1\nZORK 2\n";
    for (const std::string command : {"trace", "objects"}) {
        const VeilRun r = runVeil(command + " " + lens.string() + " -n 20 --quiet -o " +
                                  (dir / command).string());
        ASSERT_EQ(r.exitCode, 0) << r.err;
        std::vector<size_t> at;
        for (const std::string said :
             {":1:6: warning: glass catalog LIGHTPATH named by GCAT is not loaded",
              ":11:7: note: glass BK7 is in no loaded catalog under that name; taken as N-BK7",
              ":17:7: warning: unknown glass 'MYSTERY'", "warning: no fields in the file",
              "w.zmx: warning: 3 commands veil does not read were ignored: SSID (line 5, 2 "
              "lines), FROB (line 21), ZORK (line 22)\n"}) {
            const size_t first = r.err.find(said);
            ASSERT_NE(first, std::string::npos) << command << ": " << said << "\n" << r.err;
            EXPECT_EQ(r.err.find(said, first + 1), std::string::npos) << command << ": " << said;
            at.push_back(first);
        }
        EXPECT_TRUE(std::is_sorted(at.begin(), at.end())) << command << "\n" << r.err;
        EXPECT_EQ(r.err.find("unknown command 'FROB'"), std::string::npos) << r.err;
    }
}

namespace {

// The trace states its memory estimate and refuses, before any ray and with nothing written,
// a run that would not fit: each criterion adds an image of every detector's pixels.
TEST(VeilTrace, MemoryIsEstimatedAndCheckedBeforeTheFirstRay) {
    const std::filesystem::path dir =
        std::filesystem::path(::testing::TempDir()) / "veil_trace_memory";
    std::filesystem::remove_all(dir);
    const std::string big = "--set detector.pixels[1]=4096 --set detector.pixels[2]=4096 ";
    VeilRun r = runVeil(big +
                        "trace examples/scenes/longfocus_360mm_sun.toml -n 100 --where scatter "
                        "--where 'reflect{2}' --max-memory 2G -o " +
                        dir.string());
    EXPECT_EQ(r.exitCode, 1);
    // 16777216 pixels x (24 bytes x (2 + 3 layers) + 16 x (1 + 3)): 3.09 GB with the process.
    EXPECT_NE(r.err.find("the trace needs about 3."), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("(16777216 pixels on 1 detector, 3 criterion layers each)"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("more than --max-memory's 2 GB: lower the detectors' pixels or use "
                         "fewer --where criteria, or raise --max-memory"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
    // Within the limit the estimate is shown with the progress.
    r = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 200 --threads 1 -o " +
                dir.string());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find(", memory about 0.0"), std::string::npos) << r.err;
}

}  // namespace
