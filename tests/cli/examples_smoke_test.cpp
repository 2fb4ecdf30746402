// Every bundled example runs through every command it makes sense for, with small budgets:
// lens files through info, layout, export, trace, paths, view and ghosts (a lens without sources is
// traced with one beam per system field), scenes through the same (ghost path pictures are
// left to ghosts_command_test). Each run exits 0, warns
// of nothing, and writes what it lists.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/cli/run_veil.h"
#include "tests/text_checks.h"

namespace {

using veil_test::hasNonFinite;

std::vector<std::string> examples() {
    std::vector<std::string> out;
    for (const char* dir : {"examples/lenses", "examples/zmx", "examples/scenes"})
        for (const auto& e :
             std::filesystem::directory_iterator(std::string(VEIL_SOURCE_DIR) + "/" + dir))
            out.push_back(std::string(dir) + "/" + e.path().filename().string());
    std::sort(out.begin(), out.end());
    return out;
}

TEST(ExamplesSmoke, EveryExampleRunsThroughEveryCommand) {
    const std::vector<std::string> files = examples();
    ASSERT_GE(files.size(), 21u);  // 8 lenses, 2 Zemax files, 11 scenes
    const std::string out = ::testing::TempDir() + "veil_smoke";
    std::filesystem::remove_all(out);
    for (const std::string& f : files) {
        const std::string stem = std::filesystem::path(f).stem().string();
        const std::string dir = out + "/" + stem;
        std::ifstream text(std::string(VEIL_SOURCE_DIR) + "/" + f);
        const std::string content((std::istreambuf_iterator<char>(text)),
                                  std::istreambuf_iterator<char>());
        const bool window = content.find("kind = \"window\"") != std::string::npos;
        const std::vector<std::string> commands = {
            "info " + f + " --json",
            "layout " + f + " -o " + dir + "/layout",
            "export " + f + " -o " + dir + "/scene.ply",
            "trace " + f + " -n 40 --quiet -o " + dir + "/trace",
            "paths " + f + " --where 'detector' --first 3 -n 200 --quiet -o " + dir + "/paths",
            "view " + f + " --where 'detector' --first 3 -n 200 --quiet -o " + dir + "/scene.html",
            // A window source has no sequential ghost estimate: ghosts asks for --field.
            "ghosts " + f + " -n 100 --grid 12 --top 0 --quiet -o " + dir + "/ghosts" +
                (window ? " --field 0,0.3" : ""),
            "objects " + f + " -n 200 --quiet -o " + dir + "/objects",
            "scatter " + f + " --quiet -o " + dir + "/scatter",
        };
        for (const std::string& c : commands) {
            SCOPED_TRACE(c);
            const VeilRun r = runVeil(c);
            EXPECT_EQ(r.exitCode, 0) << r.err;
            EXPECT_EQ(r.err.find("warning"), std::string::npos) << r.err;
            // info's surface table shows a flat's radius and an object at infinity as inf,
            // the file's own values; every computed number is finite or n/a.
            if (c.rfind("info", 0) != 0) {
                EXPECT_FALSE(hasNonFinite(r.out)) << r.out;
            }
        }
        for (const char* written :
             {"/trace/summary.json", "/ghosts/ghosts.md", "/ghosts/ghosts.csv",
              "/ghosts/ghosts.json", "/objects/objects.md", "/objects/objects.csv",
              "/objects/objects.json", "/scatter/scatter.md", "/scatter/scatter.json"})
            EXPECT_FALSE(hasNonFinite(readText(dir + written))) << dir + written;
        EXPECT_TRUE(std::filesystem::exists(dir + "/layout/layout.png")) << f;
        EXPECT_TRUE(std::filesystem::exists(dir + "/scene.ply")) << f;
        EXPECT_TRUE(std::filesystem::exists(dir + "/trace/summary.json")) << f;
        EXPECT_TRUE(std::filesystem::exists(dir + "/paths/paths.svg")) << f;
        EXPECT_TRUE(std::filesystem::exists(dir + "/scene.html")) << f;
        EXPECT_TRUE(std::filesystem::exists(dir + "/ghosts/ghosts.md")) << f;
        EXPECT_TRUE(std::filesystem::exists(dir + "/objects/objects.png")) << f;
    }
    std::filesystem::remove_all(out);
}

}  // namespace
