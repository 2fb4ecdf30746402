// veil paths SCENE --where EXPR --first N -o paths.svg: traces rays with path histories and
// draws the first N paths (in ray order) that satisfy the criterion over the y-z section of
// lens, mechanics, stop and detector, as SVG and PNG (the PNG beside the SVG unless --png).
//
//   veil paths examples/scenes/longfocus_360mm_sun.toml --where "emit(sun)" --first 300
//       -o all.svg
//   veil paths scene.toml --where "seq(fresnel(L4.back), fresnel(L4.front), hit(sensor))"
//       --first 50 --rays 2e6 --colour event -o ghost.svg
//
// Rays are traced in batches of --batch rays per source (batch b with seed --seed + b) until
// N paths are found or --rays are traced; the same seed gives the same paths with any number
// of threads. The criterion syntax is docs/criteria.md; an error names its column.

#include "cli/paths_command.h"

#include <filesystem>
#include <iostream>
#include <memory>

#include "analysis/layout.h"
#include "analysis/path_picture.h"
#include "tracer/prepared_scene.h"

namespace veil::cli {

void addPathsCommand(CLI::App& app, PathsOptions& o) {
    CLI::App* sub = app.add_subcommand("paths", "draw the first N ray paths matching a criterion");
    sub->add_option("scene", o.file, "scene file (.toml) with [[source]]")->required();
    sub->add_option("--where", o.where, "path criterion (docs/criteria.md)")->required();
    sub->add_option("--first", o.first, "number of paths to draw")
        ->check(CLI::Range(1, 1000000))
        ->capture_default_str();
    sub->add_option("-o,--output", o.output, "SVG file to write")->capture_default_str();
    sub->add_option("--png", o.png, "PNG file (default: the SVG name with .png)");
    sub->add_option("--rays", o.rays, "emitted rays to trace at most (all sources)")
        ->check(CLI::Range(1.0, 1e13))
        ->capture_default_str();
    sub->add_option("--batch", o.batch, "rays per source per batch")
        ->check(CLI::Range(1.0, 1e9))
        ->capture_default_str();
    sub->add_option("--colour,--color", o.colour, "segment colour: flux (log) or event type")
        ->check(CLI::IsMember({"flux", "event"}))
        ->capture_default_str();
    sub->add_option("--mode", o.mode,
                    "split (every Fresnel branch is a path) or random (one path per ray)")
        ->check(CLI::IsMember({"split", "random"}))
        ->capture_default_str();
    sub->add_option("--min-flux", o.minRelativeFlux,
                    "cull a branch below this share of its ray's emitted flux, after every bounce "
                    "(both modes)")
        ->capture_default_str();
    sub->add_option("--seed", o.seed, "random seed")->capture_default_str();
    sub->add_option("--threads", o.threads, "worker threads (0: all cores)")->capture_default_str();
    sub->add_option("--width-px", o.widthPx, "PNG width in pixels")
        ->check(CLI::Range(200, 20000))
        ->capture_default_str();
    sub->add_flag("--no-mechanics", o.noMechanics, "leave the [mechanics] section out");
}

int runPaths(const CommonOptions& common, const PathsOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    SceneOptions so;
    so.mechanics = !o.noMechanics;
    const std::unique_ptr<const PreparedScene> prepared = PreparedScene::read(o.file, catalog, so);
    const SceneSetup& setup = prepared->setup();
    const TraceSetup& ts = prepared->trace();
    reportSceneNotes(setup);

    const auto limit = limitThreads(o.threads);
    PathSelectionOptions po;
    po.where = o.where;
    po.count = static_cast<size_t>(o.first);
    po.maxRays = static_cast<uint64_t>(o.rays);
    po.batchRays = static_cast<uint64_t>(o.batch);
    po.transport.seed = o.seed;
    po.transport.mode =
        o.mode == "random" ? TransportOptions::Mode::Random : TransportOptions::Mode::Split;
    po.transport.minRelativeFlux = o.minRelativeFlux;
    const PathSelection sel = selectPaths(ts.transport, ts.images, po);

    veil::LayoutOptions lo;
    lo.title = setup.prescription.system.name.empty() ? o.file : setup.prescription.system.name;
    const Picture base = drawLayout(setup.scene, lo);
    PathPictureOptions pp;
    pp.colouring = o.colour == "event" ? PathColouring::EventType : PathColouring::LogFlux;
    // Keep exit segments inside the scene's frame (the layout's padding, a little wider).
    const Bounds3 b = setup.scene.bounds();
    const double pad = 0.06 * std::max(b.hi.z - b.lo.z, b.hi.y - b.lo.y);
    pp.clipZY = std::array<double, 4>{b.lo.z - pad, b.hi.z + pad, b.lo.y - pad, b.hi.y + pad};
    const Picture pic = drawPaths(base, sel, pp);

    std::filesystem::path png = o.png;
    if (png.empty()) png = std::filesystem::path(o.output).replace_extension(".png");
    const std::filesystem::path parent = std::filesystem::path(o.output).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent);
    pic.writeSvg(o.output);
    pic.writePng(png, o.widthPx);
    std::cout << "found " << sel.paths.size() << " of " << o.first << " paths matching '" << o.where
              << "' in " << sel.raysTraced << " rays (" << sel.pathsMatched << " of "
              << sel.pathsEvaluated << " paths matched)\n"
              << "wrote " << o.output << " and " << png.string() << "\n";
    if (sel.paths.size() < static_cast<size_t>(o.first))
        std::cerr << "veil: only " << sel.paths.size() << " matching paths in " << sel.raysTraced
                  << " rays; raise --rays to find more\n";
    return 0;
}

}  // namespace veil::cli
