// Every command line of the README's Usage section runs as written, in order, on the bundled
// files: a fresh folder that sees the repository's examples/ and tests/, with the built veil
// first on the PATH. A README line that stops working fails here.

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli/run_veil.h"

namespace {

// The `veil ...` lines of the first sh block after "## Usage", without their trailing
// comments (a '#' outside quotes after a space).
std::vector<std::string> usageLines() {
    const std::string readme = readText(std::string(VEIL_SOURCE_DIR) + "/README.md");
    const size_t usage = readme.find("\n## Usage");
    EXPECT_NE(usage, std::string::npos);
    const size_t open = readme.find("```sh\n", usage);
    const size_t close = readme.find("```", open + 6);
    std::istringstream block(readme.substr(open + 6, close - open - 6));
    std::vector<std::string> out;
    for (std::string line; std::getline(block, line);) {
        if (line.rfind("veil ", 0) != 0) continue;
        bool quoted = false;
        for (size_t i = 0; i < line.size(); ++i) {
            if (line[i] == '\'') quoted = !quoted;
            if (!quoted && line[i] == '#' && i > 0 && line[i - 1] == ' ') {
                line.resize(i);
                break;
            }
        }
        while (!line.empty() && line.back() == ' ') line.pop_back();
        out.push_back(line);
    }
    return out;
}

struct LineRun {
    int exitCode = -1;
    std::string err;
};

LineRun runIn(const std::string& dir, const std::string& line) {
    const std::string errFile = dir + "/stderr.txt";
    const std::string exeDir = std::filesystem::path(VEIL_EXE).parent_path().string();
    const std::string cmd =
        "cd " + dir + " && PATH=" + exeDir + ":$PATH " + line + " > /dev/null 2> " + errFile;
    LineRun r;
    const int status = std::system(cmd.c_str());
    r.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.err = readText(errFile);
    return r;
}

TEST(ReadmeUsage, EveryLineRunsAsWritten) {
    const std::vector<std::string> lines = usageLines();
    ASSERT_GE(lines.size(), 10u);
    const std::string dir = ::testing::TempDir() + "veil_usage_" + std::to_string(getpid());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    for (const char* link : {"examples", "tests"})
        std::filesystem::create_directory_symlink(std::string(VEIL_SOURCE_DIR) + "/" + link,
                                                  dir + "/" + link);
    for (const std::string& line : lines) {
        SCOPED_TRACE(line);
        const LineRun r = runIn(dir, line);
        EXPECT_EQ(r.exitCode, 0) << r.err;
        // No warning: the bundled files are clean.
        EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
    }
    for (const char* file : {"out/dg/layout.svg", "out/dg/layout.png", "out/dg.obj",
                             "out/sun7/sensor_image.exr", "out/l4/sensor_image.where1.png",
                             "out/db/rays.vrdb", "out/l4paths/paths.svg", "out/ghosts/ghosts.md"})
        EXPECT_TRUE(std::filesystem::exists(dir + "/" + file)) << file;
    std::filesystem::remove_all(dir);
}

}  // namespace
