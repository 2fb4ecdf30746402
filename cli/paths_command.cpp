// veil paths SCENE --where EXPR --first N -o DIR: traces rays with path histories and draws
// the first N emitted rays (in ray order) with a path that satisfies the criterion, each with
// every one of its branches that does, over the y-z section of lens, mechanics, stop and
// detector, as DIR/paths.svg and DIR/paths.png (DIR defaults to ./paths).
//
//   veil paths examples/scenes/longfocus_360mm_sun.toml --where "emit(sun)" --first 300
//       -o out/all
//   veil paths scene.toml --where "seq(fresnel(L4.back), fresnel(L4.front), hit(sensor))"
//       --first 50 -n 2M --colour event -o out/ghost
//
// Rays are traced in batches of --batch rays per source (batch b with seed --seed + b) until
// N such rays are found or -n rays per source are traced; the same seed gives the same paths with
// any number of threads. The criterion syntax is docs/criteria.md; an error names its column.

#include "cli/paths_command.h"

#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "analysis/pictures/layout.h"
#include "analysis/pictures/path_picture.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_transport.h"

namespace veil::cli {

void addPathDrawingOptions(CLI::App* sub, std::string& colour, std::string& mode,
                           double& minRelativeFlux) {
    sub->add_option("--colour,--color", colour, "segment colour: flux (log) or event type")
        ->check(CLI::IsMember({"flux", "event"}))
        ->capture_default_str();
    sub->add_option("--mode", mode,
                    "split (every Fresnel branch is a path) or random (one path per ray)")
        ->check(CLI::IsMember({"split", "random"}))
        ->capture_default_str();
    sub->add_option("--min-flux", minRelativeFlux,
                    "a branch below this share of its ray's emitted flux, after every bounce "
                    "(both modes), plays Russian roulette: kept at 1e-2 of it or ended")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
}

PathSelectionOptions pathSelectionOptions(const SceneTransport& trace, const std::string& where,
                                          int first, uint64_t raysPerSource, uint64_t batch,
                                          uint64_t seed, const std::string& mode,
                                          double minRelativeFlux) {
    PathSelectionOptions po;
    po.where = where;
    po.count = static_cast<size_t>(first);
    po.maxRays = raysPerSource * trace.view.sources.size();
    po.batchRays = batch;
    po.transport.seed = seed;
    po.transport.mode =
        mode == "random" ? TransportOptions::Mode::Random : TransportOptions::Mode::Split;
    po.transport.minRelativeFlux = minRelativeFlux;
    po.transport.rescueRelativeFlux = std::max(1e-2, minRelativeFlux);
    return po;
}

void addPathsCommand(CLI::App& app, PathsOptions& o) {
    CLI::App* sub =
        app.add_subcommand("paths", "draw the first N rays with paths matching a criterion");
    sub->add_option("scene", o.file, "scene or lens file (.toml or .zmx)")->required();
    sub->add_option("--where", o.where, "path criterion (docs/criteria.md)")->required();
    sub->add_option("--first", o.first,
                    "emitted rays to draw, each with all its branches that match")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    addRays(sub, o.rays, "emitted rays per source to trace at most");
    addOutputFolder(sub, o.output, "paths");
    addFields(sub, o.fields);
    addCount(sub, "--batch", o.batch, "rays per source per batch");
    addPathDrawingOptions(sub, o.colour, o.mode, o.minRelativeFlux);
    addRunControls(sub, o.threads, o.seed);
    sub->add_option("--width-px", o.widthPx, "PNG width in pixels")
        ->check(CLI::Range(200, 20000))
        ->capture_default_str();
    sub->add_flag("--no-mechanics", o.noMechanics, "leave the [mechanics] section out");
    addReportFlags(sub, o.json, o.quiet);
}

int runPaths(const CommonOptions& common, const PathsOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    SceneOptions so;
    so.mechanics = !o.noMechanics;
    const std::unique_ptr<const PreparedScene> prepared =
        prepareTracedScene(common, o.file, o.fields, catalog, so);
    const SceneGeometry& setup = prepared->geometry();
    const SceneTransport& ts = prepared->transport();
    reportSceneNotes(*prepared);

    const auto limit = limitThreads(o.threads);
    PathSelectionOptions po = pathSelectionOptions(ts, o.where, o.first, o.rays, o.batch, o.seed,
                                                   o.mode, o.minRelativeFlux);
    po.whereSource = "--where 1";  // as trace names its criteria
    // Progress by batch; the run ends early once --first rays are found.
    ProgressReporter reporter;
    if (!o.quiet) {
        po.progress = reporter.sink();
        po.progress({po.task, 0, po.maxRays});
    }
    const PathSelection sel = selectPaths(ts.view, ts.images, po);
    reporter.finishAt(sel.raysTraced);

    veil::LayoutOptions lo;
    lo.title = setup.prescription.system.name.empty() ? o.file : setup.prescription.system.name;
    lo.sources = layoutSources(ts.view.sources, setup.scene);
    lo.axisVerticesMm = layoutAxis(*setup.model);
    lo.detectors = layoutDetectors(setup.detectors);
    const Picture base = drawLayout(setup.scene, lo);
    PathPictureOptions pp;
    pp.colouring = o.colour == "event" ? PathColouring::EventType : PathColouring::LogFlux;
    const Picture pic = drawPaths(base, sel, pp);  // clipped to the layout's frame

    const std::filesystem::path dir = outputFolder(o.output, "paths", o.json);
    WrittenFiles written;
    if (!dir.empty()) {
        written.beginRun(dir);
        std::filesystem::create_directories(dir);
        writePicture(pic, dir / "paths", o.widthPx, written);
        written.finishRun();
    }
    if (sel.rays.size() < static_cast<size_t>(o.first))
        std::cerr << "veil: only " << sel.rays.size() << " of " << sel.raysTraced
                  << " rays have a matching path; raise -n to find more\n";
    if (o.json) {
        nlohmann::json j{{"scene", o.file},
                         {"where", o.where},
                         {"requested", o.first},
                         {"found", sel.rays.size()},
                         {"paths_drawn", sel.pathCount()},
                         {"rays_traced", sel.raysTraced},
                         {"paths_evaluated", sel.pathsEvaluated},
                         {"paths_matched", sel.pathsMatched},
                         {"seed", o.seed},
                         {"files", written.json()}};
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    std::cout << "found " << sel.rays.size() << " of " << o.first << " rays with paths matching '"
              << o.where << "' in " << sel.raysTraced << " rays, " << sel.pathCount()
              << " matching paths drawn (" << sel.pathsMatched << " of " << sel.pathsEvaluated
              << " paths matched)\n";
    if (!o.quiet) written.print(std::cout);
    return 0;
}

}  // namespace veil::cli
