// veil trace SCENE -n RAYS -o DIR: forward nonsequential Monte Carlo through the scene.
//
//   veil trace examples/scenes/longfocus_360mm_sun.toml -n 1000000 -o out/
//   veil trace scene.toml -n 1e6 --threads 2 --seed 7 --mode random --roulette 1e-4 -o out/
//
// Writes, for every detector, DIR/<name>.exr (float channels value, irradiance, variance,
// count; the first three scaled by header attributes, analysis/reports/image_output.h) and
// DIR/<name>.png (false-colour log preview with a colour bar), and DIR/summary.json (the flux
// budget and every detector's total flux with its relative error). Progress goes to standard
// error (cli/progress.h: a bar with rays/s and the time left on a terminal, a few plain lines
// in a log; none with --quiet); the closing summary goes to standard output. The same seed
// gives bitwise the same images with any number of threads.

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "analysis/criteria/criterion_images.h"
#include "analysis/criteria/criterion_names.h"
#include "analysis/ghosts/ghosts.h"
#include "analysis/reports/image_output.h"
#include "analysis/runs/ray_statistics.h"
#include "analysis/runs/stray_light_run.h"
#include "cli/commands.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/output_file.h"
#include "tracer/scene/prepared_scene.h"

namespace veil::cli {

void addTraceCommand(CLI::App& app, TraceOptions& o) {
    CLI::App* sub = app.add_subcommand("trace", "forward nonsequential Monte Carlo ray trace");
    sub->add_option("scene", o.file, "scene or lens file (.toml or .zmx)")->required();
    addRays(sub, o.rays, "emitted rays per source")->required();
    addOutputFolder(sub, o.output, "trace");
    addFields(sub, o.fields);
    addRunControls(sub, o.threads, o.seed);
    addTransportFlags(sub, o.transport);
    addReportFlags(sub, o.json, o.quiet);
    sub->add_option("--where", o.where,
                    "path criterion (docs/criteria.md); repeatable: one image per criterion plus "
                    "the rest, and the detector flux split by criterion");
    sub->add_flag("--prune", o.prune,
                  "with --where: stop tracing a branch as soon as no criterion can match it "
                  "(faster; then only the criterion images are complete)");
    sub->add_option("--save-rays", o.saveRays,
                    "write every ray's path history to this ray database file "
                    "(docs/ray-database.md); its size is estimated before tracing");
    sub->add_flag("--events-only", o.eventsOnly,
                  "with --save-rays: store events and fluxes without positions and directions "
                  "(about a quarter of the size; enough for criteria and fluxes, not for path "
                  "pictures)");
}

void addRaysCommand(CLI::App& app, RaysOptions& o) {
    CLI::App* sub = app.add_subcommand("rays", "summarise a ray database without tracing again");
    sub->add_option("file", o.file, "ray database written by veil trace --save-rays")->required();
    sub->add_option("--where", o.where,
                    "path criterion (docs/criteria.md) re-evaluated on the saved histories, "
                    "repeatable: the detector flux split by criterion, as trace --where");
    addReportFlags(sub, o.json, o.quiet);
}

int runRays(const CommonOptions&, const RaysOptions& o) {
    RayDatabaseReader reader(o.file);
    const RayDatabaseInfo& info = reader.info();
    // Criteria are compiled (and their errors raised) before any record is read.
    std::vector<CriterionFlux> split;
    if (!o.where.empty()) split = criterionFluxes(reader, o.where);
    const RayStatistics s = rayStatistics(reader);
    if (o.json) {
        nlohmann::json j;
        j["scene"] = info.sceneName;
        j["seed"] = info.seed;
        j["unit"] = info.fluxUnit;
        j["rays"] = s.rays;
        j["paths"] = s.paths;
        j["events"] = s.events;
        j["geometry"] = info.encoding.positions;
        for (int t = 0; t < kEventTypeCount; ++t)
            j["events_by_type"][std::string(toString(static_cast<EventType>(t)))] =
                s.eventsByType[t];
        for (const auto& [name, flux] : s.detectedFlux) j["detected_flux"][name] = flux;
        if (!split.empty()) {
            j["by_criterion"] = nlohmann::json::array();
            for (size_t k = 0; k < split.size(); ++k) {
                nlohmann::json c{{"layer", k + 1 < split.size() ? "where" + std::to_string(k + 1)
                                                                : std::string("rest")},
                                 {"criterion", split[k].criterion},
                                 {"paths", split[k].paths},
                                 {"detected_flux", nlohmann::json::object()},
                                 {"relative_error", nlohmann::json::object()}};
                for (const auto& [name, flux] : split[k].detectedFlux) {
                    c["detected_flux"][name] = flux;
                    c["relative_error"][name] = split[k].relativeError.at(name);
                }
                j["by_criterion"].push_back(c);
            }
        }
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    std::cout << o.file << ": scene " << info.sceneName << ", seed " << info.seed << "\n  "
              << s.rays << " rays, " << s.paths << " paths, " << s.events << " events"
              << (info.encoding.positions ? "" : " (events only, no geometry)") << "\n";
    for (int t = 0; t < kEventTypeCount; ++t)
        if (s.eventsByType[t])
            std::cout << "  " << std::left << std::setw(18) << toString(static_cast<EventType>(t))
                      << std::right << std::setw(12) << s.eventsByType[t] << "\n";
    for (const auto& [name, flux] : s.detectedFlux)
        std::cout << "  detected on " << name << ": " << std::scientific << std::setprecision(6)
                  << flux << " " << info.fluxUnit << "\n";
    for (size_t k = 0; k < split.size(); ++k) {
        const bool rest = k + 1 == split.size();
        std::cout << "  " << std::left << std::setw(8)
                  << (rest ? std::string("rest") : "where" + std::to_string(k + 1)) << std::right
                  << split[k].paths << " paths  "
                  << (rest ? std::string("none of the above") : split[k].criterion) << "\n";
        for (const auto& [name, flux] : split[k].detectedFlux)
            std::cout << "      on " << name << ": "
                      << formatFlux(flux, split[k].relativeError.at(name), info.fluxUnit) << "\n";
    }
    return 0;
}

namespace {

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

}  // namespace

namespace {

// The size of the ray database a run will write, from the first rays of the same run (ray i
// is the same ray in any run with the same seed), said before tracing; a run whose database
// would not fit on its disk stops here.
void checkRayDatabaseSize(const TransportScene& ts, const std::vector<DetectorImage>& images,
                          const TransportOptions& options, uint64_t raysPerSource,
                          const PathEncoding& encoding, const std::string& path, bool quiet) {
    const uint64_t sample = std::min<uint64_t>(raysPerSource, 200);
    TransportOptions o = options;
    o.recordHistories = true;
    std::mutex m;
    uint64_t bytes = 0, events = 0;
    traceNonsequential(ts, images, sample, o, {}, [&](uint64_t, const PathHistory& h) {
        std::vector<uint8_t> buffer;
        encodeHistory(h, encoding, buffer);
        std::lock_guard lock(m);
        bytes += buffer.size();
        events += h.size();
    });
    const double perRay = static_cast<double>(bytes) / static_cast<double>(sample * ts.sources.size());
    const double total = perRay * static_cast<double>(raysPerSource * ts.sources.size());
    auto size = [](double b) {
        std::ostringstream os;
        os << std::setprecision(3);
        if (b >= 1e9) os << b / 1e9 << " GB";
        else if (b >= 1e6) os << b / 1e6 << " MB";
        else os << b / 1e3 << " kB";
        return os.str();
    };
    std::filesystem::path folder = std::filesystem::path(path).parent_path();
    if (folder.empty()) folder = ".";
    while (!std::filesystem::exists(folder) && folder.has_parent_path() && folder != folder.parent_path())
        folder = folder.parent_path();
    std::error_code ec;
    const std::filesystem::space_info space = std::filesystem::space(folder, ec);
    if (!ec && total > 0.95 * static_cast<double>(space.available))
        throw ParseError({"--save-rays " + path, 0, 0},
                         "the ray database would take about " + size(total) + " (" +
                             size(perRay) + " per ray, " +
                             std::to_string(events / std::max<uint64_t>(1, sample * ts.sources.size())) +
                             " events per ray) and " + folder.string() + " has " +
                             size(static_cast<double>(space.available)) +
                             " free: trace fewer rays, add --events-only, or save elsewhere");
    if (!quiet)
        std::cerr << "veil: --save-rays: about " << size(total) << " for "
                  << raysPerSource * ts.sources.size() << " rays (" << size(perRay)
                  << " per ray, from the first " << sample * ts.sources.size() << " rays"
                  << (encoding.positions ? "; --events-only stores about a quarter" : ", events only")
                  << ") to " << path << "\n";
}

}  // namespace

std::unique_ptr<PreparedScene> prepareTracedScene(const CommonOptions& common,
                                                  const std::string& path,
                                                  const std::vector<std::string>& fields,
                                                  const GlassCatalog& catalog,
                                                  const SceneOptions& options) {
    SceneFile file = readScene(common, path, catalog);
    if (!fields.empty()) {
        setFieldSources(file, catalog, parseFields(fields));
    } else if (file.sources.empty()) {
        const auto used = addSystemFieldSources(file, catalog);
        const bool angle = file.prescription.system.fieldKind == SystemData::FieldKind::AngleDeg;
        std::cerr << "veil: note: " << path << " has no [[source]]: tracing one "
                  << (angle ? "collimated beam" : "point source") << " per system field (";
        for (size_t k = 0; k < used.size(); ++k)
            std::cerr << (k ? "; " : "") << used[k].first << "," << used[k].second;
        std::cerr << (angle ? " deg" : " mm")
                  << "; 1 W through the first surface); add [[source]] (docs/format.md) or --field "
                     "X,Y to choose\n";
    }
    return PreparedScene::build(std::move(file), catalog, options);
}

int runTrace(const CommonOptions& common, const TraceOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    const std::unique_ptr<const PreparedScene> prepared =
        prepareTracedScene(common, o.file, o.fields, catalog);
    const SceneSetup& setup = prepared->setup();
    const TraceSetup& ts = prepared->trace();
    reportSceneNotes(*prepared);
    if (o.prune && o.where.empty())
        throw ParseError({"--prune", 0, 0}, "--prune needs at least one --where");

    StrayLightSpec spec;
    spec.raysPerSource = o.rays;
    TransportOptions& options = spec.transport;
    applyTransportFlags(o.transport, options);
    options.seed = o.seed;
    // Under mpirun the rays split over the ranks; rank 0 writes everything (docs/scaling.md).
    options.ranks = Ranks::world();
    if (!options.ranks.single() && !o.saveRays.empty())
        throw ParseError({"--save-rays " + o.saveRays, 0, 0},
                         "the ray database is written by one process: run veil trace "
                         "--save-rays without mpirun");
    spec.where = o.where;
    spec.prune = o.prune;
    const uint64_t total = spec.raysPerSource * ts.transport.sources.size();
    const std::filesystem::path dir = outputFolder(o.output, "trace", o.json);
    WrittenFiles written;

    if (o.eventsOnly && o.saveRays.empty())
        throw ParseError({"--events-only", 0, 0}, "--events-only needs --save-rays FILE");
    PathEncoding encoding{.positions = true, .directions = true, .doublePrecision = false};
    if (o.eventsOnly) encoding = PathEncoding{};
    if (!o.saveRays.empty()) {
        // A file veil may create, before the sample traced to size it.
        if (std::filesystem::is_directory(o.saveRays))
            throw ParseError({"--save-rays " + o.saveRays, 0, 0},
                             "is a folder: give the ray database's file name");
        const std::filesystem::path parent = std::filesystem::path(o.saveRays).parent_path();
        requireWritableFolder(parent.empty() ? "." : parent, "--save-rays", o.saveRays);
    }
    if (!o.saveRays.empty())
        checkRayDatabaseSize(ts.transport, ts.images, options, spec.raysPerSource, encoding,
                             o.saveRays, o.quiet);

    // Once the run's spec has been checked (criteria included), just before the first ray,
    // the folder's older run gives way (WrittenFiles::beginRun) and the ray database opens.
    std::unique_ptr<RayDatabaseWriter> db;
    spec.openConsumer = [&]() -> RayCallback {
        if (!options.ranks.root()) return {};
        written.beginRun(dir);
        if (o.saveRays.empty()) return {};
        {
            RayDatabaseInfo info = describeScene(setup.scene, o.file);
            info.encoding = encoding;
            // A detector's own name names its object in criteria on the saved rays too.
            for (size_t d = 0; d < setup.detectors.size(); ++d) {
                RayDatabaseObject& obj = info.objects[setup.detectors[d].object];
                if (setup.detectors[d].name != obj.name)
                    obj.aliases.push_back(setup.detectors[d].name);
            }
            info.seed = o.seed;
            info.fluxUnit = ts.transport.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
            for (const Source& src : ts.transport.sources) info.sources.push_back(src.name());
            const std::filesystem::path parent = std::filesystem::path(o.saveRays).parent_path();
            if (!parent.empty()) std::filesystem::create_directories(parent);
            db = std::make_unique<RayDatabaseWriter>(o.saveRays, info);
            return [&db](uint64_t i, const PathHistory& h) { db->add(i, h); };
        }
    };
    const auto limit = limitThreads(o.threads);
    std::optional<ProgressReporter> reporter;
    if (!o.quiet && options.ranks.root()) reporter.emplace("trace", total);
    if (reporter) spec.progress = [&reporter](uint64_t done) { reporter->update(done); };
    const StrayLightResult result = runStrayLight(*prepared, spec);
    if (!options.ranks.root()) return 0;  // its share went to rank 0
    if (db) {
        db->setEmittedRays(total);
        db->close();
        written.add(o.saveRays);
    }
    if (reporter) reporter->finish();
    if (o.prune && result.budget.prunedBranches == 0)
        std::cerr << "veil: warning: --prune stopped no branch: no --where criterion turned false "
                     "before its path ended (seq(...), hit(...) and counts without an upper "
                     "bound can only fail when a path ends; not, {0,1}-style counts and "
                     "detector(...) can end a branch early), so the run cost the same\n";

    const std::string& unit = result.fluxUnit;
    const double seconds = result.seconds;
    nlohmann::json summary;
    const FluxBudget& b = result.budget;
    summary["scene"] = o.file;
    summary["rays_per_source"] = spec.raysPerSource;
    summary["seed"] = o.seed;
    summary["seconds"] = seconds;
    summary["unit"] = unit;
    summary["budget"] = {{"emitted", b.emitted},
                         {"detected", b.detected},
                         {"absorbed_surface", b.absorbedSurface},
                         {"absorbed_volume", b.absorbedVolume},
                         {"escaped", b.escaped},
                         {"culled", b.culled},
                         {"dropped", b.dropped},
                         {"dropped_branches",
                          {{"no_refracted_direction", b.droppedBranches[0]},
                           {"no_scatter_direction", b.droppedBranches[1]}}},
                         {"roulette_gain", b.rouletteGain},
                         {"imbalance", b.imbalance()},
                         {"segments", b.segments},
                         {"branches", b.branches},
                         {"pruned_branches", b.prunedBranches}};
    std::ostringstream text;
    text << "Flux budget (" << unit << ")\n";
    auto line = [&](const char* what, double v) {
        text << "  " << std::left << std::setw(18) << what << std::right << std::setw(16)
             << std::scientific << std::setprecision(6) << v << "  " << std::fixed
             << std::setprecision(3) << std::setw(8)
             << (b.emitted > 0 ? 100.0 * v / b.emitted : 0.0) << " %\n";
    };
    line("emitted", b.emitted);
    line("detected", b.detected);
    line("absorbed", b.absorbed());
    line("escaped", b.escaped);
    line("culled", b.culled);
    if (b.dropped > 0 || b.droppedBranches[0] + b.droppedBranches[1] > 0) {
        line("dropped", b.dropped);
        text << "    (" << b.droppedBranches[0] << " " << DropReason::NoRefractedDirection << ", "
             << b.droppedBranches[1] << " " << DropReason::NoScatterDirection << ")\n";
    }
    if (b.rouletteGain > 0) line("roulette gain", b.rouletteGain);
    if (o.prune) text << "  pruned " << b.prunedBranches << " branches (--prune)\n";
    text << "  imbalance " << std::scientific << b.imbalance() << " (relative "
         << (b.emitted > 0 ? b.imbalance() / b.emitted : 0.0) << ")\n";
    text << std::fixed << std::setprecision(1) << "  " << total << " rays, " << b.segments
         << " segments in " << seconds << " s (" << std::setprecision(0)
         << total / std::max(seconds, 1e-9) << " rays/s)\n\nDetectors\n";

    // Images: one EXR per detector (the total and its criterion layers), PNG previews.
    if (!dir.empty()) {
        std::filesystem::create_directories(dir);
        for (size_t d = 0; d < result.images.size(); ++d) {
            const DetectorImage& img = result.images[d];
            const std::string name = img.geometry().name;
            ExrInfo info{unit, total};
            std::vector<ImageLayer> layers{{result.layers ? "all" : "", &img}};
            if (result.layers) {
                const size_t n = result.layers->criterionCount();
                for (size_t c = 0; c <= n; ++c)
                    layers.push_back({c < n ? "where" + std::to_string(c + 1) : "rest",
                                      &result.layers->images()[c][d]});
            }
            writeDetectorExr(dir / (name + ".exr"), layers, info);
            written.add(dir / (name + ".exr"));
            PreviewOptions po;
            po.fluxUnit = unit;
            po.emittedRays = total;
            writeDetectorPng(dir / (name + ".png"), img, po);
            written.add(dir / (name + ".png"));
            if (result.layers) {
                const size_t n = result.layers->criterionCount();
                for (size_t c = 0; c <= n; ++c) {
                    const std::string tag = c < n ? "where" + std::to_string(c + 1) : "rest";
                    PreviewOptions lp = po;
                    lp.title =
                        name + ": " + (c < n ? result.layers->text(c) : "none of the above");
                    const std::filesystem::path png = dir / (name + "." + tag + ".png");
                    writeDetectorPng(png, result.layers->images()[c][d], lp);
                    written.add(png);
                }
            }
        }
    }

    // The report: the same rows on the terminal and in summary.json.
    summary["detectors"] = nlohmann::json::array();
    // A detector named apart from its object is shown with it: "sensor_image (on sensor)",
    // the object name veil rays and criteria use as well.
    auto objectOf = [&](const std::string& detector) -> std::string {
        for (const DetectorGeometry& g : setup.detectors)
            if (g.name == detector) return setup.scene.object(g.object).name;
        return detector;
    };
    for (const StrayLightRow& row : result.report()) {
        if (row.layer.empty()) {
            const std::string object = objectOf(row.detector);
            text << "  " << row.detector << (object != row.detector ? " (on " + object + ")" : "")
                 << ": " << formatFlux(row.flux, row.relativeError, unit) << "\n";
            nlohmann::json jd{{"name", row.detector},
                              {"object", object},
                              {"flux", row.flux},
                              {"relative_error", num(row.relativeError)}};
            if (result.layers) jd["by_criterion"] = nlohmann::json::array();
            summary["detectors"].push_back(jd);
            continue;
        }
        text << "    " << std::left << std::setw(8) << row.layer << std::right
             << formatFlux(row.flux, row.relativeError, unit) << "  " << row.criterion << "\n";
        summary["detectors"].back()["by_criterion"].push_back(
            {{"layer", row.layer},
             {"criterion", row.criterion},
             {"flux", row.flux},
             {"relative_error", num(row.relativeError)}});
    }
    if (!dir.empty()) {
        writeTextFile(dir / "summary.json", summary.dump(2) + "\n");
        written.add(dir / "summary.json");
    }
    written.finishRun();
    if (o.json) {
        summary["files"] = written.json();
        std::cout << summary.dump(2) << "\n";
        return 0;
    }
    std::cout << text.str();
    if (!o.quiet) {
        std::cout << "\n";
        written.print(std::cout);
    }
    return 0;
}

}  // namespace veil::cli
