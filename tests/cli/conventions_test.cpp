// The command-line conventions of docs/cli.md, held for every subcommand: the test walks
// `veil --help` and each `veil COMMAND --help`, so a new command or option that breaks them
// (or is not documented) fails here.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/cli/run_veil.h"

namespace {

std::vector<std::string> subcommands() {
    const VeilRun r = runVeil("--help");
    EXPECT_EQ(r.exitCode, 0);
    std::vector<std::string> out;
    bool in = false;
    std::istringstream lines(r.out);
    for (std::string line; std::getline(lines, line);) {
        if (line.rfind("Subcommands:", 0) == 0) {
            in = true;
            continue;
        }
        std::smatch m;
        if (in && std::regex_search(line, m, std::regex("^  ([a-z]+) "))) out.push_back(m[1]);
    }
    return out;
}

// Long option names and whether each has the given short form, from COMMAND --help.
std::map<std::string, std::string> optionsOf(const std::string& command) {
    const VeilRun r = runVeil(command + " --help");
    EXPECT_EQ(r.exitCode, 0) << command;
    std::map<std::string, std::string> out;  // --long -> short ("" if none)
    std::istringstream lines(r.out);
    for (std::string line; std::getline(lines, line);) {
        std::smatch m;
        if (!std::regex_search(line, m, std::regex("^  (-[a-zA-Z],)?(--[a-z0-9-]+)"))) continue;
        std::string shortName = m[1];
        if (!shortName.empty()) shortName.pop_back();
        out[m[2]] = shortName;
        // A second long name (--colour,--color).
        const std::string rest = line.substr(m.position(0) + m.length(0));
        if (std::regex_search(rest, m, std::regex("^,(--[a-z0-9-]+)"))) out[m[1]] = "";
    }
    return out;
}

const std::set<std::string> kCommon = {"--help", "--json", "--quiet", "--threads", "--seed",
                                       "--field"};

TEST(CliConventions, EveryCommandFollowsThemAndIsDocumented) {
    const std::vector<std::string> commands = subcommands();
    ASSERT_GE(commands.size(), 7u);
    const std::string doc = readText(std::string(VEIL_SOURCE_DIR) + "/docs/cli.md");
    for (const std::string& c : commands) {
        SCOPED_TRACE(c);
        const auto options = optionsOf(c);
        // Every command reports as JSON and can be quiet.
        EXPECT_TRUE(options.count("--json"));
        EXPECT_TRUE(options.count("--quiet"));
        // Commands that trace: -n/--rays, --threads, --seed, --field.
        if (options.count("--rays")) {
            EXPECT_EQ(options.at("--rays"), "-n");
            EXPECT_TRUE(options.count("--threads"));
            EXPECT_TRUE(options.count("--seed"));
            // pst makes its own beam, one per --angles value: --field has no place there.
            if (c != "pst") {
                EXPECT_TRUE(options.count("--field"));
            }
        }
        for (const char* old : {"--mc-rays", "--png", "--output-dir"}) EXPECT_FALSE(options.count(old));
        if (options.count("--output")) {
            EXPECT_EQ(options.at("--output"), "-o");
        }
        // The command's section in docs/cli.md names each of its own options.
        const size_t at = doc.find("\n## " + c + "\n");
        ASSERT_NE(at, std::string::npos) << "docs/cli.md has no section '## " << c << "'";
        const size_t end = doc.find("\n## ", at + 1);
        const std::string section = doc.substr(at, end == std::string::npos ? end : end - at);
        for (const auto& [name, shortName] : options) {
            if (kCommon.count(name)) {
                EXPECT_NE(doc.find("`" + name), std::string::npos) << name;
                continue;
            }
            EXPECT_NE(section.find(name), std::string::npos)
                << name << " of " << c << " is not documented in docs/cli.md";
        }
    }
}

TEST(CliConventions, RayCountsAreWholeNumbersWithSuffixes) {
    const std::string dir = ::testing::TempDir() + "veil_counts";
    VeilRun r = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 1.5 -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("'1.5' is not a whole number"), std::string::npos) << r.err;
    r = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 0.0005k -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("'0.0005k' is not a whole number"), std::string::npos) << r.err;
    // A suffix times a fraction that makes a whole number is that number.
    r = runVeil("trace examples/lenses/singlet.toml -n 0.5k --json");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(nlohmann::json::parse(r.out)["rays_per_source"].get<uint64_t>(), 500u);
    r = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 0 -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    r = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n ten -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("'ten'"), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));  // nothing written on a bad command line
    // 0.2k = 200 rays: the JSON report says so.
    r = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 0.2k --json --quiet");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["rays_per_source"].get<int>(), 200);
    // --json without -o writes nothing and says so.
    EXPECT_TRUE(j["files"].empty());
    EXPECT_FALSE(std::filesystem::exists(std::string(VEIL_SOURCE_DIR) + "/trace"));
}

// One rule for the field of an object at infinity, as [[source]] field_deg has it: strictly
// inside (-90, 90) degrees. "--field 0,90" had emitted 1.6e16 W from a 1 W beam, "0,180" was
// silently "0,0", and "1e300,0" ran.
TEST(CliConventions, FieldAnglesLieStrictlyInsideNinetyDegrees) {
    const std::string dir = ::testing::TempDir() + "veil_fields";
    for (const char* f : {"0,90", "0,180", "1e300,0", "-90,0"}) {
        const VeilRun r =
            runVeil(std::string("trace examples/scenes/longfocus_360mm_sun.toml -n 10 --field ") +
                    f + " -o " + dir);
        EXPECT_EQ(r.exitCode, 1) << f;
        EXPECT_NE(r.err.find("field 1: a field angle of an object at infinity lies strictly "
                             "between -90 and 90 degrees"),
                  std::string::npos)
            << r.err;
    }
    EXPECT_FALSE(std::filesystem::exists(dir));
    const VeilRun r =
        runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 10 --field 0,89 --json");
    EXPECT_EQ(r.exitCode, 0) << r.err;
}

// An option's bad value is a bad command line (exit 2), said as every error is.
TEST(CliConventions, BadOptionValuesExitTwoWithTheVeilPrefix) {
    const std::string dir = ::testing::TempDir() + "veil_bad_options";
    VeilRun r =
        runVeil("render examples/scenes/longfocus_360mm_sun.toml --time-limit 0s -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("veil: error: --time-limit:1:1: '0s' is no time limit"), std::string::npos)
        << r.err;
    // A range the option parser checks.
    r = runVeil("render examples/scenes/longfocus_360mm_sun.toml --aimed-splats 2 -o " + dir);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_EQ(r.err.rfind("veil: error: --aimed-splats", 0), 0u) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir));
}

TEST(CliConventions, MistypedCommandGetsASuggestion) {
    const VeilRun r = runVeil("trce examples/scenes/longfocus_360mm_sun.toml");
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_NE(r.err.find("did you mean 'trace'?"), std::string::npos) << r.err;
}

// Every command that writes files lists them at the end; -o is a folder for several files.
TEST(CliConventions, RunsListWhatTheyWrote) {
    const std::string dir = ::testing::TempDir() + "veil_written";
    std::filesystem::remove_all(dir);
    VeilRun r = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 50 --quiet -o " + dir +
                        "/t");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.out.find("wrote "), std::string::npos) << "--quiet lists nothing";
    r = runVeil("trace examples/scenes/longfocus_360mm_sun.toml -n 50 -o " + dir + "/t");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("wrote 3 files in " + dir + "/t: sensor_image.exr, sensor_image.png, "
                         "summary.json"),
              std::string::npos)
        << r.out;
    r = runVeil("export examples/scenes/longfocus_360mm.toml -o " + dir + "/x/scene.ply");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_NE(r.out.find("wrote 1 file in " + dir + "/x: scene.ply"), std::string::npos) << r.out;
    r = runVeil("paths examples/scenes/longfocus_360mm_sun.toml --where 'emit(sun)' --first 5 "
                "-n 200 --json -o " + dir + "/p");
    ASSERT_EQ(r.exitCode, 0) << r.err;
    const nlohmann::json j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["found"].get<int>(), 5);
    EXPECT_EQ(j["files"].size(), 2u);
    EXPECT_TRUE(std::filesystem::exists(dir + "/p/paths.svg"));
}

}  // namespace
