// veil glare SCENE: the veiling glare index (ISO 9358) at field positions, its specular
// (ghost) and diffuse (scatter) parts, with errors (analysis/studies/glare.h, docs/glare.md).
//
//   veil glare examples/scenes/double_gauss_50mm_painted.toml -o out/glare
//   veil glare scene.toml --field 0,0 --field 0,15 --spot-deg 1 --passes 16
//
// Writes DIR/glare.md, glare.csv, glare.json and, for two positions or more, glare.png /
// glare.svg (VGI and its parts against the field angle). The table goes to standard output
// (or the JSON with --json), progress to standard error.

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <optional>
#include <sstream>

#include "analysis/pictures/chart.h"
#include "analysis/studies/glare.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/output_file.h"
#include "tracer/scene/scene_spec.h"

namespace veil::cli {

void addGlareCommand(CLI::App& app, GlareOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "glare", "veiling glare index (ISO 9358) at field positions: ghosts and scatter");
    sub->add_option("scene", o.file, "scene or lens file (.toml or .zmx)")->required();
    sub->add_option("--spot-deg", o.spotDeg, "angular diameter of the black spot")
        ->check(CLI::Range(1e-3, 20.0))
        ->capture_default_str();
    sub->add_option("--field-deg", o.fieldDeg,
                    "half angle of the bright Lambertian field about the axis")
        ->check(CLI::Range(1.0, 89.0))
        ->capture_default_str();
    addFields(sub, o.fields)
        ->description(
            "black spot position X,Y in degrees (repeatable; default: the axis and the lens's "
            "fields)");
    sub->add_option("--f-number", o.fNumbers,
                    "stop the lens down to this image-space F-number (repeatable; needs a "
                    "[mechanics] stop; default: the lens as given)")
        ->check(CLI::Range(0.1, 1000.0));
    sub->add_option("--passes", o.passes, "render passes per position and field")
        ->check(CLI::Range(2, 100000))
        ->capture_default_str();
    addCount(sub, "--photons", o.photons, "photons per pass");
    addCount(sub, "--rays-per-pixel", o.raysPerPixel, "backward rays per pixel per pass");
    sub->add_option("--pixels", o.pixels, "pixels per side of the measuring square")
        ->check(CLI::Range(1, 256))
        ->capture_default_str();
    sub->add_option("--gsf", o.gsf,
                    "where to measure the glare spread function (a point source's stray light): "
                    "at the positions on the axis, at all, or none")
        ->check(CLI::IsMember({"axis", "all", "none"}))
        ->capture_default_str();
    sub->add_option("--gsf-radius-mm", o.gsfRadiusMm,
                    "radius of the GSF's disc about the point's image (default: the image height "
                    "of the lens's largest field)")
        ->check(CLI::Range(1e-3, 1e4));
    sub->add_option("--gsf-pixels", o.gsfPixels, "pixels per side of the GSF's detector")
        ->check(CLI::Range(16, 2048))
        ->capture_default_str();
    addOutputFolder(sub, o.output, "glare");
    addRunControls(sub, o.threads, o.seed);
    addReportFlags(sub, o.json, o.quiet);
}

int runGlareCommand(const CommonOptions& common, const GlareOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    const std::filesystem::path dir = outputFolder(o.output, "glare", o.json);
    const SceneSpec file = readScene(common, o.file, catalog);
    reportImportWarnings(file);
    GlareSpec spec;
    for (const auto& [x, y] : parseFields(o.fields)) spec.fieldsDeg.push_back(Vec2(x, y));
    spec.spotDiameterDeg = o.spotDeg;
    spec.fieldHalfAngleDeg = o.fieldDeg;
    spec.fNumbers = o.fNumbers;
    spec.passes = o.passes;
    spec.pixels = o.pixels;
    spec.spread = o.gsf == "all"    ? GlareSpreadAt::All
                  : o.gsf == "none" ? GlareSpreadAt::None
                                    : GlareSpreadAt::Axis;
    spec.spreadRadiusMm = o.gsfRadiusMm;
    spec.spreadPixels = o.gsfPixels;
    spec.render.photonsPerPass = o.photons;
    spec.render.raysPerPixel = o.raysPerPixel;
    spec.render.seed = o.seed;
    const auto limit = limitThreads(o.threads);
    if (spec.spread != GlareSpreadAt::None)
        std::cerr << "veil: note: each measurement takes --passes " << spec.passes
                  << "; the glare spread function adds, per field it is measured at, a point "
                     "source of "
                  << 2 * spec.passes << " passes and a check of 2 x " << spec.passes
                  << " (--gsf none leaves it out)\n";
    ProgressReporter reporter;
    if (!o.quiet) spec.progress = reporter.sink();
    const GlareResult result = runGlare(file, catalog, spec);
    reporter.finish();

    WrittenFiles written;
    if (!dir.empty()) {
        written.beginRun(dir);
        for (const std::filesystem::path& f : writeGlareFiles(result, dir)) written.add(f);
        written.finishRun();
    }
    printReport(result.json(), result.markdown(), written, o.json, o.quiet);
    return 0;
}

}  // namespace veil::cli
