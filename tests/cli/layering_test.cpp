// The house's rules, checked on the source tree (docs/architecture.md): no file includes a
// header of a module above its own; tracer/ and analysis/ keep their files in concept folders,
// each listed in the module's README.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;

const fs::path kRoot = VEIL_SOURCE_DIR;

// The modules from the bottom up.
const std::map<std::string, int> kLayer = {
    {"lensdata", 0}, {"geometry", 1}, {"tracer", 2}, {"analysis", 3}, {"cli", 4}};

bool isSource(const fs::path& p) { return p.extension() == ".h" || p.extension() == ".cpp"; }

std::string readText(const fs::path& p) {
    std::ifstream in(p);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
}

TEST(Layering, NoFileIncludesAHeaderOfAHigherModule) {
    const std::regex include(R"(^#include "([a-z]+)/)");
    int files = 0;
    for (const auto& [module, layer] : kLayer) {
        for (const auto& entry : fs::recursive_directory_iterator(kRoot / module)) {
            if (!entry.is_regular_file() || !isSource(entry.path())) continue;
            ++files;
            std::ifstream in(entry.path());
            std::string line;
            for (int n = 1; std::getline(in, line); ++n) {
                std::smatch m;
                if (!std::regex_search(line, m, include)) continue;
                const auto other = kLayer.find(m[1].str());
                if (other == kLayer.end()) continue;
                EXPECT_LE(other->second, layer)
                    << fs::relative(entry.path(), kRoot).string() << ":" << n << " includes "
                    << m[1].str() << "/, a module above " << module;
            }
        }
    }
    EXPECT_GT(files, 200);  // the walk found the tree
}

TEST(Layering, TracerAndAnalysisKeepTheirFilesInConceptFolders) {
    for (const std::string module : {"tracer", "analysis"}) {
        int topLevel = 0;
        std::vector<std::string> folders;
        for (const auto& entry : fs::directory_iterator(kRoot / module)) {
            if (entry.is_regular_file() && isSource(entry.path())) ++topLevel;
            if (entry.is_directory()) folders.push_back(entry.path().filename().string());
        }
        EXPECT_LE(topLevel, 14) << module << "/ holds " << topLevel << " source files at its top";
        EXPECT_GE(folders.size(), 5u) << module;
        const std::string readme = readText(kRoot / module / "README.md");
        for (const std::string& f : folders)
            EXPECT_NE(readme.find("`" + f + "/`"), std::string::npos)
                << module << "/README.md does not list its folder " << f << "/";
    }
}

}  // namespace
