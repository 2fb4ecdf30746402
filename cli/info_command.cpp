// veil info FILE: first-order data, surfaces, spot sizes and the import report of a lens.
//
//   veil info examples/lenses/double_gauss_50mm.toml
//   veil info lens.zmx --json        # the same as JSON on standard output
//
// JSON: the primary wavelength's first-order data at the top level (efl_mm, bfl_mm,
// ffl_mm, f_number, ...), every wavelength under "wavelengths", surfaces, elements, spots
// and the import report beside them.

#include <iostream>

#include "analysis/lens/info_report.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "lensdata/glass_catalog.h"

namespace veil::cli {

void addInfoCommand(CLI::App& app, InfoOptions& options) {
    CLI::App* sub =
        app.add_subcommand("info", "first-order data, spots and import report of a lens");
    sub->add_option("file", options.file, "lens or scene file (.toml or .zmx)")->required();
    addReportFlags(sub, options.json, options.quiet);
    sub->add_option("--aim", options.aim, "ray aiming: real (to the real stop) or paraxial")
        ->check(CLI::IsMember({"real", "paraxial"}));
    sub->add_option("--rings", options.rings, "hexapolar rings for the spot diagrams")
        ->check(CLI::Range(1, 200));
}

int runInfo(const CommonOptions& common, const InfoOptions& options) {
    const GlassCatalog catalog = loadCatalog(common);
    const InfoReport report =
        makeInfoReport(options.file, readScene(common, options.file, catalog).prescription,
                       catalog, options.aim == "real" ? AimMode::Real : AimMode::Paraxial,
                       options.rings);
    if (options.json)
        std::cout << report.json().dump(2) << "\n";
    else
        std::cout << report.text();
    return 0;
}

}  // namespace veil::cli
