// veil sweep SCENE --vary KEY=VALUES ... -n RAYS -o DIR: what-if studies
// (analysis/studies/sweep.h).
//
//   veil sweep examples/scenes/longfocus_360mm_sun.toml -n 20000 -o out/finish
//       --vary properties.black_anodized.scatter.reflectance=0.01:0.09:0.02
//
// Every variant is the scene with the varied values, traced forward with the same seeds
// (common random numbers) in batches; DIR gets sweep.csv, sweep.md, sweep.json and the plot
// sweep.png / sweep.svg, and DIR/variants/<k>.json per variant, which a rerun with the same
// options reads instead of tracing again. A line per variant goes to standard error; the
// table to standard output (or the JSON with --json).

#include <algorithm>
#include <chrono>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analysis/reports/format.h"
#include "analysis/studies/sweep.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/glass_catalog.h"

namespace veil::cli {

void addSweepCommand(CLI::App& app, SweepOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "sweep", "what-if study: vary scene values, trace every variant with the same rays");
    sub->add_option("scene", o.file, "scene file (.toml)")->required();
    sub->add_option("--vary", o.vary,
                    "KEY=VALUES: a TOML key path of the scene (properties.black.reflectance, "
                    "mechanics.baffles[1].z_mm, source.sun.field_deg[2]) and its values: a list "
                    "0.01,0.05, a range 10:60:5 or a geometric range 0.001:1:x10; repeatable "
                    "(the grid of all, or --zip)")
        ->required();
    sub->add_flag("--zip", o.zip,
                  "pair the values of every --vary (equal counts) instead of taking their grid");
    sub->add_option("--measure", o.measure,
                    "how each variant is measured: trace (forward Monte Carlo, -n rays), render "
                    "(the bidirectional renderer, --batches passes: dark mounts' scatter) or "
                    "ghosts (the sequential two-reflection ghost estimate)")
        ->check(CLI::IsMember({"trace", "render", "ghosts"}))
        ->capture_default_str();
    addRays(sub, o.rays, "emitted rays per source per variant (--measure trace)");
    sub->add_option("--batches", o.batches,
                    "batches per variant (seeds seed..seed+batches-1, the same in every "
                    "variant; render: its passes): the errors and the errors of the changes "
                    "come from their spread")
        ->check(CLI::Range(2, 10000))
        ->capture_default_str();
    addCount(sub, "--photons", o.photons, "--measure render: photons per source per pass")
        ->capture_default_str();
    addCount(sub, "--rays-per-pixel", o.raysPerPixel,
             "--measure render: backward rays per pixel per pass")
        ->capture_default_str();
    sub->add_option("--detector", o.detector,
                    "--measure render or ghosts: the detector (default: the first)");
    addOutputFolder(sub, o.output, "sweep");
    addFields(sub, o.fields);
    addRunControls(sub, o.threads, o.seed);
    addTransportFlags(sub, o.transport);
    sub->add_option("--where", o.where,
                    "path criterion (docs/criteria.md); repeatable: each variant's detector flux "
                    "split by criterion, one line per criterion in the plot");
    sub->add_flag("--prune", o.prune,
                  "with --where: stop tracing a branch as soon as no criterion can match it");
    addReportFlags(sub, o.json, o.quiet);
}

int runSweepCommand(const CommonOptions& common, const SweepOptions& o) {
    SweepSpec spec;
    spec.scene = o.file;
    spec.baseEdits = sceneEdits(common);
    for (const std::string& v : o.vary) spec.axes.push_back(parseSweepAxis(v));
    spec.zip = o.zip;
    if (!o.fields.empty()) spec.fieldsDeg = parseFields(o.fields);
    spec.measure = o.measure == "render"   ? SweepMeasure::Render
                   : o.measure == "ghosts" ? SweepMeasure::Ghosts
                                           : SweepMeasure::Trace;
    if (spec.measure == SweepMeasure::Trace && o.rays == 0)
        throw ParseError({"-n", 0, 0}, "--measure trace needs the rays per variant: give -n N");
    spec.raysPerSource = o.rays;
    spec.batches = o.batches;
    spec.render.photonsPerPass = o.photons;
    spec.render.ghostPhotonsPerPass =
        std::min<uint64_t>(spec.render.ghostPhotonsPerPass, o.photons);
    spec.render.raysPerPixel = o.raysPerPixel;
    spec.detector = o.detector;
    applyTransportFlags(o.transport, spec.transport);
    spec.transport.seed = o.seed;
    spec.where = o.where;
    spec.prune = o.prune;
    if (o.prune && o.where.empty())
        throw ParseError({"--prune", 0, 0}, "--prune needs at least one --where");
    // The variants are counted (and a --zip mismatch found) before the catalog is loaded.
    const size_t count = sweepVariants(spec).size();
    const GlassCatalog catalog = loadCatalog(common);
    reportImportWarnings(readScene(common, o.file, catalog));
    spec.folder = outputFolder(o.output, "sweep", false);
    // Under mpirun the variants split over the ranks; rank 0 writes (docs/scaling.md).
    spec.ranks = Ranks::world();

    const auto limit = limitThreads(o.threads);
    const auto started = std::chrono::steady_clock::now();
    auto since = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
    };
    ProgressReporter reporter;
    if (!o.quiet) spec.progress = reporter.sink();
    // A sweep continues the variants an earlier run finished: its files stay.
    WrittenFiles written;
    if (spec.ranks.root()) written.beginRun(spec.folder, true);
    const SweepResult result = runSweep(spec, catalog);
    if (!spec.ranks.root()) return 0;  // its variants went to rank 0
    reporter.finish();

    const std::vector<std::filesystem::path> files = writeSweep(result, spec.folder);
    for (const auto& f : files) written.add(f);
    written.finishRun();
    int failed = 0, resumed = 0, reused = 0;
    for (const SweepVariant& v : result.variants) {
        failed += !v.error.empty();
        resumed += v.resumed;
        reused += v.geometryReused;
    }
    std::ostringstream text;
    text << result.markdown() << "\n"
         << count << " variants in " << elapsed(since()) << ": " << count - failed << " measured ("
         << resumed << " read from an earlier run, " << reused
         << " on the first variant's geometry), " << failed << " could not be run";
    printReport(result.json(), text.str(), written, o.json, o.quiet);
    // A sweep none of whose variants could be run did nothing that was asked.
    if (failed == static_cast<int>(count) && count > 0) {
        std::cerr << "veil: error: no variant could be run; the first one's error: "
                  << result.variants.front().error << "\n";
        return 1;
    }
    return 0;
}

}  // namespace veil::cli
