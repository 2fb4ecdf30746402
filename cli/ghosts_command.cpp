// veil ghosts SCENE: every two-reflection (or four-reflection) ghost of the lens, estimated
// sequentially, verified by one pruned Monte Carlo run, ranked, imaged and drawn.
//
//   veil ghosts examples/lenses/double_gauss_50mm.toml
//   veil ghosts examples/scenes/longfocus_360mm_sun.toml --top 5 -o out/ghosts
//   veil ghosts lens.zmx --field 0,0 --field 0,10 --coating 'L3.*=uncoated' --json
//
// A bare lens file (no [[source]]) gets the default scene of analysis/ghosts/ghosts.h: a collimated
// 1 W beam per system field filling the first surface, an absorbing stop plate, the detector
// on the image surface. Writes to the output folder (default ./ghosts; with --json only when
// -o is given): ghosts.csv, ghosts.json, ghosts.md (the
// whole ranked table), images/ghost_RR.exr|png per ghost (RR = rank, Monte Carlo), their sum
// ghosts_all.exr|png and nominal.png, and paths/ghost_RR.svg|png for the top K ghosts plus
// paths/all_ghosts.svg|png. The terminal shows the top K rows; --json prints the whole table
// as JSON on standard output instead.

#include "cli/ghosts_command.h"

#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analysis/ghosts/ghost_run.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/glass_catalog.h"

namespace veil::cli {

namespace fs = std::filesystem;

void addGhostsCommand(CLI::App& app, GhostsOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "ghosts", "rank every ghost of the lens: sequential estimate, Monte Carlo, images, paths");
    sub->add_option("scene", o.file, "scene file (.toml) or bare lens file (.toml, .zmx)")
        ->required();
    sub->add_option("--order", o.order, "2: two-reflection ghosts; 4: also four-reflection")
        ->check(CLI::IsMember({2, 4}))
        ->capture_default_str();
    sub->add_option("--top", o.top, "rows shown and ghosts drawn (0: all rows, no drawings)")
        ->check(CLI::Range(0, 100000))
        ->capture_default_str();
    addFields(sub, o.fields);
    sub->add_option("--coating", o.coatings,
                    "what-if GLOB=PROPERTY (e.g. 'L3.*=ideal_ar'), repeatable: re-ranks and "
                    "shows what changed");
    addOutputFolder(sub, o.output, "ghosts");
    sub->add_option("--grid", o.grid, "sequential estimate: grid rays across each beam")
        ->check(CLI::Range(2, 4096))
        ->capture_default_str();
    addRays(sub, o.rays, "Monte Carlo rays per source (0: the sequential estimate only)", 0);
    sub->add_option("--paths", o.paths,
                    "emitted rays per ghost path picture, each drawn with its matching branches")
        ->check(CLI::Range(1, 100000))
        ->capture_default_str();
    addRunControls(sub, o.threads, o.seed);
    addReportFlags(sub, o.json, o.quiet);
    sub->add_option("--detector", o.detector, "detector name (default: the first)");
    sub->add_option("--near-focus", o.nearFocusMm,
                    "footprint diameter (mm) below which a ghost counts as focused on the "
                    "detector (0: 10 pixels)")
        ->capture_default_str();
    sub->add_option("--min-r4", o.minFourthOrder,
                    "--order 4: skip paths whose four normal-incidence reflectances multiply "
                    "to less than this")
        ->capture_default_str();
    sub->add_flag("--no-images", o.noImages, "write the tables only (no EXR, PNG, paths)");
    sub->add_option("--decades", o.decades, "PNG images: decades of the log colour scale")
        ->check(CLI::Range(0.5, 20.0))
        ->capture_default_str();
    sub->add_option("--pixels", o.pixels,
                    "detector pixels along the longer side for the ghost images (fewer pixels: "
                    "less Monte Carlo noise per pixel; 0: the scene's)")
        ->check(CLI::Range(0, 16384))
        ->capture_default_str();
    addMaxMemory(sub, o.maxMemory, "Monte Carlo check");
}

int runGhosts(const CommonOptions& common, const GhostsOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    GhostRunSpec spec;
    spec.scene = o.file;
    spec.options.order = o.order;
    spec.options.gridRays = o.grid;
    spec.options.minFourthOrderReflectance = o.minFourthOrder;
    spec.options.nearFocusMm = o.nearFocusMm;
    spec.options.detector = o.detector;
    spec.fieldsDeg = parseFields(o.fields);
    spec.coatings = o.coatings;
    spec.pixels = o.pixels;
    spec.maxMemoryBytes = static_cast<double>(o.maxMemory);
    spec.monteCarloRays = o.rays;
    spec.seed = o.seed;
    GhostRun run = prepareGhostRun(readScene(common, o.file, catalog), catalog, spec);
    reportSceneNotes(*run.scene);
    ProgressReporter reporter;
    if (!o.quiet) spec.progress = reporter.sink();
    const auto limit = limitThreads(o.threads);
    runGhostAnalysis(run, catalog, spec);
    const fs::path out = outputFolder(o.output, "ghosts", o.json);
    WrittenFiles written;
    written.beginRun(out);
    if (!out.empty()) {
        GhostFilesSpec files{!o.noImages, o.decades, o.top, o.paths, o.seed, {}};
        files.progress = spec.progress;
        for (const fs::path& f : writeGhostFiles(run, out, files)) written.add(f);
    }
    reporter.finish();
    written.finishRun();
    if (o.json) {
        nlohmann::json j = run.report.json();
        j["files"] = written.json();
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    std::ostringstream footer;
    if (!o.quiet && !written.files().empty()) {
        footer << "\n";
        written.print(footer);
    }
    std::cout << run.report.terminal(o.top > 0 ? static_cast<size_t>(o.top) : 0, footer.str());
    return 0;
}

}  // namespace veil::cli
