// An output folder holds at most one finished run (cli/options.h, WrittenFiles): veil-run.json,
// written last, lists every file of the run with its size and CRC-32; a new run into the
// folder first removes the older run's manifest, its unchanged files and the temporaries a
// killed run left; a run refused for bad input touches nothing.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "run_veil.h"
#include "tracer/records/ray_database.h"

namespace {

namespace fs = std::filesystem;

std::string freshDir(const std::string& name) {
    const fs::path p = fs::path(::testing::TempDir()) / name;
    fs::remove_all(p);
    return p.string();
}

std::set<std::string> filesIn(const fs::path& dir) {
    std::set<std::string> out;
    for (const auto& e : fs::recursive_directory_iterator(dir))
        if (e.is_regular_file()) out.insert(fs::relative(e.path(), dir).string());
    return out;
}

std::string crcOf(const fs::path& file) {
    std::ifstream in(file, std::ios::binary);
    const std::vector<char> bytes{std::istreambuf_iterator<char>(in), {}};
    char text[9];
    std::snprintf(text, sizeof text, "%08x",
                  veil::crc32(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()));
    return text;
}

// The manifest's files, each checked against the folder: size and CRC-32 as listed.
std::set<std::string> manifestFiles(const fs::path& dir) {
    const nlohmann::json m = nlohmann::json::parse(readText((dir / "veil-run.json").string()));
    EXPECT_EQ(m["run_id"].get<std::string>().size(), 16u);
    EXPECT_NE(m["command"].get<std::string>().find("veil"), std::string::npos);
    std::set<std::string> out;
    for (const auto& f : m["files"]) {
        const std::string name = f["name"];
        out.insert(name);
        EXPECT_EQ(f["bytes"].get<uint64_t>(), fs::file_size(dir / name)) << name;
        EXPECT_EQ(f["crc32"].get<std::string>(), crcOf(dir / name)) << name;
    }
    return out;
}

TEST(OutputFolder, HoldsOneFinishedRunListedInItsManifest) {
    const std::string dir = freshDir("veil_output_folder");
    VeilRun r = runVeil("trace examples/scenes/double_gauss_50mm.toml -n 2 --quiet -o " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const std::set<std::string> traced{"sensor.exr", "sensor.png", "summary.json"};
    EXPECT_EQ(manifestFiles(dir), traced);
    std::set<std::string> all = traced;
    all.insert("veil-run.json");
    EXPECT_EQ(filesIn(dir), all);

    // What a killed run leaves (temporaries), a file of the user's, and one of the older
    // run's files changed since.
    std::ofstream(dir + "/sensor.png.tmp") << "half";
    std::ofstream(dir + "/run.vrdb.partial") << "half";
    std::ofstream(dir + "/notes.txt") << "mine";
    std::ofstream(dir + "/summary.json", std::ios::app) << "edited\n";

    // A run refused for bad input touches nothing.
    r = runVeil("trace examples/scenes/double_gauss_50mm.toml -n 2 --quiet --where 'hit(' -o " +
                dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_TRUE(fs::exists(dir + "/veil-run.json"));
    EXPECT_TRUE(fs::exists(dir + "/sensor.exr"));

    // Another command into the folder: the older run's unchanged files and the temporaries
    // go, the changed file and the user's stay (and are not in the manifest).
    r = runVeil("layout examples/scenes/double_gauss_50mm.toml -o " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("summary.json was written by an older run into this folder and changed "
                         "since; kept"),
              std::string::npos)
        << r.err;
    EXPECT_EQ(manifestFiles(dir), (std::set<std::string>{"layout.svg", "layout.png"}));
    EXPECT_EQ(filesIn(dir), (std::set<std::string>{"layout.svg", "layout.png", "notes.txt",
                                                   "summary.json", "veil-run.json"}));
}

TEST(OutputFolder, JsonWithoutOutputWritesNoManifest) {
    const VeilRun r = runVeil("layout examples/scenes/double_gauss_50mm.toml --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_FALSE(fs::exists(std::string(VEIL_SOURCE_DIR) + "/veil-run.json"));
    EXPECT_FALSE(fs::exists(std::string(VEIL_SOURCE_DIR) + "/layout"));
}

}  // namespace

// A folder is locked while a run writes into it (kRunLock, cli/options.h): a second run is
// refused, naming the first; the lock of a process that no longer runs is removed, with a
// note. Two runs into one folder had both exited 0, the last to finish winning.
TEST(OutputFolder, IsLockedWhileARunWritesIntoIt) {
    const std::string dir = freshDir("veil_locked");
    fs::create_directories(dir);
    char host[256] = {};
    ASSERT_EQ(gethostname(host, sizeof host - 1), 0);
    // Process 1 always runs.
    std::ofstream(fs::path(dir) / ".veil-lock")
        << "1 " << host << " veil trace examples/lenses/singlet.toml -o " << dir;
    VeilRun r = runVeil("trace examples/lenses/singlet.toml -n 10 -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("another veil run is writing into this folder (process 1 on " +
                         std::string(host) + ": veil trace examples/lenses/singlet.toml"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(fs::exists(fs::path(dir) / "veil-run.json"));
    EXPECT_TRUE(fs::exists(fs::path(dir) / ".veil-lock"));  // the other run's, untouched
    // A process that has ended: its lock goes.
    const pid_t child = fork();
    if (child == 0) _exit(0);
    ASSERT_GT(child, 0);
    int status = 0;
    waitpid(child, &status, 0);
    std::ofstream(fs::path(dir) / ".veil-lock") << child << " " << host << " veil render x";
    r = runVeil("trace examples/lenses/singlet.toml -n 10 -o " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.err.find("removed the lock of a run that no longer runs (process " +
                         std::to_string(child) + ": veil render x)"),
              std::string::npos)
        << r.err;
    EXPECT_TRUE(fs::exists(fs::path(dir) / "veil-run.json"));
    EXPECT_FALSE(fs::exists(fs::path(dir) / ".veil-lock"));  // released at the end
}
