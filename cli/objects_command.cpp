// veil objects SCENE: the objects the sources light and the detector sees, ranked by the
// product (analysis/studies/objects.h).
//
//   veil objects examples/scenes/longfocus_360mm_sun.toml -n 20000 -o out/objects
//
// Writes DIR/objects.csv, objects.md, objects.json and the layout objects.png / objects.svg
// with the first --top objects coloured by rank; the table goes to standard output (or the
// JSON with --json), progress to standard error.

#include <iostream>
#include <nlohmann/json.hpp>

#include "analysis/studies/objects.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/output_file.h"
#include "tracer/scene/prepared_scene.h"

namespace veil::cli {

void addObjectsCommand(CLI::App& app, ObjectsOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "objects",
        "the objects the sources light and the detector sees, ranked: what to blacken or "
        "baffle first");
    sub->add_option("scene", o.file, "scene or lens file (.toml or .zmx)")->required();
    addRays(sub, o.rays, "rays per source, and rays from the detector")->capture_default_str();
    sub->add_option("--source", o.source,
                    "count the light of this [[source]] alone (default: every source)");
    sub->add_option("--detector", o.detector,
                    "the detector whose view counts (default: the first)");
    addFields(sub, o.fields);
    sub->add_flag("--optical", o.includeOptical,
                  "rank the polished optical faces (lens faces, mirrors) with the rest; by "
                  "default they are listed apart");
    sub->add_option("--rank", o.rank,
                    "what ranks: product (lit x seen, the geometry whatever the finishes) or "
                    "estimate (the first-order scatter with the scene's finishes)")
        ->check(CLI::IsMember({"product", "estimate"}))
        ->capture_default_str();
    sub->add_option("--top", o.top, "ranked objects coloured in the picture")
        ->check(CLI::Range(1, 1000))
        ->capture_default_str();
    addOutputFolder(sub, o.output, "objects");
    addRunControls(sub, o.threads, o.seed);
    addTransportFlags(sub, o.transport);
    addReportFlags(sub, o.json, o.quiet);
}

int runObjectsCommand(const CommonOptions& common, const ObjectsOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    const std::unique_ptr<const PreparedScene> prepared =
        prepareTracedScene(common, o.file, o.fields, catalog);
    reportSceneNotes(*prepared);
    ObjectsSpec spec;
    spec.rays = o.rays;
    applyTransportFlags(o.transport, spec.transport);
    spec.transport.seed = o.seed;
    spec.source = o.source;
    spec.detector = o.detector;
    spec.includeOptical = o.includeOptical;
    spec.rank = o.rank == "estimate" ? ObjectsSpec::Rank::Estimate : ObjectsSpec::Rank::Product;
    const std::filesystem::path dir = outputFolder(o.output, "objects", o.json);
    const auto limit = limitThreads(o.threads);
    ProgressReporter reporter;
    if (!o.quiet) spec.progress = reporter.sink();
    const ObjectsResult result = runObjects(*prepared, spec);
    reporter.finish();

    WrittenFiles written;
    if (!dir.empty()) {
        written.beginRun(dir);
        std::filesystem::create_directories(dir);
        for (const auto& [name, text] :
             {std::pair<std::string, std::string>{"objects.csv", result.csv()},
              {"objects.md", result.markdown()},
              {"objects.json", result.json()}}) {
            writeTextFile(dir / name, text);
            written.add(dir / name);
        }
        writePicture(drawObjects(*prepared, result, o.top), dir / "objects", 2000, written);
        written.finishRun();
    }
    printReport(result.json(), result.markdown(), written, o.json, o.quiet);
    return 0;
}

}  // namespace veil::cli
