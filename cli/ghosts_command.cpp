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
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <sstream>

#include "analysis/criteria/criterion_names.h"
#include "analysis/ghosts/ghost_report.h"
#include "analysis/ghosts/ghosts.h"
#include "analysis/pictures/layout.h"
#include "analysis/pictures/path_picture.h"
#include "analysis/reports/image_output.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/output_file.h"
#include "tracer/scene/prepared_scene.h"

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
}

int runGhosts(const CommonOptions& common, const GhostsOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    SceneFile file = readScene(common, o.file, catalog);
    double imageShiftMm = 0.0;
    const bool defaultScene = addDefaultGhostScene(file, catalog, &imageShiftMm);
    if (!o.fields.empty()) {
        setFieldSources(file, catalog, parseFields(o.fields));
    }
    if (o.pixels > 0) {
        if (file.detectors.empty()) file.detectors.emplace_back();
        for (DetectorSpec& d : file.detectors) {
            const double w = d.sizeMm ? d.sizeMm->x : 1.0, h = d.sizeMm ? d.sizeMm->y : 1.0;
            // Square pixels, o.pixels along the longer side.
            d.pixelsX =
                w >= h ? o.pixels : std::max(1, static_cast<int>(std::lround(o.pixels * w / h)));
            d.pixelsY =
                h >= w ? o.pixels : std::max(1, static_cast<int>(std::lround(o.pixels * h / w)));
        }
    }
    const std::unique_ptr<PreparedScene> prepared = PreparedScene::build(std::move(file), catalog);
    const SceneSetup& setup = prepared->setup();
    TraceSetup& ts = prepared->trace();
    reportSceneNotes(*prepared);

    const auto limit = limitThreads(o.threads);
    GhostOptions go;
    go.order = o.order;
    go.gridRays = o.grid;
    go.minFourthOrderReflectance = o.minFourthOrder;
    go.nearFocusMm = o.nearFocusMm;
    go.detector = o.detector;

    // Coating what-if: the baseline ranking first, then the overrides.
    std::map<std::string, std::pair<int, double>> baseline;  // label -> rank, relative flux
    std::vector<std::string> changes;
    if (!o.coatings.empty()) {
        const GhostAnalysis before = GhostTracer(setup, ts, catalog, go).analyse();
        for (size_t r = 0; r < before.ghosts.size(); ++r)
            baseline[before.ghosts[r].path.label] = {static_cast<int>(r) + 1,
                                                     before.ghosts[r].relativeFlux()};
        changes = applyCoatingOverrides(ts, setup.scene, prepared->file().properties, o.coatings);
    }
    const GhostTracer tracer(setup, ts, catalog, go);
    const GhostAnalysis a = tracer.analyse();
    const int det = tracer.detectorIndex();
    const std::string unit = ts.transport.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";

    GhostMonteCarlo mc;
    if (o.rays >= 1) {
        GhostMonteCarloOptions mo;
        mo.raysPerSource = o.rays;
        mo.transport.seed = o.seed;
        const uint64_t total = mo.raysPerSource * ts.transport.sources.size();
        std::optional<ProgressReporter> reporter;
        if (!o.quiet) {
            reporter.emplace("Monte Carlo", total);
            mo.progress = [&reporter](uint64_t done) { reporter->update(done); };
        }
        mc = runGhostMonteCarlo(setup, ts, a, mo);
        if (reporter) reporter->finish();
    }
    const bool haveMc = mc.images != nullptr;

    // The table: one set of rows, every format written from it (analysis/ghosts/ghost_report.h).
    GhostReportSpec rs;
    rs.scene = o.file;
    rs.defaultScene = defaultScene;
    rs.imageShiftMm = imageShiftMm;
    rs.order = o.order;
    rs.gridRays = o.grid;
    rs.coatingOverrides = o.coatings;
    rs.coatingChanges = changes;
    rs.baseline = baseline;
    rs.mcRaysPerSource = haveMc ? o.rays : 0;
    rs.seed = o.seed;
    const GhostReport report = makeGhostReport(rs, setup, ts, a, haveMc ? &mc : nullptr, det);
    const nlohmann::json j = report.json();

    const fs::path out = outputFolder(o.output, "ghosts", o.json);
    WrittenFiles written;
    written.beginRun(out);
    if (!out.empty()) {
        fs::create_directories(out);
        writeTextFile(out / "ghosts.json", j.dump(2) + "\n");
        writeTextFile(out / "ghosts.csv", report.csv());
        writeTextFile(out / "ghosts.md", report.markdown());
        for (const char* f : {"ghosts.json", "ghosts.csv", "ghosts.md"}) written.add(out / f);
    }

    // Images (Monte Carlo) and path pictures.
    if (!out.empty() && haveMc && !o.noImages) {
        fs::create_directories(out / "images");
        const auto& layers = mc.images->images();
        ExrInfo info{unit, mc.emittedRays};
        PreviewOptions po;
        po.fluxUnit = unit;
        po.emittedRays = mc.emittedRays;
        po.decades = o.decades;
        const DetectorImage& sum = layers[a.ghosts.size() + 1][det];
        // Every image sums the sources (fields): said in its title when there are several.
        const size_t nSources = ts.transport.sources.size();
        const std::string allSources =
            nSources > 1 ? " (sum of " + std::to_string(nSources) + " sources)" : "";
        for (size_t r = 0; r < a.ghosts.size(); ++r) {
            const DetectorImage& img = layers[r + 1][det];
            std::ostringstream stem;
            stem << "ghost_" << std::setw(2) << std::setfill('0') << r + 1;
            writeDetectorExr(out / "images" / (stem.str() + ".exr"), img, info);
            po.title = "#" + std::to_string(r + 1) + " " + a.ghosts[r].path.label + allSources;
            writeDetectorPng(out / "images" / (stem.str() + ".png"), img, po);
            written.add(out / "images" / (stem.str() + ".exr"));
            written.add(out / "images" / (stem.str() + ".png"));
        }
        writeDetectorExr(out / "ghosts_all.exr", sum, info);
        po.title = "all " + std::to_string(a.ghosts.size()) + " ghosts" + allSources;
        writeDetectorPng(out / "ghosts_all.png", sum, po);
        po.title = "nominal image" + allSources;
        writeDetectorPng(out / "nominal.png", layers[0][det], po);
        for (const char* f : {"ghosts_all.exr", "ghosts_all.png", "nominal.png"})
            written.add(out / f);
    }
    if (!out.empty() && !o.noImages && o.top > 0) {
        fs::create_directories(out / "paths");
        veil::LayoutOptions lo;
        lo.title = setup.prescription.system.name.empty() ? o.file : setup.prescription.system.name;
        lo.sources = layoutSources(ts.transport.sources, setup.scene);
        lo.axisVerticesMm = layoutAxis(*setup.model);
        const Picture base = drawLayout(setup.scene, lo);
        const PathPictureOptions pp;  // clipped to the layout's frame
        const NameTable names = criterionNames(setup.scene, ts.transport);
        auto draw = [&](const std::string& criterion, const fs::path& stem) {
            const CompiledCriterion c = compileCriterion(criterion, names);
            const std::vector<CompiledCriterion> one{c};
            const CriteriaFilter filter(one);
            PathSelectionOptions so;
            so.where = criterion;
            so.count = static_cast<size_t>(o.paths);
            so.maxRays = 200000;
            so.batchRays = 2000;
            so.transport.seed = o.seed;
            so.transport.minRelativeFlux = 1e-9;
            so.transport.filter = &filter;
            const PathSelection sel = selectPaths(ts.transport, ts.images, so);
            const Picture pic = drawPaths(base, sel, pp);
            writePicture(pic, stem, 2000, written);
        };
        const size_t k = std::min<size_t>(static_cast<size_t>(o.top), a.ghosts.size());
        for (size_t r = 0; r < k; ++r) {
            std::ostringstream stem;
            stem << "ghost_" << std::setw(2) << std::setfill('0') << r + 1;
            draw(a.ghosts[r].path.criterion, out / "paths" / stem.str());
        }
        draw(a.allGhostsCriterion, out / "paths" / "all_ghosts");
    }
    written.finishRun();

    if (o.json) {
        nlohmann::json jj = j;
        jj["files"] = written.json();
        std::cout << jj.dump(2) << "\n";
        return 0;
    }
    std::ostringstream footer;
    if (!o.quiet && !written.files().empty()) {
        footer << "\n";
        written.print(footer);
    }
    std::cout << report.terminal(o.top > 0 ? static_cast<size_t>(o.top) : 0, footer.str());
    return 0;
}

}  // namespace veil::cli
