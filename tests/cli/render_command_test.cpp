// veil render as a user runs it: the files it writes and lists, the components adding up to
// the total in summary.json and the EXR, a resumed run equal to a straight one, and bad input
// refused before any pass with nothing written.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/reports/image_output.h"
#include "tests/cli/run_veil.h"
#include "tests/text_checks.h"

namespace {

std::string dirFor(const std::string& what) {
    const std::string d = ::testing::TempDir() + "veil_render_cli_" +
                          ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_" +
                          what;
    std::filesystem::remove_all(d);
    return d;
}

const std::string kSun = "examples/scenes/longfocus_360mm_sun.toml";
const std::string kSmall = " --photons 5k --rays-per-pixel 2 --time-limit none";

TEST(RenderCommand, WritesTheComponentsAndTheyAddUp) {
    const std::string dir = dirFor("a");
    const VeilRun r = runVeil("render " + kSun + " --passes 2" + kSmall + " -o " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("wrote 8 files in " + dir + ": sensor_image.exr, sensor_image.png"),
              std::string::npos)
        << r.out;
    EXPECT_NE(r.out.find("pass limit reached"), std::string::npos) << r.out;
    EXPECT_FALSE(veil_test::hasNonFinite(r.out)) << r.out;
    EXPECT_FALSE(veil_test::hasNonFinite(readText(dir + "/summary.json")));
    const nlohmann::json s = nlohmann::json::parse(readText(dir + "/summary.json"));
    EXPECT_EQ(s["passes"].get<int>(), 2);
    double sum = 0.0;
    for (const char* c : {"visible", "direct", "caustic", "secondary"}) {
        EXPECT_GT(s["components"][c]["flux"].get<double>(), 0.0) << c;
        sum += s["components"][c]["flux"].get<double>();
    }
    const double total = s["total"]["flux"].get<double>();
    EXPECT_NEAR(sum, total, 1e-12 * total);
    EXPECT_NEAR(s["total"]["transmittance"].get<double>(), total / s["emitted_flux"].get<double>(),
                1e-12);
    // The Sun 7 degrees off axis forms no image on the sensor: all its light is stray.
    EXPECT_EQ(s["image_forming"]["flux"].get<double>(), 0.0);
    EXPECT_NEAR(s["stray"]["flux"].get<double>(), total, 1e-12 * total);
    // The EXR: five layers and the stray and image-forming light, the total's pixels the sum
    // of the components'.
    const veil::DetectorExr exr = veil::readDetectorExr(dir + "/sensor_image.exr");
    ASSERT_EQ(exr.layers.size(), 7u);
    ASSERT_TRUE(exr.layer("stray"));
    ASSERT_TRUE(exr.layer("image"));
    const veil::ExrLayer* t = exr.layer("total");
    ASSERT_TRUE(t);
    EXPECT_NEAR(t->totalFlux, total, 1e-9 * total);
    double worst = 0.0;
    for (size_t p = 0; p < t->value.size(); ++p) {
        double px = 0.0;
        for (const char* c : {"visible", "direct", "caustic", "secondary"})
            px += exr.layer(c)->value[p];
        if (t->value[p] > 0.0) worst = std::max(worst, std::abs(px - t->value[p]) / t->value[p]);
    }
    EXPECT_LT(worst, 1e-5);  // float storage
}

// The joined paths split the light exactly as the components do: no scatter on the path is
// the visible light, some scatter is direct + caustic + secondary; pruning keeps only what
// matches.
TEST(RenderCommand, SplitsTheImageByCriteria) {
    const std::string dir = dirFor("where");
    VeilRun r = runVeil("render " + kSun + " --passes 2" + kSmall +
                        " --where 'scatter{,0}' --where scatter --where 'scatter(L*.edge)'"
                        " --json -o " +
                        dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json s = nlohmann::json::parse(r.out);
    const nlohmann::json& c = s["components"];
    const nlohmann::json& w = s["criteria"];
    ASSERT_EQ(w.size(), 3u);
    const double visible = c["visible"]["flux"].get<double>();
    const double scattered = c["direct"]["flux"].get<double>() +
                             c["caustic"]["flux"].get<double>() +
                             c["secondary"]["flux"].get<double>();
    EXPECT_EQ(w[0]["layer"], "where1");
    EXPECT_NEAR(w[0]["flux"].get<double>(), visible, 1e-12 * visible);
    EXPECT_NEAR(w[1]["flux"].get<double>(), scattered, 1e-12 * scattered);
    EXPECT_EQ(w[1]["components"]["visible"]["flux"].get<double>(), 0.0);
    EXPECT_EQ(w[0]["components"]["secondary"]["flux"].get<double>(), 0.0);
    const double edge = w[2]["flux"].get<double>();
    EXPECT_GT(edge, 0.0);
    EXPECT_LT(edge, 0.5 * scattered);
    const veil::DetectorExr exr = veil::readDetectorExr(dir + "/sensor_image.exr");
    EXPECT_EQ(exr.layers.size(), 22u);  // 5 plain, 5 per criterion, stray and image
    ASSERT_TRUE(exr.layer("where3.caustic"));
    EXPECT_TRUE(std::filesystem::exists(dir + "/sensor_image.where3.png"));

    // The target on one criterion's image: the run stops when that image's error reaches
    // it, and says so.
    for (const std::string on : {"where2", "caustic"}) {
        r = runVeil("render " + kSun + " --passes 30" + kSmall +
                    " --where 'scatter{,0}' --where scatter --target-error 0.7 --target-on " + on +
                    " --json -o " + dirFor("target_" + on));
        ASSERT_EQ(r.exitCode, 0) << r.err;
        const nlohmann::json t = nlohmann::json::parse(r.out);
        EXPECT_EQ(t["target_on"], on);
        EXPECT_EQ(t["stopped"], "target error reached") << on;
        const double got = t["target_mean_relative_error"].get<double>();
        EXPECT_LE(got, 0.7) << on;
        EXPECT_EQ(got, on == "caustic"
                           ? t["components"]["caustic"]["mean_relative_error"].get<double>()
                           : t["criteria"][1]["mean_relative_error"].get<double>());
        EXPECT_LT(t["passes"].get<int>(), 30) << on;
    }

    // Single scatter with pruning: photons stop at their second scatter; the total is the
    // criterion's light.
    r = runVeil("render " + kSun + " --passes 2" + kSmall +
                " --where 'scatter{1}' --prune --json -o " + dirFor("prune"));
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json p = nlohmann::json::parse(r.out);
    EXPECT_GT(p["pruned_photon_branches_this_run"].get<uint64_t>(), 0u);
    EXPECT_EQ(p["total"]["flux"].get<double>(), p["criteria"][0]["flux"].get<double>());
    EXPECT_EQ(p["components"]["visible"]["flux"].get<double>(), 0.0);
    EXPECT_GT(p["total"]["flux"].get<double>(), 0.3 * scattered);
    EXPECT_LT(p["total"]["flux"].get<double>(), scattered);
    // --prune alone, or a criterion naming nothing in the scene: refused before any pass.
    r = runVeil("render " + kSun + " --prune -o " + dirFor("noprune"));
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--prune needs at least one --where"), std::string::npos) << r.err;
    r = runVeil("render " + kSun + " --where 'scatter(nosuch)' -o " + dirFor("nosuch"));
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--where 1:1:9"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dirFor("nosuch")));
}

TEST(RenderCommand, ResumingGivesTheStraightRun) {
    const std::string a = dirFor("straight"), b = dirFor("resumed");
    VeilRun r = runVeil("render " + kSun + " --passes 3" + kSmall + " --json -o " + a);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json straight = nlohmann::json::parse(r.out);
    r = runVeil("render " + kSun + " --passes 2" + kSmall + " --quiet -o " + b);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    r = runVeil("render " + kSun + " --passes 3" + kSmall + " --json --resume " + b);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json resumed = nlohmann::json::parse(r.out);
    EXPECT_EQ(resumed["passes"].get<int>(), 3);
    EXPECT_EQ(resumed["passes_this_run"].get<int>(), 1);
    EXPECT_EQ(resumed["total"]["flux"].get<double>(), straight["total"]["flux"].get<double>());
    EXPECT_EQ(resumed["mean_relative_error"].get<double>(),
              straight["mean_relative_error"].get<double>());
    // The third pass's visible photons, balanced after the second (from the checkpoint in the
    // resumed run), moved away from the first two passes' 5000 (--photons 5k).
    EXPECT_EQ(resumed["visible_photons_per_source_last_pass"].get<uint64_t>(),
              straight["visible_photons_per_source_last_pass"].get<uint64_t>());
    EXPECT_NE(straight["visible_photons_per_source_last_pass"].get<uint64_t>(), 5000u);
    // Other options than the checkpoint's: refused, naming the file.
    r = runVeil("render " + kSun + " --passes 4 --photons 6k --rays-per-pixel 2 --resume " + b);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("render.checkpoint: the checkpoint belongs to another scene or other "
                         "render options"),
              std::string::npos)
        << r.err;
}

// A sensor rendered in tiles (--tile-rays: 3 tiles of 25000 pixels here, each tile's view
// points gathering all the photons traced again) gives the images of one trace over the whole
// sensor: the first pass bitwise (the same rays, the same photons, the same gathers, each pixel's
// sums in the same order), with each photon's gathered light summed over the tiles; later passes
// differ only as the guides' sums were added in another order, within their error bars. Memory
// holds one tile's view points.
TEST(RenderCommand, TilesGiveTheImageOfOneTrace) {
    const std::string a = dirFor("whole"), b = dirFor("tiles");
    // veil render's summary of `passes` passes into `dir`, tiled or not.
    auto render = [&](int passes, const std::string& dir, bool tiled) {
        const VeilRun r =
            runVeil("render " + kSun + " --passes " + std::to_string(passes) + kSmall +
                    (tiled ? " --tile-rays 50000" : "") + " --json --quiet -o " + dir);
        EXPECT_EQ(r.exitCode, 0) << r.err;
        return r.exitCode == 0 ? nlohmann::json::parse(r.out) : nlohmann::json::object();
    };
    const nlohmann::json whole = render(1, a, false), tiles = render(1, b, true);
    ASSERT_TRUE(whole.contains("options") && tiles.contains("options"));
    EXPECT_EQ(whole["options"]["tile_pixels"].get<int>(), 65536);
    EXPECT_EQ(tiles["options"]["tile_pixels"].get<int>(), 25000);
    for (const char* c : {"visible", "direct", "caustic", "secondary"}) {
        EXPECT_GT(whole["components"][c]["flux"].get<double>(), 0.0) << c;
        EXPECT_EQ(tiles["components"][c]["flux"].get<double>(),
                  whole["components"][c]["flux"].get<double>())
            << c;
    }
    EXPECT_EQ(tiles["view_points_this_run"].get<uint64_t>(),
              whole["view_points_this_run"].get<uint64_t>());
    EXPECT_EQ(tiles["photons_this_run"].get<uint64_t>(), whole["photons_this_run"].get<uint64_t>());
    const double effective = whole["gathered_effective_photons"].get<double>();
    EXPECT_GT(effective, 10.0);
    EXPECT_NEAR(tiles["gathered_effective_photons"].get<double>(), effective, 1e-9 * effective);
    // The pixels too, layer by layer.
    const veil::DetectorExr ea = veil::readDetectorExr(a + "/sensor_image.exr"),
                            eb = veil::readDetectorExr(b + "/sensor_image.exr");
    ASSERT_EQ(ea.layers.size(), eb.layers.size());
    for (size_t l = 0; l < ea.layers.size(); ++l)
        EXPECT_EQ(ea.layers[l].value, eb.layers[l].value) << ea.layers[l].name;
    EXPECT_LT(tiles["memory_estimate_bytes"].get<double>(),
              whole["memory_estimate_bytes"].get<double>());
    // Two passes: the same light within the error bars of the two.
    const nlohmann::json whole2 = render(2, a, false), tiles2 = render(2, b, true);
    ASSERT_TRUE(whole2.contains("total") && tiles2.contains("total"));
    const double fa = whole2["total"]["flux"].get<double>(),
                 fb = tiles2["total"]["flux"].get<double>();
    const double sa = whole2["total"]["relative_error"].get<double>() * fa,
                 sb = tiles2["total"]["relative_error"].get<double>() * fb;
    EXPECT_GT(sa, 0.0);
    EXPECT_LT(std::abs(fa - fb), 4.0 * std::hypot(sa, sb)) << fa << " " << fb;
}

// The time limit holds inside a pass: a pass of a billion photons per source is cut at its next
// block once the limit passes (before, the limit was checked between passes only, and this run
// went on for hours), and with no pass finished there is nothing to write.
TEST(RenderCommand, TheTimeLimitCutsAPassUnderWay) {
    const std::string dir = dirFor("cut");
    const VeilRun r = runVeil(
        "render " + kSun + " --photons 1e9 --rays-per-pixel 2 --time-limit 1s --quiet -o " + dir);
    EXPECT_EQ(r.exitCode, 1) << r.err;
    EXPECT_NE(r.err.find("no pass finished (the time limit ended the run first)"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir + "/summary.json"));
}

TEST(RenderCommand, BadInputStopsBeforeAnyPass) {
    const std::string dir = dirFor("bad");
    // A singlet whose edge and flats absorb: nothing scatters (a bare lens scatters at its
    // ground edges and flats, which is stray light to render).
    const std::string scene = ::testing::TempDir() + "veil_render_cli_no_scatter.toml";
    {
        std::ofstream f(scene);
        f << "lens = \"" << VEIL_SOURCE_DIR << "/examples/lenses/singlet.toml\"\n"
          << "[[assign]]\nobjects = \"L1.edge\"\nproperty = \"absorber\"\n"
          << "[[assign]]\nobjects = \"L1.flat*\"\nproperty = \"absorber\"\n";
    }
    VeilRun r = runVeil("render " + scene + " --passes 1 -o " + dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("no surface scatters"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
    r = runVeil("render " + kSun + " --time-limit soon -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("'soon' is no time limit"), std::string::npos) << r.err;
    r = runVeil("render " + kSun + " --detector nosuch -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("no detector 'nosuch' in the scene (it has sensor_image)"),
              std::string::npos)
        << r.err;
    r = runVeil("render " + kSun + " --resume " + dir + " -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("holds no render.checkpoint"), std::string::npos) << r.err;
    r = runVeil("render " + kSun + " --target-on where2 --where scatter -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("'where2' is no image of this run"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("where1 to where1"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
    r = runVeil("render " + kSun + " --target-on glare -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("or where<k> with --where"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
    r = runVeil("render " + kSun + " --alpha 1.5 -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_FALSE(std::filesystem::exists(dir));
    // --photons takes auto, work or a count, nothing else.
    r = runVeil("render " + kSun + " --photons lots -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--photons takes auto, work or a count: 'lots' is not a whole number"),
              std::string::npos)
        << r.err;
    r = runVeil("render " + kSun + " --photons 0 -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--photons must be at least 1"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
    // --connect is on or off.
    r = runVeil("render " + kSun + " --connect maybe -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("--connect"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
    // Memory the machine does not have is refused before any of it is taken (1e9 rays per
    // pixel had allocated 16 GB at 1.5 GB/s); so is more than --max-memory.
    r = runVeil("render " + kSun + " --rays-per-pixel 1e9 --passes 1 -o " + dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("the render needs about"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("65536 pixels in tiles of 1 x 1000000000 rays per pixel"),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("lower --tile-rays, --rays-per-pixel or the detector's pixels"),
              std::string::npos)
        << r.err;
    // Tiles of no ray, or of more than the most: refused, naming the option.
    for (const char* bad : {"0", "1e10", "-3"}) {
        r = runVeil("render " + kSun + " --tile-rays " + bad + " -o " + dir);
        EXPECT_EQ(r.exitCode, 2) << bad;
        EXPECT_NE(r.err.find("--tile-rays"), std::string::npos) << r.err;
    }
    r = runVeil("render " + kSun + " --max-memory 10M --passes 1 -o " + dir);
    EXPECT_EQ(r.exitCode, 1);
    EXPECT_NE(r.err.find("more than --max-memory's 0.01 GB"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("or raise --max-memory"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
}

}  // namespace
