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
#include "lensdata/output_file.h"
#include "lensdata/toml_reader.h"
#include "lensdata/toml_writer.h"
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

void addExportLensCommand(CLI::App& app, ExportLensOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "export-lens",
        "a lens file (Zemax, CODE V) as a veil lens file to read and edit (docs/format.md)");
    sub->add_option("file", o.file, "lens or scene file (.zmx, .seq, .toml)")->required();
    addOutputFile(sub, o.output,
                  "TOML file to write (folders created as needed; default: standard output)");
    addReportFlags(sub, o.json, o.quiet);
}

int runExportLens(const CommonOptions& common, const ExportLensOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    // The lens as the commands read and build it: --set edits applied, and sizes that did not
    // build fitted (each change a comment at the top, as the import's other warnings).
    const SceneSpec spec = readScene(common, o.file, catalog);
    reportImportWarnings(spec);
    const Prescription& lens = spec.prescription;
    const std::string name = std::filesystem::path(o.file).filename().string();
    std::string text = prescriptionToml(lens, catalog, name);
    std::string said;
    for (const ImportNote& n : lens.report)
        if (n.severity != ImportNote::Severity::Info) said += "#   " + n.message + "\n";
    if (!said.empty()) {
        const size_t at = text.find("\n\n");
        text.insert(at + 1, "# What the import changed or left out:\n" + said);
    }
    // What is written reads back (a check, not a second opinion: the same reader).
    readTomlPrescriptionText(text, name + " as TOML", catalog);
    WrittenFiles written;
    if (o.output.empty()) {
        std::cout << text;
        return 0;
    }
    const std::filesystem::path out(o.output);
    if (out.has_parent_path()) std::filesystem::create_directories(out.parent_path());
    writeTextFile(out, text);
    written.add(out);
    if (o.json) {
        nlohmann::json j{
            {"file", o.file}, {"surfaces", lens.surfaces.size()}, {"files", written.json()}};
        std::cout << j.dump(2) << "\n";
    } else if (!o.quiet) {
        std::cout << lens.surfaces.size() << " surfaces of " << name
                  << " written as a veil lens file\n";
        written.print(std::cout);
    }
    return 0;
}

}  // namespace veil::cli
