#pragma once
// Subcommands of the veil executable.

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "lensdata/glass_catalog.h"

namespace veil::cli {

struct CommonOptions {
    std::vector<std::string> glassCatalogs;
};
// Built-in catalogs, VEIL_GLASS_PATH and every --glass-catalog file.
GlassCatalog loadCatalog(const CommonOptions& common);

struct InfoOptions {
    std::string file;
    bool json = false;
    std::string aim = "real";
    int rings = 8;
};
void addInfoCommand(CLI::App& app, CommonOptions& common, InfoOptions& options);
int runInfo(const CommonOptions& common, const InfoOptions& options);

}  // namespace veil::cli
