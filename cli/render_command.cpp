// veil render SCENE -o DIR: progressive bidirectional rendering of the stray light a detector
// receives (tracer/render/render.h; the method and every knob in docs/render.md).
//
//   veil render examples/scenes/longfocus_360mm_sun.toml -o out/render
//   veil render scene.toml --target-error 0.02 --time-limit 30m -o out/r
//   veil render scene.toml --resume out/r --passes 200
//
// Writes DIR/<detector>.exr (layers total, visible, direct, caustic, secondary: the mean flux
// per pixel over the passes with the variance of the mean), DIR/<detector>.png and
// DIR/<detector>.<component>.png (false colour, log scale), DIR/summary.json, and
// DIR/render.checkpoint after every pass (atomically), from which --resume continues.

#include "cli/render_command.h"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "analysis/criteria/criterion_names.h"
#include "analysis/criteria/render_criteria.h"
#include "analysis/reports/image_output.h"
#include "analysis/runs/render_run.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/errors.h"
#include "lensdata/output_file.h"
#include "tracer/render/render.h"

namespace veil::cli {

namespace {

constexpr const char* kCheckpoint = "render.checkpoint";

// "1 pass", "2 passes".
std::string passesText(long long n) { return std::to_string(n) + (n == 1 ? " pass" : " passes"); }

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

// FNV-1a over the text that determines a run's numbers: the scene as the renderer sees it and
// the options that change what a pass computes.
uint64_t fingerprint(const TransportScene& ts, const DetectorGeometry& g, const ExitAperture& a,
                     const RenderOptions& o, const std::vector<std::string>& where) {
    std::ostringstream os;
    os << std::setprecision(17);
    for (const SceneObject& obj : ts.scene->objects()) os << obj << "\n";
    os << ts.scene->bounds() << "\n";
    for (const OpticalProperty& p : ts.properties) os << p << "\n";
    for (int p : ts.propertyOfObject) os << p << ",";
    for (const Source& s : ts.sources) os << s << "\n";
    os << g << "\n" << a << "\n";
    os << o.raysPerPixel << " " << o.photonsPerPass << " " << o.initialRadiusMm << " " << o.alpha
       << " " << o.seed << " " << o.splitBackward << " " << o.minRelativeWeight << " "
       << o.maxSpecularDepth << " " << o.detectorRadiusPixels << " " << o.viewPointRelativeWeight
       << " " << o.rouletteRelativeFlux << " " << o.maxPhotonSegments << " " << o.prune << " "
       << o.areaSamples << " " << o.quasiRandomPhotons << " " << o.ghostPhotons() << " "
       << o.photonRescueRelativeFlux << " " << o.guideFraction;
    for (const std::string& w : where) os << "\nwhere " << w;
    const std::string text = os.str();
    uint64_t h = 1469598103934665603ull;
    for (unsigned char c : text) {
        h ^= c;
        h *= 1099511628211ull;
    }
    return h;
}

double emittedFlux(const TransportScene& ts) {
    double f = 0.0;
    for (const Source& s : ts.sources) f += s.totalFlux();
    return f;
}

}  // namespace

std::optional<double> parseDuration(const std::string& text) {
    if (text == "none" || text == "0") return kInfinity;
    if (text.empty()) return std::nullopt;
    double total = 0.0;
    size_t i = 0;
    bool any = false;
    while (i < text.size()) {
        size_t j = i;
        while (j < text.size() &&
               (std::isdigit(static_cast<unsigned char>(text[j])) || text[j] == '.'))
            ++j;
        if (j == i) return std::nullopt;
        double v = 0.0;
        try {
            v = std::stod(text.substr(i, j - i));
        } catch (...) {
            return std::nullopt;
        }
        double unit = 1.0;
        if (j < text.size()) {
            const char u = text[j];
            if (u == 'h')
                unit = 3600.0;
            else if (u == 'm')
                unit = 60.0;
            else if (u == 's')
                unit = 1.0;
            else
                return std::nullopt;
            ++j;
        } else if (any) {
            return std::nullopt;  // "1h30": the unit of 30 is unclear
        }
        total += v * unit;
        any = true;
        i = j;
    }
    if (!(total > 0.0) || !std::isfinite(total)) return std::nullopt;
    return total;
}

void addRenderCommand(CLI::App& app, RenderCommandOptions& o) {
    CLI::App* sub = app.add_subcommand(
        "render",
        "stray light image by bidirectional photon mapping (progressive, docs/render.md)");
    sub->add_option("scene", o.file, "scene or lens file (.toml or .zmx)")->required();
    addOutputFolder(sub, o.output, "render");
    sub->add_option("--target-error", o.targetError,
                    "stop when the mean relative error of the lit pixels falls below this")
        ->check(CLI::Range(1e-6, 1.0))
        ->capture_default_str();
    sub->add_option("--target-on", o.targetOn,
                    "the image --target-error applies to: total, visible, direct, caustic, "
                    "secondary, or where<k> (the k-th --where criterion's image)")
        ->capture_default_str();
    sub->add_option("--time-limit", o.timeLimit,
                    "stop after this long: 90s, 10m, 1h30m ('none': no limit)")
        ->capture_default_str();
    sub->add_option("--passes", o.passes, "stop after this many passes in all (0: no limit)")
        ->check(CLI::Range(0, 100000000))
        ->capture_default_str();
    sub->add_option("--resume", o.resume,
                    "continue the run in this folder (its render.checkpoint); same scene and "
                    "options");
    sub->add_option("--detector", o.detector, "the detector to render (default: the first)");
    addCount(sub, "--photons", o.photons, "photons per source per pass");
    addCount(sub, "--ghost-photons", o.ghostPhotons,
             "of those, how many follow every specular branch and deposit the sources' visible "
             "light and ghosts (at most --photons)");
    addCount(sub, "--rays-per-pixel", o.raysPerPixel, "backward rays per pixel per pass");
    sub->add_option("--radius", o.radiusMm,
                    "initial gathering radius r1 in mm (0: 1 % of the scattering parts' size)")
        ->check(CLI::Range(0.0, 1e6))
        ->capture_default_str();
    sub->add_option("--alpha", o.alpha, "radius reduction per pass, in (0, 1)")
        ->check(CLI::Range(0.01, 0.99))
        ->capture_default_str();
    sub->add_option("--area-samples", o.areaSamples,
                    "probes per view point of the share of its gathering disk on its own "
                    "object (the rim correction; 0: off)")
        ->check(CLI::Range(0, 4096))
        ->capture_default_str();
    sub->add_option("--guide", o.guide,
                    "share of each pass's pixel rays drawn where the passes before it found "
                    "light, in [0, 1) (0: uniform over the exit aperture)")
        ->check(CLI::Range(0.0, 0.99))
        ->capture_default_str();
    sub->add_option("--roulette", o.roulette,
                    "photons below this share of their emitted flux (once scattered: of their flux "
                    "just after their first scatter) play Russian roulette (0: off)")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    sub->add_option("--backward", o.backward,
                    "backward rays: split (every specular child) or random (one by weight)")
        ->check(CLI::IsMember({"split", "random"}))
        ->capture_default_str();
    sub->add_option("--photon-points", o.photonPoints,
                    "where a pass's photons start: sobol (quasi-random, evenly spread, each "
                    "pass scrambled anew) or random")
        ->check(CLI::IsMember({"sobol", "random"}))
        ->capture_default_str();
    sub->add_option("--min-weight", o.minWeight,
                    "split backward rays: end branches below this share of the ray's weight")
        ->check(CLI::Range(0.0, 0.5))
        ->capture_default_str();
    sub->add_option("--where", o.where,
                    "path criterion on the joined path, photon events then the backward ones "
                    "(docs/criteria.md); repeatable: one image per criterion beside the total");
    sub->add_flag("--prune", o.prune,
                  "with --where: stop photons and backward rays as soon as no criterion can "
                  "match their path (faster; the total then holds only matching light)");
    addFields(sub, o.fields);
    addRunControls(sub, o.threads, o.seed);
    addReportFlags(sub, o.json, o.quiet);
}

int runRender(const CommonOptions& common, const RenderCommandOptions& o) {
    const std::optional<double> timeLimit = parseDuration(o.timeLimit);
    if (!timeLimit)
        throw ParseError({"--time-limit", 1, 1},
                         "'" + o.timeLimit + "' is no duration: write 90s, 10m, 1h30m or none");
    if (!std::isfinite(*timeLimit) && o.passes == 0 && o.targetError <= 0.0)
        throw ParseError({"--time-limit", 1, 1}, "the run would never stop");
    if (o.prune && o.where.empty())
        throw ParseError({"--prune", 0, 0}, "--prune needs at least one --where");
    if (o.where.size() > 64) throw ParseError({"--where", 0, 0}, "at most 64 criteria");
    // --target-on: the total, a component, or a criterion's image (where<k>, 1-based).
    std::optional<RenderComponent> targetComponent;
    int targetCriterion = -1;
    if (o.targetOn != "total") {
        for (int c = 0; c < kRenderComponents; ++c)
            if (o.targetOn == toString(static_cast<RenderComponent>(c)))
                targetComponent = static_cast<RenderComponent>(c);
        if (!targetComponent) {
            int k = 0;
            if (o.targetOn.rfind("where", 0) == 0 && o.targetOn.size() > 5 &&
                o.targetOn.find_first_not_of("0123456789", 5) == std::string::npos)
                k = std::stoi(o.targetOn.substr(5, 3));
            if (k < 1 || k > static_cast<int>(o.where.size()))
                throw ParseError(
                    {"--target-on", 1, 1},
                    "'" + o.targetOn +
                        "' is no image of this run: total, visible, direct, "
                        "caustic, secondary" +
                        (o.where.empty() ? std::string(", or where<k> with --where")
                                         : ", where1 to where" + std::to_string(o.where.size())));
            targetCriterion = k - 1;
        }
    }

    const GlassCatalog catalog = loadCatalog(common);
    const std::unique_ptr<const PreparedScene> prepared =
        prepareTracedScene(common, o.file, o.fields, catalog);
    const TraceSetup& trace = prepared->trace();
    const TransportScene& ts = trace.transport;
    reportSceneNotes(*prepared);
    if (ts.sources.empty()) throw ModelError(o.file, "the scene has no light source to render");
    if (trace.images.empty()) throw ModelError(o.file, "the scene has no detector to render");
    const DetectorImage& detector = trace.images[findDetector(trace, o.detector)];
    const DetectorGeometry& geometry = detector.geometry();

    RenderOptions ro;
    ro.raysPerPixel = o.raysPerPixel;
    ro.photonsPerPass = o.photons;
    ro.ghostPhotonsPerPass = o.ghostPhotons;
    ro.alpha = o.alpha;
    ro.seed = o.seed;
    ro.rouletteRelativeFlux = o.roulette;
    ro.splitBackward = o.backward == "split";
    ro.quasiRandomPhotons = o.photonPoints == "sobol";
    ro.minRelativeWeight = o.minWeight;
    ro.initialRadiusMm = o.radiusMm > 0.0 ? o.radiusMm : defaultInitialRadius(ts);
    ro.check();
    ro.prune = o.prune;
    ro.areaSamples = o.areaSamples;
    ro.guideFraction = o.guide;
    std::unique_ptr<RenderCriteria> criteria;
    if (!o.where.empty()) {
        const NameTable names = criterionNames(*ts.scene, ts);
        std::vector<CompiledCriterion> compiled;
        for (size_t i = 0; i < o.where.size(); ++i)
            compiled.push_back(
                compileCriterion(o.where[i], names, "--where " + std::to_string(i + 1)));
        criteria = std::make_unique<RenderCriteria>(std::move(compiled), names);
    }
    const int criterionCount = static_cast<int>(o.where.size());
    const ExitAperture aperture = exitApertureFor(*ts.scene, geometry);
    // Under mpirun every pass splits over the ranks; rank 0 decides when to stop, writes the
    // checkpoint and the images (docs/scaling.md).
    const Ranks ranks = Ranks::world();
    const Renderer renderer(ts, detector, aperture, ro, criteria.get(), ranks);
    const uint64_t print = fingerprint(ts, geometry, aperture, ro, o.where);

    // Where the run lives: -o, else the --resume folder, else ./render; with --json and
    // neither, a temporary folder removed at the end (--json writes files only with -o).
    std::filesystem::path dir;
    const bool scratchRun = o.json && o.output.empty() && o.resume.empty();
    if (!o.output.empty())
        dir = o.output;
    else if (!o.resume.empty())
        dir = o.resume;
    else if (scratchRun)
        dir = std::filesystem::temp_directory_path() / ("veil_render_" + std::to_string(getpid()));
    else
        dir = "render";
    struct RemoveAtEnd {
        std::filesystem::path dir;
        ~RemoveAtEnd() {
            std::error_code ec;
            if (!dir.empty()) std::filesystem::remove_all(dir, ec);
        }
    } removeAtEnd{scratchRun && ranks.root() ? dir : std::filesystem::path()};
    RenderState state(geometry, ro.initialRadiusMm, ro.alpha, criterionCount);
    if (!o.resume.empty() && ranks.root()) {
        const std::filesystem::path cp = std::filesystem::path(o.resume) / kCheckpoint;
        if (!std::filesystem::exists(cp))
            throw ParseError({"--resume", 1, 1},
                             o.resume + " holds no " + kCheckpoint + " to continue");
        state = RenderState::read(cp, print, geometry);
    }
    state.shareFromRoot(ranks);
    if (o.passes > 0 && state.passes() >= o.passes && !o.quiet && ranks.root())
        std::cerr << "veil: the run already has " << state.passes() << " passes (--passes "
                  << o.passes << "): writing its images\n";
    // A resumed run continues the folder's files; a new one clears the older run's away.
    WrittenFiles written;
    if (ranks.root()) {
        written.beginRun(dir, !o.resume.empty());
        std::filesystem::create_directories(dir);
    }

    const auto limit = limitThreads(o.threads);
    const bool terminal = !o.quiet && isatty(fileno(stderr));
    const auto start = std::chrono::steady_clock::now();
    auto seconds = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    const int startPasses = state.passes();
    uint64_t photons = 0, gathers = 0, viewPoints = 0, prunedBranches = 0, prunedPhotons = 0;
    double backwardSeconds = 0.0, photonSeconds = 0.0;
    double lastLine = -1e9;
    std::string stopReason;
    // The mean pixel error of the image the target applies to.
    auto targetError = [&] {
        if (targetComponent) return state.meanRelativeError(*targetComponent);
        if (targetCriterion >= 0) return state.criterionMeanRelativeError(targetCriterion);
        return state.meanRelativeError();
    };
    while (true) {
        if (ranks.root()) {
            if (state.passes() >= 2 && targetError() <= o.targetError)
                stopReason = "target error reached";
            else if (o.passes > 0 && state.passes() >= o.passes)
                stopReason = "pass limit reached";
            else if (seconds() >= *timeLimit)
                stopReason = "time limit reached";
        }
        if (!ranks.broadcastFlag(stopReason.empty())) break;
        const RenderPass pass =
            renderer.runPass(state.passes() + 1, state.radiusMm(), state.learned());
        state.add(pass, ranks);
        if (!ranks.root()) continue;
        state.write(dir / kCheckpoint, print);
        photons += pass.photons;
        gathers += pass.gathers;
        viewPoints += pass.viewPoints;
        prunedBranches += pass.prunedBranches;
        prunedPhotons += pass.prunedPhotons;
        backwardSeconds += pass.backwardSeconds;
        photonSeconds += pass.photonSeconds;
        if (o.quiet) continue;
        const double t = seconds();
        const double err = targetError();
        const int done = state.passes() - startPasses;
        // Passes still needed: the error falls as n^(-alpha / 2).
        std::string eta = "-";
        if (std::isfinite(err) && err > o.targetError) {
            const double need = state.passes() * std::pow(err / o.targetError, 2.0 / ro.alpha);
            eta = duration((need - state.passes()) * t / done);
        } else if (std::isfinite(err)) {
            eta = "0s";
        }
        std::ostringstream line;
        line << "render: pass " << state.passes() << ", error "
             << (std::isfinite(err) ? std::to_string(100.0 * err).substr(0, 5) + " %" : "-")
             << ", radius " << std::setprecision(3) << pass.radiusMm << " mm, " << std::fixed
             << std::setprecision(0) << photons / std::max(t, 1e-9) << " photons/s, ETA " << eta;
        if (terminal) {
            std::cerr << "\r" << line.str() << "\033[K" << std::flush;
        } else if (t - lastLine >= 10.0) {
            std::cerr << line.str() << "\n";
            lastLine = t;
        }
    }
    if (!ranks.root()) return 0;  // its share went to rank 0
    if (terminal) std::cerr << "\n";
    if (o.prune && prunedBranches + prunedPhotons == 0 && state.passes() > startPasses)
        std::cerr << "veil: warning: --prune stopped no branch: no --where criterion turned "
                     "false on any path, so pruning saved nothing\n";
    const double runSeconds = seconds();
    if (state.passes() == 0)
        throw ModelError(o.file, "no pass finished (--time-limit " + o.timeLimit + ")");

    // Images and summary.
    const std::string unit = ts.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
    const std::string name = geometry.name;
    const DetectorImage total = state.total();
    std::vector<DetectorImage> components;
    for (int c = 0; c < kRenderComponents; ++c)
        components.push_back(state.component(static_cast<RenderComponent>(c)));
    const uint64_t n = static_cast<uint64_t>(state.passes());
    // Criterion k: its total, then its components.
    std::vector<std::vector<DetectorImage>> byCriterion(static_cast<size_t>(criterionCount));
    for (int k = 0; k < criterionCount; ++k) {
        byCriterion[k].push_back(state.criterionTotal(k));
        for (int c = 0; c < kRenderComponents; ++c)
            byCriterion[k].push_back(state.criterionComponent(k, static_cast<RenderComponent>(c)));
    }
    auto layerName = [](int k) { return "where" + std::to_string(k + 1); };
    ExrInfo info{unit, n};
    std::vector<ImageLayer> layers{{"total", &total}};
    for (int c = 0; c < kRenderComponents; ++c)
        layers.push_back({std::string(toString(static_cast<RenderComponent>(c))), &components[c]});
    for (int k = 0; k < criterionCount; ++k) {
        layers.push_back({layerName(k), &byCriterion[k][0]});
        for (int c = 0; c < kRenderComponents; ++c)
            layers.push_back(
                {layerName(k) + "." + std::string(toString(static_cast<RenderComponent>(c))),
                 &byCriterion[k][c + 1]});
    }
    writeDetectorExr(dir / (name + ".exr"), layers, info);
    written.add(dir / (name + ".exr"));
    PreviewOptions po;
    po.fluxUnit = unit;
    po.emittedRays = n;
    po.decades = 3.0;  // stray light spans a few decades; 6 would flatten it
    po.title = name + ": stray light, " + passesText(n);
    writeDetectorPng(dir / (name + ".png"), total, po);
    written.add(dir / (name + ".png"));
    for (int c = 0; c < kRenderComponents; ++c) {
        const std::string comp(toString(static_cast<RenderComponent>(c)));
        if (components[c].totalFlux() == 0.0) continue;
        PreviewOptions cp = po;
        cp.title = name + ": " + comp + " component, " + passesText(n);
        writeDetectorPng(dir / (name + "." + comp + ".png"), components[c], cp);
        written.add(dir / (name + "." + comp + ".png"));
    }
    for (int k = 0; k < criterionCount; ++k) {
        PreviewOptions cp = po;
        cp.title = name + ": " + o.where[k] + ", " + passesText(n);
        const std::filesystem::path png = dir / (name + "." + layerName(k) + ".png");
        writeDetectorPng(png, byCriterion[k][0], cp);
        written.add(png);
    }

    const double emitted = emittedFlux(ts);
    const double error = state.meanRelativeError();
    nlohmann::json summary;
    summary["scene"] = o.file;
    summary["detector"] = name;
    summary["unit"] = unit;
    summary["passes"] = state.passes();
    summary["passes_this_run"] = state.passes() - startPasses;
    summary["seconds_this_run"] = runSeconds;
    summary["stopped"] = stopReason;
    summary["seed"] = o.seed;
    const RankTraffic traffic = rankTraffic();
    if (!ranks.single())
        summary["ranks"] = {{"count", ranks.size()},
                            {"rank0_bytes_received", traffic.received},
                            {"rank0_bytes_sent", traffic.sent},
                            {"rank0_seconds_in_mpi", traffic.seconds}};
    summary["options"] = {{"rays_per_pixel", ro.raysPerPixel},
                          {"photons_per_source_per_pass", ro.photonsPerPass},
                          {"ghost_photons_per_source_per_pass", ro.ghostPhotons()},
                          {"initial_radius_mm", ro.initialRadiusMm},
                          {"alpha", ro.alpha},
                          {"roulette", ro.rouletteRelativeFlux},
                          {"area_samples", ro.areaSamples},
                          {"guide", ro.guideFraction},
                          {"photon_points", ro.quasiRandomPhotons ? "sobol" : "random"}};
    summary["final_radius_mm"] = state.radiusMm();
    summary["exit_aperture"] = {
        {"center_mm", {aperture.centerMm.x, aperture.centerMm.y, aperture.centerMm.z}},
        {"radius_mm", aperture.radiusMm}};
    summary["mean_relative_error"] = num(error);
    summary["target_error"] = o.targetError;
    summary["target_on"] = o.targetOn;
    summary["target_mean_relative_error"] = num(targetError());
    summary["lit_pixels"] = state.litPixels();
    summary["emitted_flux"] = emitted;
    auto fluxJson = [&](const DetectorImage& img) {
        const double f = img.totalFlux();
        const double rel = f != 0.0 ? std::sqrt(img.totalVariance(n)) / std::abs(f) : kInfinity;
        return nlohmann::json{{"flux", f},
                              {"relative_error", num(rel)},
                              {"transmittance", emitted > 0.0 ? f / emitted : 0.0}};
    };
    summary["total"] = fluxJson(total);
    for (int c = 0; c < kRenderComponents; ++c) {
        const auto rc = static_cast<RenderComponent>(c);
        nlohmann::json j = fluxJson(components[c]);
        j["mean_relative_error"] = num(state.meanRelativeError(rc));
        summary["components"][std::string(toString(rc))] = j;
    }
    summary["criteria"] = nlohmann::json::array();
    for (int k = 0; k < criterionCount; ++k) {
        nlohmann::json j = fluxJson(byCriterion[k][0]);
        j["layer"] = layerName(k);
        j["where"] = o.where[k];
        j["mean_relative_error"] = num(state.criterionMeanRelativeError(k));
        for (int c = 0; c < kRenderComponents; ++c)
            j["components"][std::string(toString(static_cast<RenderComponent>(c)))] =
                fluxJson(byCriterion[k][c + 1]);
        summary["criteria"].push_back(j);
    }
    summary["prune"] = o.prune;
    if (o.prune) {
        summary["pruned_backward_branches_this_run"] = prunedBranches;
        summary["pruned_photon_branches_this_run"] = prunedPhotons;
    }
    summary["photons_this_run"] = photons;
    summary["view_points_this_run"] = viewPoints;
    summary["gathers_this_run"] = gathers;
    summary["backward_seconds_this_run"] = backwardSeconds;
    summary["photon_seconds_this_run"] = photonSeconds;
    writeTextFile(dir / "summary.json", summary.dump(2) + "\n");
    written.add(dir / "summary.json");
    written.add(dir / kCheckpoint);
    written.finishRun();

    if (o.json) {
        summary["files"] = scratchRun ? nlohmann::json::array() : written.json();
        std::cout << summary.dump(2) << "\n";
        return 0;
    }
    std::ostringstream text;
    auto rel = [&](const DetectorImage& img) {
        return img.totalFlux() != 0.0 ? std::sqrt(img.totalVariance(n)) / std::abs(img.totalFlux())
                                      : kInfinity;
    };
    text << "Stray light on " << name << " (" << unit << ", mean of " << passesText(n) << ")"
         << (o.prune ? ": only light whose path matches a --where (--prune)" : "") << "\n";
    text << "  total       " << formatFlux(total.totalFlux(), rel(total), unit)
         << "   transmittance " << std::scientific << std::setprecision(3)
         << (emitted > 0 ? total.totalFlux() / emitted : 0.0) << "\n";
    for (int c = 0; c < kRenderComponents; ++c) {
        const std::string comp(toString(static_cast<RenderComponent>(c)));
        text << "  " << std::left << std::setw(11) << comp << " " << std::right
             << formatFlux(components[c].totalFlux(), rel(components[c]), unit) << "\n";
    }
    for (int k = 0; k < criterionCount; ++k) {
        const DetectorImage& img = byCriterion[k][0];
        text << "  " << std::left << std::setw(11) << layerName(k) << " " << std::right
             << formatFlux(img.totalFlux(), rel(img), unit) << "   " << o.where[k] << "\n";
    }
    if (o.prune)
        text << "  pruned " << prunedBranches << " backward and " << prunedPhotons
             << " photon branches (--prune)\n";
    text << std::defaultfloat << std::setprecision(4) << "  " << passesText(state.passes()) << " ("
         << state.passes() - startPasses << " this run, " << elapsed(runSeconds) << "), "
         << stopReason << "; mean pixel error "
         << (std::isfinite(error)
                 ? std::to_string(100.0 * error).substr(0, 5) + " %"
                 : std::string(state.passes() < 2 ? "unknown (it takes two passes)" : "unknown"))
         << " over " << state.litPixels() << " lit pixels (target " << 100.0 * o.targetError
         << " %";
    const double finalTargetError = targetError();
    if (o.targetOn != "total")
        text << " on " << o.targetOn << ": "
             << (std::isfinite(finalTargetError)
                     ? std::to_string(100.0 * finalTargetError).substr(0, 5) + " %"
                     : "unknown");
    text << ")\n";
    text << "  radius " << ro.initialRadiusMm << " mm -> " << state.radiusMm() << " mm, "
         << ro.photonsPerPass << " photons per source and " << ro.raysPerPixel
         << " rays per pixel per pass\n";
    if (!ranks.single())
        text << "  across " << ranks.size() << " ranks: rank 0 received "
             << static_cast<double>(traffic.received) / 1e6 << " MB and sent "
             << static_cast<double>(traffic.sent) / 1e6 << " MB, " << elapsed(traffic.seconds)
             << " in those calls\n";
    if (stopReason != "target error reached" && std::isfinite(finalTargetError) &&
        finalTargetError > o.targetError)
        text << "  the target error was not reached: continue with --resume " << dir.string()
             << "\n";
    std::cout << text.str();
    if (!o.quiet) {
        std::cout << "\n";
        written.print(std::cout);
    }
    return 0;
}

}  // namespace veil::cli
