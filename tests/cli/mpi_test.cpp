// veil across MPI ranks (docs/scaling.md): trace, render, sweep and pst under
// `mpirun -np 2` (and 3, oversubscribed) write bitwise the files of one process with the same
// seed; a render checkpointed with one rank count resumes with another; a failure on the ranks
// stops the job with its message and a non-zero exit, and commands that do not split their
// work refuse to run as several ranks. Skipped, saying why, where veil was built without MPI
// or mpirun is missing.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/cli/run_veil.h"

namespace {

std::string dirFor(const std::string& what) {
    const std::string d = ::testing::TempDir() + "veil_mpi_" +
                          ::testing::UnitTest::GetInstance()->current_test_info()->name() + "_" +
                          what;
    std::filesystem::remove_all(d);
    return d;
}

// The prefix that starts veil as `ranks` ranks of one thread each (root may run mpirun in CI
// containers; --oversubscribe: more ranks than cores).
std::string mpirun(int ranks) {
#ifdef VEIL_MPIEXEC
    return "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 "
           "OMPI_MCA_rmaps_base_oversubscribe=1 " +
           std::string(VEIL_MPIEXEC) + " -np " + std::to_string(ranks) +
           " --oversubscribe --bind-to none";
#else
    (void)ranks;
    return "";
#endif
}

std::string mpiexecPath() {
#ifdef VEIL_MPIEXEC
    return VEIL_MPIEXEC;
#else
    return "";
#endif
}

#define SKIP_WITHOUT_MPI()                                                                   \
    do {                                                                                     \
        if (mpirun(1).empty())                                                               \
            GTEST_SKIP() << "veil was built without MPI (install Debian's libopenmpi-dev "   \
                            "and openmpi-bin and configure again): nothing to run on ranks"; \
        if (!std::filesystem::exists(mpiexecPath()))                                         \
            GTEST_SKIP() << "mpirun is not on this machine";                                 \
    } while (0)

std::string bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
}

// Two folders hold the same files, byte for byte (summary.json without its clock readings).
void expectSameFiles(const std::string& a, const std::string& b,
                     const std::vector<std::string>& files) {
    for (const std::string& f : files) {
        const std::string x = bytes(a + "/" + f), y = bytes(b + "/" + f);
        ASSERT_FALSE(x.empty()) << a << "/" << f;
        EXPECT_TRUE(x == y) << f << " differs between " << a << " and " << b;
    }
}

nlohmann::json withoutClock(nlohmann::json j) {
    for (auto it = j.begin(); it != j.end();) {
        // The clock, and the memory estimate (it counts what the process holds, which differs
        // between a rank and one process), are the machine's, not the run's numbers.
        if (it.key().find("seconds") != std::string::npos || it.key() == "files" ||
            it.key() == "ranks" || it.key() == "memory_estimate_bytes")
            it = j.erase(it);
        else
            ++it;
    }
    return j;
}

const std::string kSun = "examples/scenes/longfocus_360mm_sun.toml";

TEST(Mpi, TraceOnRanksIsBitwiseOneProcess) {
    SKIP_WITHOUT_MPI();
    const std::string args = "trace " + kSun +
                             " -n 3000 --seed 5 --threads 1 --quiet --where fresnel --where "
                             "'not fresnel' -o ";
    const std::string one = dirFor("one"), two = dirFor("two"), three = dirFor("three");
    const VeilRun a = runVeil(args + one);
    ASSERT_EQ(a.exitCode, 0) << a.err;
    const VeilRun b = runVeil(args + two, mpirun(2));
    ASSERT_EQ(b.exitCode, 0) << b.err;
    const VeilRun c = runVeil(args + three, mpirun(3));
    ASSERT_EQ(c.exitCode, 0) << c.err;
    for (const std::string& d : {two, three}) {
        expectSameFiles(one, d,
                        {"sensor_image.exr", "sensor_image.png", "sensor_image.where1.png"});
        EXPECT_EQ(withoutClock(nlohmann::json::parse(bytes(one + "/summary.json"))),
                  withoutClock(nlohmann::json::parse(bytes(d + "/summary.json"))));
    }
    // Rank 0 alone printed the report.
    ASSERT_NE(b.out.find("Flux budget"), std::string::npos) << b.out;
    EXPECT_EQ(b.out.find("Flux budget"), b.out.rfind("Flux budget")) << b.out;
}

// Renders `args` for 2 passes on one rank and on two, expecting the same `files`, then resumes each
// to 3 passes on the other's rank count: still one run. The summary of the first, after checking
// that the second's is the same.
nlohmann::json renderOnRanksAndResume(const std::string& args,
                                      const std::vector<std::string>& files) {
    const std::string one = dirFor("one"), two = dirFor("two");
    const VeilRun a = runVeil(args + "--passes 2 -o " + one);
    EXPECT_EQ(a.exitCode, 0) << a.err;
    const VeilRun b = runVeil(args + "--passes 2 -o " + two, mpirun(2));
    EXPECT_EQ(b.exitCode, 0) << b.err;
    expectSameFiles(one, two, files);
    const VeilRun c = runVeil(args + "--passes 3 --resume " + one, mpirun(2));
    EXPECT_EQ(c.exitCode, 0) << c.err;
    const VeilRun d = runVeil(args + "--passes 3 --resume " + two);
    EXPECT_EQ(d.exitCode, 0) << d.err;
    expectSameFiles(one, two, files);
    const nlohmann::json s = nlohmann::json::parse(bytes(one + "/summary.json"));
    EXPECT_EQ(s["passes"].get<int>(), 3);
    EXPECT_EQ(withoutClock(s), withoutClock(nlohmann::json::parse(bytes(two + "/summary.json"))));
    return s;
}

TEST(Mpi, RenderOnRanksIsBitwiseAndResumesOnAnotherRankCount) {
    SKIP_WITHOUT_MPI();
    // In 4 tiles of the sensor (--tile-rays): each tile's pixels and photons split over the ranks.
    renderOnRanksAndResume("render " + kSun +
                               " --photons 4k --rays-per-pixel 2 --tile-rays 40000 --time-limit "
                               "none --threads 1 --quiet --seed 3 ",
                           {"render.checkpoint", "sensor_image.exr", "sensor_image.png"});
}

TEST(Mpi, BalancedPhotonsOnRanksAreBitwiseOneProcess) {
    // The default photons (auto): each pass's count from the work counts of the pass before,
    // the same on every rank count, through a resume on another rank count.
    SKIP_WITHOUT_MPI();
    const nlohmann::json s = renderOnRanksAndResume(
        "render examples/scenes/seed_fig13_butt_ends.toml --rays-per-pixel 2 --time-limit none "
        "--threads 1 --quiet --seed 5 ",
        {"render.checkpoint", "sensor.exr"});
    EXPECT_TRUE(s["options"]["balanced_photons"].get<bool>());
    EXPECT_NE(s["photons_per_source_last_pass"].get<uint64_t>(),
              s["options"]["photons_per_source_per_pass"].get<uint64_t>());
}

TEST(Mpi, SweepAndPstOnRanksAreBitwiseOneProcess) {
    SKIP_WITHOUT_MPI();
    const std::string sweep = "sweep " + kSun +
                              " --vary properties.black_anodized.scatter.reflectance=0.02,0.05,0.1 "
                              "-n 400 --batches 2 --threads 1 --quiet -o ";
    const std::string one = dirFor("sweep1"), two = dirFor("sweep2");
    const VeilRun a = runVeil(sweep + one);
    ASSERT_EQ(a.exitCode, 0) << a.err;
    const VeilRun b = runVeil(sweep + two, mpirun(2));
    ASSERT_EQ(b.exitCode, 0) << b.err;
    expectSameFiles(one, two, {"sweep.csv", "sweep.md", "sweep.png"});
    for (int k = 0; k < 3; ++k) {
        // Every variant's record saved by rank 0, the same but for its clock.
        const std::string f = "/variants/" + std::to_string(k) + ".json";
        EXPECT_EQ(withoutClock(nlohmann::json::parse(bytes(one + f))),
                  withoutClock(nlohmann::json::parse(bytes(two + f))))
            << f;
    }
    const std::string pst =
        "pst " + kSun + " --angles 0,1,2 -n 400 --batches 2 --threads 1 --quiet -o ";
    const std::string p1 = dirFor("pst1"), p2 = dirFor("pst2");
    const VeilRun c = runVeil(pst + p1);
    ASSERT_EQ(c.exitCode, 0) << c.err;
    const VeilRun d = runVeil(pst + p2, mpirun(2));
    ASSERT_EQ(d.exitCode, 0) << d.err;
    expectSameFiles(p1, p2, {"pst.csv", "pst.md", "pst.png"});
}

TEST(Mpi, AFailureStopsEveryRankWithItsMessage) {
    SKIP_WITHOUT_MPI();
    const std::string dir = dirFor("bad");
    const VeilRun a =
        runVeil("trace examples/scenes/no_such_scene.toml -n 100 -o " + dir, mpirun(2));
    EXPECT_NE(a.exitCode, 0);
    EXPECT_NE(a.err.find("no_such_scene.toml"), std::string::npos) << a.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
    // A command that does not split its work is refused, not run twice.
    const VeilRun g = runVeil("ghosts " + kSun, mpirun(2));
    EXPECT_NE(g.exitCode, 0);
    EXPECT_NE(g.err.find("veil ghosts runs in one process"), std::string::npos) << g.err;
    // The ray database has one writer.
    const VeilRun s =
        runVeil("trace " + kSun + " -n 100 --save-rays " + dir + "/r.vrdb -o " + dir, mpirun(2));
    EXPECT_NE(s.exitCode, 0);
    EXPECT_NE(s.err.find("without mpirun"), std::string::npos) << s.err;
}

}  // namespace
