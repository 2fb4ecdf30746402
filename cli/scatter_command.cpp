// veil scatter SCENE: what the scene's scatter models do (analysis/studies/scatter_report.h): each
// scattering property's TIS against incidence at the scene's wavelengths, its BRDF (and
// BTDF) against scatter angle, and measured tables' stated TIS beside the model's.
//
//   veil scatter examples/scenes/materials.toml -o out/scatter
//   veil scatter scene.toml --property black_anodize --wavelength 550 --bsdf
//
// Writes DIR/scatter.md, scatter.csv, scatter.json, tis.png/.svg (per wavelength when there
// are several), brdf_NAME.png/.svg (btdf_NAME for transmission), brdf_compare.png/.svg (every
// property's BRDF at 30 degrees incidence, when there are several) and, with --bsdf,
// each channel as a Zemax .bsdf table (NAME.brdf.bsdf, NAME.btdf.bsdf) at the first
// wavelength. The report goes to standard output (or the JSON with --json).

#include <iostream>

#include "analysis/studies/scatter_report.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/output_file.h"
#include "lensdata/zemax_bsdf.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/surfaces/property_table.h"
#include "tracer/surfaces/scatter_tabulation.h"

namespace veil::cli {

void addScatterCommand(CLI::App& app, ScatterOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "scatter", "the scene's scatter models: TIS against incidence, BRDF against angle, tables");
    sub->add_option("scene", o.file, "scene or lens file (.toml or .zmx)")->required();
    sub->add_option("--property", o.properties,
                    "report this property (repeatable; default: every scattering property an "
                    "object carries)");
    sub->add_option("--wavelength", o.wavelengthsNm,
                    "wavelength in nm (repeatable; default: the lens's wavelengths)")
        ->check(CLI::Range(100.0, 100000.0));
    sub->add_flag("--bsdf", o.writeBsdf,
                  "also write each channel as a Zemax .bsdf table at the first wavelength");
    addOutputFolder(sub, o.output, "scatter");
    addReportFlags(sub, o.json, o.quiet);
}

namespace {

std::string fileSafe(const std::string& name) {
    std::string s;
    for (char c : name)
        s += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
    return s;
}

}  // namespace

int runScatterCommand(const CommonOptions& common, const ScatterOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    const std::filesystem::path dir = outputFolder(o.output, "scatter", o.json);
    const std::unique_ptr<const PreparedScene> prepared =
        PreparedScene::build(readScene(common, o.file, catalog), catalog);
    reportSceneNotes(*prepared);
    const PropertyTable& table = prepared->spec().properties;
    ScatterReportSpec spec;
    spec.properties = o.properties;
    spec.wavelengthsNm = o.wavelengthsNm;
    const ScatterReport report = scatterReport(
        table, prepared->scene(), table.resolve(prepared->scene()), prepared->model(), spec);

    WrittenFiles written;
    if (!dir.empty()) {
        written.beginRun(dir);
        std::filesystem::create_directories(dir);
        for (const auto& [name, text] :
             {std::pair<std::string, std::string>{"scatter.md", report.markdown()},
              {"scatter.csv", report.csv()},
              {"scatter.json", report.json()}}) {
            writeTextFile(dir / name, text);
            written.add(dir / name);
        }
        if (!report.properties.empty())
            for (size_t w = 0; w < report.wavelengthsNm.size(); ++w)
                writePicture(
                    drawTisChart(report, static_cast<int>(w)),
                    dir / (report.wavelengthsNm.size() == 1
                               ? std::string("tis")
                               : "tis_" + std::to_string(std::lround(report.wavelengthsNm[w])) +
                                     "nm"),
                    1600, written);
        const double nm = report.wavelengthsNm.front();
        if (report.properties.size() >= 2) {
            std::vector<const OpticalProperty*> all;
            for (const ScatterPropertyReport& r : report.properties)
                all.push_back(&table.property(table.find(r.name)));
            writePicture(drawBrdfComparison(all, nm, 30.0), dir / "brdf_compare", 1600, written);
        }
        for (const ScatterPropertyReport& r : report.properties) {
            const OpticalProperty& p = table.property(table.find(r.name));
            const std::string stem = fileSafe(r.name);
            writePicture(drawBsdfChart(p, false, nm, 1.0, spec.plotIncidencesDeg),
                         dir / ("brdf_" + stem), 1600, written);
            if (!r.transmitTis.empty())
                writePicture(
                    drawBsdfChart(p, true, nm, r.transmitIndex.front(), spec.plotIncidencesDeg),
                    dir / ("btdf_" + stem), 1600, written);
            if (o.writeBsdf) {
                for (bool transmit : {false, true}) {
                    if (transmit && r.transmitTis.empty()) continue;
                    const ZemaxBsdf d = tabulateScatter(p, transmit, exportGrid(), nm, 1.0,
                                                        transmit ? r.transmitIndex.front() : 1.0);
                    std::ostringstream os;
                    writeZemaxBsdf(os, d);
                    const auto path = dir / (stem + (transmit ? ".btdf.bsdf" : ".brdf.bsdf"));
                    writeTextFile(path, os.str());
                    written.add(path);
                }
            }
        }
        written.finishRun();
    }
    printReport(report.json(), report.markdown(), written, o.json, o.quiet);
    return 0;
}

}  // namespace veil::cli
