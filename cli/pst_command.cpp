// veil pst SCENE --angles 0:85:1 -n RAYS -o DIR: point source transmittance against the
// source's angle off the axis (analysis/studies/pst.h).
//
//   veil pst examples/lenses/double_gauss_50mm.toml --angles 0:80:5 -n 20000 -o out/pst
//
// Writes DIR/pst.csv, pst.md, pst.json and the plot pst.png / pst.svg; the table goes to
// standard output (or the JSON with --json), a line per angle to standard error.

#include <algorithm>
#include <iostream>
#include <nlohmann/json.hpp>

#include "analysis/studies/pst.h"
#include "analysis/studies/sweep.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/glass_catalog.h"

namespace veil::cli {

void addPstCommand(CLI::App& app, PstOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "pst", "point source transmittance against the source's angle off the axis");
    sub->add_option("scene", o.file, "scene or lens file (.toml or .zmx)")->required();
    sub->add_option("--angles", o.angles,
                    "off-axis angles in degrees: a list 0,5,10, a range 0:85:5 or a geometric "
                    "range 1:64:x2")
        ->required();
    sub->add_option("--azimuth", o.azimuthDeg,
                    "the plane of the angles, degrees from +y toward +x (0: the y-z plane)")
        ->check(CLI::Range(-360.0, 360.0))
        ->capture_default_str();
    sub->add_option("--measure", o.measure,
                    "trace (forward Monte Carlo, -n rays per angle) or render (the bidirectional "
                    "renderer, --batches passes per angle: dark mounts' scatter)")
        ->check(CLI::IsMember({"trace", "render"}))
        ->capture_default_str();
    addRays(sub, o.rays, "rays of the collimated beam per angle (--measure trace)");
    sub->add_option("--batches", o.batches,
                    "batches per angle (seeds seed..seed+batches-1; render: its passes): the "
                    "errors come from their spread")
        ->check(CLI::Range(2, 10000))
        ->capture_default_str();
    addCount(sub, "--photons", o.photons, "--measure render: photons per pass")
        ->capture_default_str();
    addCount(sub, "--rays-per-pixel", o.raysPerPixel,
             "--measure render: backward rays per pixel per pass")
        ->capture_default_str();
    addOutputFolder(sub, o.output, "pst");
    addRunControls(sub, o.threads, o.seed);
    addTransportFlags(sub, o.transport);
    sub->add_option("--where", o.where,
                    "path criterion (docs/criteria.md); repeatable: a PST curve per criterion "
                    "beside the total, the nominal image and the stray light");
    addReportFlags(sub, o.json, o.quiet);
}

int runPstCommand(const CommonOptions& common, const PstOptions& o) {
    PstSpec spec;
    spec.scene = o.file;
    spec.edits = sceneEdits(common);
    for (const std::string& v : parseSweepValues(o.angles, "--angles " + o.angles)) {
        try {
            spec.anglesDeg.push_back(std::stod(v));
        } catch (const std::exception&) {
            throw ParseError({"--angles " + o.angles, 0, 0}, "'" + v + "' is not an angle");
        }
    }
    spec.azimuthDeg = o.azimuthDeg;
    spec.render = o.measure == "render";
    if (!spec.render && o.rays == 0)
        throw ParseError({"-n", 0, 0}, "--measure trace needs the rays per angle: give -n N");
    spec.renderOptions.photonsPerPass = o.photons;
    spec.renderOptions.ghostPhotonsPerPass =
        std::min<uint64_t>(spec.renderOptions.ghostPhotonsPerPass, o.photons);
    spec.renderOptions.raysPerPixel = o.raysPerPixel;
    spec.raysPerAngle = o.rays;
    spec.batches = o.batches;
    applyTransportFlags(o.transport, spec.transport);
    spec.transport.seed = o.seed;
    spec.where = o.where;
    const GlassCatalog catalog = loadCatalog(common);
    reportImportWarnings(readScene(common, o.file, catalog));
    const std::filesystem::path dir = outputFolder(o.output, "pst", o.json);
    const auto limit = limitThreads(o.threads);
    ProgressReporter reporter;
    if (!o.quiet) spec.progress = reporter.sink();
    // Under mpirun the angles split over the ranks; rank 0 writes (docs/scaling.md).
    spec.ranks = Ranks::world();
    const PstResult result = runPst(spec, catalog);
    if (!spec.ranks.root()) return 0;  // its rows went to rank 0
    reporter.finish();
    WrittenFiles written;
    if (!o.json || !o.output.empty()) {
        written.beginRun(dir);
        for (const auto& f : writePst(result, dir)) written.add(f);
        written.finishRun();
    }
    printReport(result.json(), result.markdown(), written, o.json, o.quiet);
    return 0;
}

}  // namespace veil::cli
