// veil trace SCENE -n RAYS -o DIR: forward nonsequential Monte Carlo through the scene.
//
//   veil trace examples/scenes/longfocus_360mm_sun.toml -n 1000000 -o out/
//   veil trace scene.toml -n 1e6 --threads 2 --seed 7 --mode random --roulette 1e-4 -o out/
//
// Writes, for every detector, DIR/<name>.exr (float channels value, irradiance, variance,
// count; the first three scaled by header attributes, analysis/image_output.h) and
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
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "analysis/criterion_images.h"
#include "analysis/criterion_names.h"
#include "analysis/image_output.h"
#include "analysis/ray_statistics.h"
#include "analysis/stray_light_run.h"
#include "cli/commands.h"
#include "cli/progress.h"
#include "lensdata/output_file.h"
#include "tracer/prepared_scene.h"

namespace veil::cli {

void addTraceCommand(CLI::App& app, TraceOptions& o) {
    CLI::App* sub = app.add_subcommand("trace", "forward nonsequential Monte Carlo ray trace");
    sub->add_option("scene", o.file, "scene file (.toml) with [[source]]")->required();
    sub->add_option("-n,--rays", o.rays, "rays per source")
        ->required()
        ->check(CLI::Range(1.0, 1e13));
    sub->add_option("-o,--output", o.output, "output folder")->required();
    sub->add_option("--threads", o.threads, "worker threads (0: all cores)")->capture_default_str();
    sub->add_option("--seed", o.seed, "random seed")->capture_default_str();
    sub->add_option("--mode", o.mode, "split (every Fresnel branch) or random (one branch)")
        ->check(CLI::IsMember({"split", "random"}))
        ->capture_default_str();
    sub->add_option("--min-flux", o.minRelativeFlux,
                    "cull a branch below this share of its ray's emitted flux, after every bounce "
                    "(both modes)")
        ->capture_default_str();
    sub->add_option("--max-split-depth", o.maxSplitDepth, "split mode: deepest split followed")
        ->capture_default_str();
    sub->add_option("--roulette", o.roulette,
                    "Russian roulette below this share of the ray's flux (0: off)")
        ->capture_default_str();
    sub->add_option("--max-segments", o.maxSegments, "segments per branch before it is culled")
        ->capture_default_str();
    sub->add_flag("--quiet", o.quiet, "no progress bar");
    sub->add_option("--where", o.where,
                    "path criterion (docs/criteria.md); repeatable: one image per criterion plus "
                    "the rest, and the detector flux split by criterion");
    sub->add_flag("--prune", o.prune,
                  "with --where: stop tracing a branch as soon as no criterion can match it "
                  "(faster; then only the criterion images are complete)");
    sub->add_option(
        "--save-rays", o.saveRays,
        "write every ray's path history to this ray database file (docs/ray-database.md)");
}

void addRaysCommand(CLI::App& app, RaysOptions& o) {
    CLI::App* sub = app.add_subcommand("rays", "summarise a ray database without tracing again");
    sub->add_option("file", o.file, "ray database written by veil trace --save-rays")->required();
    sub->add_flag("--json", o.json, "print JSON on standard output");
}

int runRays(const CommonOptions&, const RaysOptions& o) {
    RayDatabaseReader reader(o.file);
    const RayStatistics s = rayStatistics(reader);
    const RayDatabaseInfo& info = reader.info();
    if (o.json) {
        nlohmann::json j;
        j["scene"] = info.sceneName;
        j["seed"] = info.seed;
        j["unit"] = info.fluxUnit;
        j["rays"] = s.rays;
        j["paths"] = s.paths;
        j["events"] = s.events;
        for (int t = 0; t < kEventTypeCount; ++t)
            j["events_by_type"][std::string(toString(static_cast<EventType>(t)))] =
                s.eventsByType[t];
        for (const auto& [name, flux] : s.detectedFlux) j["detected_flux"][name] = flux;
        std::cout << j.dump(2) << "\n";
        return 0;
    }
    std::cout << o.file << ": scene " << info.sceneName << ", seed " << info.seed << "\n  "
              << s.rays << " rays, " << s.paths << " paths, " << s.events << " events\n";
    for (int t = 0; t < kEventTypeCount; ++t)
        if (s.eventsByType[t])
            std::cout << "  " << std::left << std::setw(18) << toString(static_cast<EventType>(t))
                      << std::right << std::setw(12) << s.eventsByType[t] << "\n";
    for (const auto& [name, flux] : s.detectedFlux)
        std::cout << "  detected on " << name << ": " << std::scientific << std::setprecision(6)
                  << flux << " " << info.fluxUnit << "\n";
    return 0;
}

namespace {

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

}  // namespace

int runTrace(const CommonOptions& common, const TraceOptions& o) {
    const GlassCatalog catalog = loadCatalog(common);
    const std::unique_ptr<const PreparedScene> prepared = PreparedScene::read(o.file, catalog);
    const SceneSetup& setup = prepared->setup();
    const TraceSetup& ts = prepared->trace();
    reportSceneNotes(setup);
    if (o.prune && o.where.empty())
        throw ParseError({o.file, 0, 0}, "--prune needs at least one --where");

    StrayLightSpec spec;
    spec.raysPerSource = static_cast<uint64_t>(o.rays);
    TransportOptions& options = spec.transport;
    options.mode =
        o.mode == "random" ? TransportOptions::Mode::Random : TransportOptions::Mode::Split;
    options.minRelativeFlux = o.minRelativeFlux;
    options.maxSplitDepth = o.maxSplitDepth;
    options.rouletteRelativeFlux = o.roulette;
    options.maxSegments = o.maxSegments;
    options.seed = o.seed;
    spec.where = o.where;
    spec.prune = o.prune;
    const uint64_t total = spec.raysPerSource * ts.transport.sources.size();

    // The ray database opens its file only once the run's spec has been checked.
    std::unique_ptr<RayDatabaseWriter> db;
    if (!o.saveRays.empty()) {
        spec.openConsumer = [&]() -> RayCallback {
            RayDatabaseInfo info = describeScene(setup.scene, o.file);
            info.seed = o.seed;
            info.fluxUnit = ts.transport.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
            for (const Source& src : ts.transport.sources) info.sources.push_back(src.name());
            const std::filesystem::path parent = std::filesystem::path(o.saveRays).parent_path();
            if (!parent.empty()) std::filesystem::create_directories(parent);
            db = std::make_unique<RayDatabaseWriter>(o.saveRays, info);
            return [&db](uint64_t i, const PathHistory& h) { db->add(i, h); };
        };
    }
    const auto limit = limitThreads(o.threads);
    std::optional<ProgressReporter> reporter;
    if (!o.quiet) reporter.emplace("trace", total);
    if (reporter) spec.progress = [&reporter](uint64_t done) { reporter->update(done); };
    const StrayLightResult result = runStrayLight(*prepared, spec);
    if (db) {
        db->setEmittedRays(total);
        db->close();
    }
    if (reporter) reporter->finish();

    std::filesystem::create_directories(o.output);
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
                         {"branches", b.branches}};
    std::cout << "Flux budget (" << unit << ")\n";
    auto line = [&](const char* what, double v) {
        std::cout << "  " << std::left << std::setw(18) << what << std::right << std::setw(16)
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
        std::cout << "    (" << b.droppedBranches[0] << " " << DropReason::NoRefractedDirection
                  << ", " << b.droppedBranches[1] << " " << DropReason::NoScatterDirection << ")\n";
    }
    if (b.rouletteGain > 0) line("roulette gain", b.rouletteGain);
    std::cout << "  imbalance " << std::scientific << b.imbalance() << " (relative "
              << (b.emitted > 0 ? b.imbalance() / b.emitted : 0.0) << ")\n";
    std::cout << std::fixed << std::setprecision(1) << "  " << total << " rays, " << b.segments
              << " segments in " << seconds << " s (" << std::setprecision(0)
              << total / std::max(seconds, 1e-9) << " rays/s)\n\nDetectors\n";

    // Images: one EXR per detector (the total and its criterion layers), PNG previews.
    const std::filesystem::path dir(o.output);
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
        PreviewOptions po;
        po.fluxUnit = unit;
        po.emittedRays = total;
        writeDetectorPng(dir / (name + ".png"), img, po);
        if (result.layers) {
            const size_t n = result.layers->criterionCount();
            for (size_t c = 0; c <= n; ++c) {
                const std::string tag = c < n ? "where" + std::to_string(c + 1) : "rest";
                PreviewOptions lp = po;
                lp.title = name + ": " + (c < n ? result.layers->text(c) : "none of the above");
                writeDetectorPng(dir / (name + "." + tag + ".png"), result.layers->images()[c][d],
                                 lp);
            }
        }
    }

    // The report: the same rows on the terminal and in summary.json.
    summary["detectors"] = nlohmann::json::array();
    for (const StrayLightRow& row : result.report()) {
        if (row.layer.empty()) {
            std::cout << "  " << row.detector << ": " << std::scientific << std::setprecision(6)
                      << row.flux << " " << unit << " +- " << std::fixed << std::setprecision(3)
                      << 100.0 * row.relativeError << " %\n";
            nlohmann::json jd{{"name", row.detector},
                              {"flux", row.flux},
                              {"relative_error", num(row.relativeError)}};
            if (result.layers) jd["by_criterion"] = nlohmann::json::array();
            summary["detectors"].push_back(jd);
            continue;
        }
        std::cout << "    " << std::left << std::setw(8) << row.layer << std::right
                  << std::scientific << std::setprecision(6) << row.flux << " " << unit << " +- "
                  << std::fixed << std::setprecision(3) << 100.0 * row.relativeError << " %  "
                  << row.criterion << "\n";
        summary["detectors"].back()["by_criterion"].push_back(
            {{"layer", row.layer},
             {"criterion", row.criterion},
             {"flux", row.flux},
             {"relative_error", num(row.relativeError)}});
    }
    writeTextFile(dir / "summary.json", summary.dump(2) + "\n");
    return 0;
}

}  // namespace veil::cli
