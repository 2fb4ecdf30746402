#include "analysis/ghosts/ghost_run.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>

#include "analysis/criteria/criterion_images.h"
#include "analysis/criteria/criterion_names.h"
#include "analysis/ghosts/coating_whatif.h"
#include "analysis/lens/default_scene.h"
#include "analysis/pictures/layout.h"
#include "analysis/pictures/path_picture.h"
#include "analysis/reports/image_output.h"
#include "analysis/runs/memory_check.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/output_file.h"
#include "tracer/records/detector.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/transport/interaction.h"

namespace veil {

namespace fs = std::filesystem;

namespace {

// Square pixels, `pixels` along the longer side of every detector.
void setPixels(SceneSpec& file, int pixels) {
    if (file.detectors.empty()) file.detectors.emplace_back();
    for (DetectorSpec& d : file.detectors) {
        const double w = d.sizeMm ? d.sizeMm->x : 1.0, h = d.sizeMm ? d.sizeMm->y : 1.0;
        d.pixelsX = w >= h ? pixels : std::max(1, static_cast<int>(std::lround(pixels * w / h)));
        d.pixelsY = h >= w ? pixels : std::max(1, static_cast<int>(std::lround(pixels * h / w)));
        if (int64_t(d.pixelsX) * d.pixelsY > kMaxDetectorPixels)
            throw ParseError({"--pixels", 0, 0},
                             std::to_string(pixels) + " makes " +
                                 (d.name.empty() ? "the detector " : "detector '" + d.name + "' ") +
                                 std::to_string(d.pixelsX) + " x " + std::to_string(d.pixelsY) +
                                 " pixels, more than " + std::to_string(kMaxDetectorPixels) +
                                 " in all");
    }
}

std::string ghostStem(size_t rank) {
    std::ostringstream stem;
    stem << "ghost_" << std::setw(2) << std::setfill('0') << rank;
    return stem.str();
}

// The Monte Carlo images: one per ghost, all ghosts together and the nominal image.
void writeImages(const GhostRun& run, const fs::path& out, const GhostFilesSpec& spec,
                 std::vector<fs::path>& written) {
    const GhostAnalysis& a = run.analysis;
    const TransportView& view = run.scene->transport().view;
    fs::create_directories(out / "images");
    const auto& layers = run.monteCarlo.images->images();
    const ExrInfo info{run.report.unit, run.monteCarlo.emittedRays};
    PreviewOptions po;
    po.fluxUnit = run.report.unit;
    po.emittedRays = run.monteCarlo.emittedRays;
    po.scale.decades = spec.decades;
    const int det = run.detector;
    // Every image sums the sources (fields): said in its title when there are several.
    const size_t nSources = view.sources.size();
    const std::string allSources =
        nSources > 1 ? " (sum of " + std::to_string(nSources) + " sources)" : "";
    for (size_t r = 0; r < a.ghosts.size(); ++r) {
        const DetectorImage& img = layers[r + 1][det];
        const std::string stem = ghostStem(r + 1);
        writeDetectorExr(out / "images" / (stem + ".exr"), img, info);
        po.title = std::string("#").append(std::to_string(r + 1)) + " " + a.ghosts[r].path.label +
                   allSources;
        writeDetectorPng(out / "images" / (stem + ".png"), img, po);
        written.push_back(out / "images" / (stem + ".exr"));
        written.push_back(out / "images" / (stem + ".png"));
    }
    const DetectorImage& sum = layers[a.ghosts.size() + 1][det];
    writeDetectorExr(out / "ghosts_all.exr", sum, info);
    po.title = "all " + std::to_string(a.ghosts.size()) + " ghosts" + allSources;
    writeDetectorPng(out / "ghosts_all.png", sum, po);
    po.title = "nominal image" + allSources;
    writeDetectorPng(out / "nominal.png", layers[0][det], po);
    for (const char* f : {"ghosts_all.exr", "ghosts_all.png", "nominal.png"})
        written.push_back(out / f);
}

// Path pictures of the top ghosts and of all ghosts together, over the layout.
void writePathPictures(const GhostRun& run, const fs::path& out, const GhostFilesSpec& spec,
                       std::vector<fs::path>& written) {
    const SceneGeometry& setup = run.scene->geometry();
    const SceneTransport& ts = run.scene->transport();
    fs::create_directories(out / "paths");
    LayoutOptions lo;
    lo.title = setup.prescription.system.name.empty() ? run.report.scene
                                                      : setup.prescription.system.name;
    lo.sources = layoutSources(ts.view.sources, setup.scene);
    lo.axisVerticesMm = layoutAxis(*setup.model);
    lo.detectors = layoutDetectors(setup.detectors);
    const Picture base = drawLayout(setup.scene, lo);
    const PathPictureOptions pp;  // clipped to the layout's frame
    const NameTable names = criterionNames(setup.scene, ts.view);
    const GhostAnalysis& a = run.analysis;
    const size_t k = std::min<size_t>(static_cast<size_t>(spec.top), a.ghosts.size());
    // The rays a picture may cost: what its Monte Carlo hit rate says pathRays take (4x), at
    // most kMaxPathRays; a ghost the Monte Carlo never found gets the rays it already spent,
    // which found none (at a rate above 3 / N it would have, 95 % of the time).
    constexpr uint64_t kMaxPathRays = 200000;
    const uint64_t batch = 2000;
    auto budget = [&](size_t row) -> uint64_t {
        const GhostMonteCarlo& mc = run.monteCarlo;
        if (!mc.images || row >= run.report.rows.size()) return kMaxPathRays;
        const GhostReportRow& g = run.report.rows[row];
        const double emitted = static_cast<double>(mc.emittedRays);
        if (!(g.mcFlux > 0.0) || !(g.mcRelativeError > 0.0))
            return std::clamp<uint64_t>(mc.emittedRays, batch, kMaxPathRays);
        const double hits = 1.0 / (g.mcRelativeError * g.mcRelativeError);
        const double rays = 4.0 * spec.pathRays * emitted / hits;
        return static_cast<uint64_t>(
            std::clamp(rays, static_cast<double>(batch), static_cast<double>(kMaxPathRays)));
    };
    auto draw = [&](const std::string& criterion, const fs::path& stem, uint64_t maxRays,
                    const std::string& task) {
        const std::vector<CompiledCriterion> one{compileCriterion(criterion, names)};
        const CriteriaFilter filter(one);
        PathSelectionOptions so;
        so.where = criterion;
        so.count = static_cast<size_t>(spec.pathRays);
        so.maxRays = maxRays;
        so.batchRays = batch;
        so.progress = spec.progress;
        so.task = task;
        so.transport.seed = spec.seed;
        so.transport.minRelativeFlux = 1e-9;
        so.transport.filter = &filter;
        const Picture pic = drawPaths(base, selectPaths(ts.view, ts.images, so), pp);
        const fs::path svg = stem.string() + ".svg", png = stem.string() + ".png";
        pic.writeSvg(svg);
        written.push_back(svg);
        pic.writePng(png, 2000);
        written.push_back(png);
    };
    for (size_t r = 0; r < k; ++r)
        draw(a.ghosts[r].path.criterion, out / "paths" / ghostStem(r + 1), budget(r),
             "path picture " + std::to_string(r + 1) + " of " + std::to_string(k + 1));
    draw(
        a.allGhostsCriterion, out / "paths" / "all_ghosts", kMaxPathRays,
        "path picture " + std::to_string(k + 1) + " of " + std::to_string(k + 1) + " (all ghosts)");
}

}  // namespace

GhostRun prepareGhostRun(SceneSpec file, const GlassCatalog& catalog, const GhostRunSpec& spec) {
    GhostRun run;
    run.defaultScene = addDefaultGhostScene(file, catalog, &run.imageShiftMm);
    if (!spec.fieldsDeg.empty()) setFieldSources(file, catalog, spec.fieldsDeg);
    if (spec.pixels > 0) setPixels(file, spec.pixels);
    run.scene = PreparedScene::build(std::move(file), catalog);
    return run;
}

void runGhostAnalysis(GhostRun& run, const GlassCatalog& catalog, const GhostRunSpec& spec) {
    const SceneGeometry& setup = run.scene->geometry();
    SceneTransport& ts = run.scene->transport();
    // Coating what-if: the baseline ranking first, then the overrides.
    std::map<std::string, std::pair<int, double>> baseline;  // label -> rank, relative flux
    std::vector<std::string> changes;
    if (!spec.coatings.empty()) {
        const GhostAnalysis before = GhostTracer(setup, ts, catalog, spec.options).analyse();
        for (size_t r = 0; r < before.ghosts.size(); ++r)
            baseline[before.ghosts[r].path.label] = {static_cast<int>(r) + 1,
                                                     before.ghosts[r].relativeFlux()};
        changes =
            applyCoatingOverrides(ts, setup.scene, run.scene->spec().properties, spec.coatings);
    }
    const GhostTracer tracer(setup, ts, catalog, spec.options);
    run.analysis = tracer.analyse();
    run.detector = tracer.detectorIndex();
    if (spec.monteCarloRays >= 1) {
        // The check's images (the nominal path, each ghost, all ghosts and the rest, on every
        // detector, beside the traced image) before any of them is taken: a fourth-order
        // analysis can find thousands of ghosts.
        uint64_t pixels = 0;
        for (const DetectorImage& d : ts.images)
            pixels += static_cast<uint64_t>(d.geometry().pixelCount());
        const double layers = static_cast<double>(run.analysis.ghosts.size()) + 3.0;
        const double bytes = residentBytes() + static_cast<double>(pixels) *
                                                   (kImageBytesPerPixel * (layers + 1.0) + 12.0);
        std::ostringstream detail;
        detail << layers << " images of " << pixels
               << " pixels: one per ghost, the nominal path, all ghosts and the rest";
        checkMemory(spec.scene.empty() ? run.scene->spec().path.string() : spec.scene,
                    "Monte Carlo check", bytes, detail.str(),
                    "lower --pixels, or give -n 0 for the sequential estimate alone",
                    spec.maxMemoryBytes);
        GhostMonteCarloOptions mo;
        mo.raysPerSource = spec.monteCarloRays;
        mo.transport.seed = spec.seed;
        if (spec.progress)
            mo.progress = [sink = spec.progress,
                           memory = "memory about " + gigabytes(bytes)](ProgressEvent e) {
                e.state = memory;
                sink(e);
            };
        run.monteCarlo = runGhostMonteCarlo(setup, ts, run.analysis, mo);
    }
    const bool haveMc = run.monteCarlo.images != nullptr;
    // The table: one set of rows, every format written from it (ghost_report.h).
    GhostReportSpec rs;
    rs.scene = spec.scene;
    rs.defaultScene = run.defaultScene;
    rs.imageShiftMm = run.imageShiftMm;
    rs.order = spec.options.order;
    rs.gridRays = spec.options.gridRays;
    rs.coatingOverrides = spec.coatings;
    rs.coatingChanges = changes;
    rs.baseline = baseline;
    rs.mcRaysPerSource = haveMc ? spec.monteCarloRays : 0;
    rs.seed = spec.seed;
    run.report = makeGhostReport(rs, setup, ts, run.analysis, haveMc ? &run.monteCarlo : nullptr,
                                 run.detector);
}

std::vector<fs::path> writeGhostFiles(const GhostRun& run, const fs::path& out,
                                      const GhostFilesSpec& spec) {
    std::vector<fs::path> written;
    fs::create_directories(out);
    writeTextFile(out / "ghosts.json", run.report.json().dump(2) + "\n");
    writeTextFile(out / "ghosts.csv", run.report.csv());
    writeTextFile(out / "ghosts.md", run.report.markdown());
    for (const char* f : {"ghosts.json", "ghosts.csv", "ghosts.md"}) written.push_back(out / f);
    if (!spec.images) return written;
    if (run.monteCarlo.images) writeImages(run, out, spec, written);
    if (spec.top > 0) writePathPictures(run, out, spec, written);
    return written;
}

}  // namespace veil
