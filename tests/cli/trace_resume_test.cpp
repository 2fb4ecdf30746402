// `veil trace` killed with SIGKILL in the middle of its run, then `--resume DIR`: the images,
// their PNGs, the ray database and the summary (but for its wall time) come out byte for byte
// as those of the run that was not stopped. Checkpoints every block, so the kill lands after
// one; the run is long enough (about 3 s on two threads) that it lands before the end.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "run_veil.h"

namespace {

namespace fs = std::filesystem;

std::vector<char> bytesOf(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

nlohmann::json summaryWithoutTime(const fs::path& dir) {
    std::ifstream in(dir / "summary.json");
    nlohmann::json j = nlohmann::json::parse(in);
    j.erase("seconds");
    return j;
}

const std::string kArgs =
    "trace examples/scenes/longfocus_360mm_sun.toml -n 4000 --threads 2 --seed 3 "
    "--where scatter --where 'reflect{2}' --checkpoint-every 0 --quiet ";

// The ray database, as events and fluxes (a quarter of the size: 4000 rays of the Sun example
// write about 60 MB with positions and directions).
std::string saveRays(const fs::path& file) { return "--events-only --save-rays " + file.string(); }

TEST(VeilTraceResume, AKilledRunGoesOnToTheSameFiles) {
    const fs::path root = fs::path(::testing::TempDir()) / "veil_trace_resume";
    fs::remove_all(root);
    const fs::path straight = root / "straight", killed = root / "killed";
    VeilRun r = runVeil(kArgs + saveRays(straight / "rays.vrdb") + " -o " + straight.string());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_FALSE(fs::exists(straight / "trace.checkpoint"));  // removed once the run is whole

    // The second run is killed once its first checkpoint is in place, a little later.
    const std::string run = std::string(VEIL_EXE) + " " + kArgs + saveRays(killed / "rays.vrdb") +
                            " -o " + killed.string();
    const std::string script = "cd " + std::string(VEIL_SOURCE_DIR) + " && (" + run +
                               " >/dev/null 2>&1 & pid=$!; while [ ! -f " +
                               (killed / "trace.checkpoint").string() +
                               " ] && kill -0 $pid 2>/dev/null; do sleep 0.02; done; sleep 0.2; "
                               "kill -9 $pid; wait $pid; exit 0)";
    ASSERT_EQ(std::system(script.c_str()), 0);
    ASSERT_TRUE(fs::exists(killed / "trace.checkpoint")) << "the run ended before the kill";
    EXPECT_FALSE(fs::exists(killed / "summary.json"));
    EXPECT_TRUE(fs::exists(killed / "rays.vrdb.partial"));

    // Other options than the killed run's are refused, before any ray and leaving its files.
    r = runVeil(kArgs + "--min-flux 2e-4 " + saveRays(killed / "rays.vrdb") + " --resume " +
                killed.string());
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("belongs to another run"), std::string::npos) << r.err;
    EXPECT_TRUE(fs::exists(killed / "rays.vrdb.partial"));

    r = runVeil(kArgs + saveRays(killed / "rays.vrdb") + " --resume " + killed.string());
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // It went on from a block after the first, not from the start.
    const size_t from = r.err.find("veil: went on from ray ");
    ASSERT_NE(from, std::string::npos) << r.err;
    const uint64_t first = std::stoull(r.err.substr(from + 23));
    EXPECT_GE(first, 256u) << r.err;
    EXPECT_LT(first, 4000u) << r.err;
    EXPECT_NE(r.err.find(" of 4000 (the rays before it from "), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(killed / "trace.checkpoint"));
    EXPECT_FALSE(fs::exists(killed / "rays.vrdb.partial"));
    for (const char* f :
         {"rays.vrdb", "sensor_image.exr", "sensor_image.png", "sensor_image.where1.png",
          "sensor_image.where2.png", "sensor_image.rest.png"}) {
        ASSERT_TRUE(fs::exists(killed / f)) << f;
        EXPECT_TRUE(bytesOf(killed / f) == bytesOf(straight / f)) << f << " differs";
    }
    EXPECT_EQ(summaryWithoutTime(killed), summaryWithoutTime(straight));
}

TEST(VeilTraceResume, ResumeChecksItsFolderAndItsRun) {
    const fs::path root = fs::path(::testing::TempDir()) / "veil_trace_resume_bad";
    fs::remove_all(root);
    fs::create_directories(root / "empty");
    VeilRun r = runVeil(kArgs + "--resume " + (root / "empty").string());
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("holds no trace.checkpoint to go on from"), std::string::npos) << r.err;
    // A checkpoint of another run (another seed) is refused before any ray.
    const fs::path dir = root / "other";
    fs::create_directories(dir);
    {
        std::ofstream junk(dir / "trace.checkpoint", std::ios::binary);
        junk << "not a checkpoint";
    }
    r = runVeil(kArgs + "--resume " + dir.string());
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("is not a veil trace checkpoint"), std::string::npos) << r.err;
    r = runVeil(kArgs + "--resume " + dir.string() + " -o " + (root / "elsewhere").string());
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("the run goes on in its own folder"), std::string::npos) << r.err;
}

}  // namespace
