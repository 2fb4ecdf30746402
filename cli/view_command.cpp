// veil view SCENE [--where EXPR --first N] -o scene.html: the scene in 3D as one self-contained
// HTML page (analysis/pictures/scene_view.h): lens solids, mechanics, detectors and sources, and
// with
// --where the first N rays with a matching path (selected as `veil paths` selects them),
// coloured by log flux or by event.
//
//   veil view examples/scenes/double_gauss_ghosts.toml -o out/scene.html
//   veil view examples/scenes/longfocus_360mm_sun.toml --where "scatter(L*.edge)" --first 200
//       -o out/butt_ends.html
//
// three.js comes from Debian's libjs-three (or $VEIL_THREE_JS_DIR) and is inlined when the
// page is written: the page fetches nothing when it is opened. The page's data and checks
// happen before any ray is traced: a missing three.js, a bad criterion or an unwritable -o
// stop the command first.

#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "analysis/pictures/path_picture.h"
#include "analysis/pictures/scene_view.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "cli/paths_command.h"
#include "cli/progress.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_transport.h"

namespace veil::cli {

void addViewCommand(CLI::App& app, ViewOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "view", "the scene and selected ray paths in 3D, as one self-contained HTML page");
    sub->add_option("scene", o.file, "scene or lens file (.toml or .zmx)")->required();
    addOutputFile(sub, o.output, "HTML file to write (folders created as needed)");
    sub->add_option("--where", o.where,
                    "draw the rays with a path matching this criterion (docs/criteria.md)");
    sub->add_option("--first", o.first,
                    "emitted rays to draw (with --where), each with all its branches that match")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    addRays(sub, o.rays, "emitted rays per source to trace at most (with --where)");
    addFields(sub, o.fields);
    addCount(sub, "--batch", o.batch, "rays per source per batch");
    addPathDrawingOptions(sub, o.colour, o.mode, o.minRelativeFlux);
    addRunControls(sub, o.threads, o.seed);
    sub->add_option("--chord-tolerance", o.chordToleranceMm,
                    "display tessellation of exact faces, mm (smaller: smoother and larger pages)")
        ->check(CLI::Range(1e-4, 10.0))
        ->capture_default_str();
    sub->add_flag("--no-mechanics", o.noMechanics, "leave the [mechanics] section out");
    addReportFlags(sub, o.json, o.quiet);
}

namespace {

namespace fs = std::filesystem;

// -o names an HTML file veil may write; --colour event needs paths.
void checkViewOptions(const ViewOptions& o) {
    const fs::path out(o.output);
    if (out.empty() || !out.has_filename())
        throw ParseError({"-o " + o.output, 0, 0}, "expected an HTML file name");
    if (fs::is_directory(out))
        throw ParseError({"-o " + o.output, 0, 0}, "is a folder; view writes one HTML file");
    requireWritableFolder(out.has_parent_path() ? out.parent_path() : fs::path("."), "-o",
                          o.output);
    if (o.where.empty() && o.colour == "event")
        throw ParseError({"--colour event", 0, 0}, "colours ray paths: give --where too");
}

// The first --first rays with a path matching --where, as veil paths selects them.
PathSelection viewPaths(const PreparedScene& prepared, const ViewOptions& o) {
    const SceneTransport& ts = prepared.transport();
    const auto limit = limitThreads(o.threads);
    PathSelectionOptions po = pathSelectionOptions(ts, o.where, o.first, o.rays, o.batch, o.seed,
                                                   o.mode, o.minRelativeFlux);
    ProgressReporter reporter;
    po.task = "view";
    if (!o.quiet && !o.json) {
        po.progress = reporter.sink();
        po.progress({po.task, 0, po.maxRays});
    }
    PathSelection sel = selectPaths(ts.view, ts.images, po);
    reporter.finishAt(sel.raysTraced);
    if (sel.rays.size() < static_cast<size_t>(o.first))
        std::cerr << "veil: only " << sel.rays.size() << " of " << sel.raysTraced
                  << " rays have a matching path; raise -n to find more\n";
    return sel;
}

void printViewReport(const ViewOptions& o, const nlohmann::json& data, size_t sources,
                     const std::optional<PathSelection>& sel) {
    const fs::path out(o.output);
    size_t triangles = 0, objects = 0;
    for (const nlohmann::json& obj : data["objects"])
        if (obj["triangles"].get<size_t>() > 0) {
            ++objects;
            triangles += obj["triangles"].get<size_t>();
        }
    WrittenFiles written;
    written.add(out);
    if (o.json) {
        nlohmann::json j{{"scene", o.file},   {"objects", objects},          {"triangles", triangles},
                         {"sources", sources}, {"bytes", fs::file_size(out)}, {"files", written.json()}};
        if (sel) {
            j["where"] = o.where;
            j["rays_found"] = sel->rays.size();
            j["paths_drawn"] = sel->pathCount();
            j["rays_traced"] = sel->raysTraced;
            j["seed"] = o.seed;
        }
        std::cout << j.dump(2) << "\n";
        return;
    }
    std::cout << objects << " objects (" << triangles << " triangles), " << sources << " source"
              << (sources == 1 ? "" : "s");
    if (sel)
        std::cout << ", " << sel->pathCount() << " paths of " << sel->rays.size()
                  << " rays matching '" << o.where << "' in " << sel->raysTraced << " rays";
    std::cout << "; " << fs::file_size(out) / 1024 << " KB, nothing fetched when opened\n";
    if (!o.quiet) written.print(std::cout);
}

}  // namespace

int runView(const CommonOptions& common, const ViewOptions& o) {
    checkViewOptions(o);
    const ThreeJs three = loadThreeJs();
    const GlassCatalog catalog = loadCatalog(common);
    SceneOptions so;
    so.mechanics = !o.noMechanics;
    const bool traced = !o.where.empty() || !o.fields.empty();
    const std::unique_ptr<const PreparedScene> prepared =
        traced ? prepareTracedScene(common, o.file, o.fields, catalog, so)
               : PreparedScene::build(readScene(common, o.file, catalog), catalog, so);
    reportSceneNotes(*prepared);
    const SceneGeometry& setup = prepared->geometry();
    const std::vector<Source> noSources;
    const std::vector<Source>& sources =
        prepared->hasSources() ? prepared->transport().view.sources : noSources;
    SceneViewOptions vo;
    vo.title = setup.prescription.system.name.empty() ? o.file : setup.prescription.system.name;
    vo.chordToleranceMm = o.chordToleranceMm;
    vo.detectors = setup.detectors;
    vo.colouring = o.colour == "event" ? PathColouring::EventType : PathColouring::LogFlux;
    std::optional<PathSelection> sel;
    if (!o.where.empty()) {
        sel = viewPaths(*prepared, o);
        vo.paths = &*sel;
        vo.title += " -- " + std::to_string(sel->pathCount()) + " paths matching '" + o.where + "'";
    }
    const nlohmann::json data = sceneViewData(setup.scene, sources, vo);
    const fs::path out(o.output);
    if (out.has_parent_path()) fs::create_directories(out.parent_path());
    writeSceneView(out, data, three);
    printViewReport(o, data, sources.size(), sel);
    return 0;
}

}  // namespace veil::cli
