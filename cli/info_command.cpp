// veil info FILE: first-order data, surfaces, spot sizes and the import report of a lens, and
// whether it builds into the scene veil trace would make of it (exit 1 when it does not).
//
//   veil info examples/lenses/double_gauss_50mm.toml
//   veil info lens.zmx --json        # the same as JSON on standard output
//
// JSON: the primary wavelength's first-order data at the top level (efl_mm, bfl_mm,
// ffl_mm, f_number, ...), every wavelength under "wavelengths", surfaces, elements, spots
// and the import report beside them.

#include <iostream>

#include "analysis/lens/default_scene.h"
#include "analysis/lens/info_report.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_spec.h"

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

namespace {

// The scene veil trace would build of this file: the same sizes, solids, mechanics and
// default stop plate, checked for collisions; what stops it is reported, not thrown.
SceneBuildCheck checkBuild(const SceneSpec& spec, const GlassCatalog& catalog) {
    SceneBuildCheck b;
    b.sizeChanges = spec.sizeChanges;
    b.elements = static_cast<int>(spec.prescription.elements().size());
    try {
        const std::unique_ptr<PreparedScene> scene = veil::prepareTracedScene(spec, catalog, {});
        const SceneGeometry& g = scene->geometry();
        b.objects = static_cast<int>(g.scene.objects().size());
        b.mechanicalParts = static_cast<int>(g.mechanicalParts.size());
        for (size_t i = spec.prescription.report.size(); i < g.notes.size(); ++i)
            b.notes.push_back(g.notes[i].message);
        b.built = true;
    } catch (const ModelError& e) {
        b.error = e.what();
    } catch (const ParseError& e) {
        b.error = e.what();
    }
    return b;
}

}  // namespace

int runInfo(const CommonOptions& common, const InfoOptions& options) {
    const GlassCatalog catalog = loadCatalog(common);
    const SceneSpec spec = readScene(common, options.file, catalog);
    InfoReport report =
        makeInfoReport(options.file, spec.prescription, catalog,
                       options.aim == "real" ? AimMode::Real : AimMode::Paraxial, options.rings);
    report.build = checkBuild(spec, catalog);
    if (options.json)
        std::cout << report.json().dump(2) << "\n";
    else
        std::cout << report.text();
    if (!report.build->built) {
        std::cerr << "veil: error: the lens does not build into a scene: " << report.build->error
                  << "\n";
        return 1;
    }
    return 0;
}

}  // namespace veil::cli
