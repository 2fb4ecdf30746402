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

#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "analysis/runs/render_run.h"
#include "cli/options.h"
#include "cli/progress.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"

namespace veil::cli {

namespace {

constexpr const char* kCheckpoint = "render.checkpoint";

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
                    "the image --target-error applies to: stray (the total without the "
                    "sources' image-forming light), total, visible, direct, caustic, "
                    "secondary, or where<k> (the k-th --where criterion's image)")
        ->capture_default_str();
    sub->add_option("--time-limit", o.timeLimit,
                    "stop after this long: 90s, 10m, 1h30m ('none': no limit); the pass under "
                    "way is then cut and left out")
        ->capture_default_str();
    sub->add_option("--passes", o.passes, "stop after this many passes in all (0: no limit)")
        ->check(CLI::Range(0, 100000000))
        ->capture_default_str();
    sub->add_option("--resume", o.resume,
                    "continue the run in this folder (its render.checkpoint); same scene and "
                    "options");
    sub->add_option("--detector", o.detector, "the detector to render (default: the first)");
    sub->add_option("--photons", o.photons,
                    "photons per source per pass: auto (100000 in the first pass, as many as "
                    "make their work that of the view points in the second, then as many as "
                    "spend the time where the --target-on image's error comes from, at most "
                    "4M), work (as many as make their work that of the view points in every "
                    "pass) or a count for every pass (20000, 2e4, 20k, 2M)")
        ->check(CLI::Validator(
            [](std::string& s) -> std::string {
                if (s == "auto" || s == "work") return {};
                std::string error;
                const auto n = parseCount(s, &error);
                if (!n) return "--photons takes auto, work or a count: " + error;
                if (*n < 1) return "--photons must be at least 1";
                return {};
            },
            "auto|work|N"))
        ->capture_default_str();
    addCount(sub, "--ghost-photons", o.ghostPhotons,
             "of those, how many follow every specular branch and deposit the sources' visible "
             "light and ghosts (at most --photons)");
    sub->add_option("--visible-photons", o.visiblePhotons,
                    "more photons per sun, beam or point source per pass that follow every "
                    "specular branch and deposit the visible light alone, gathering nothing: auto "
                    "(first 65536, or --photons if fewer, when the --target-on image holds the "
                    "visible light, else 1024; then as many as spend the time where that "
                    "image's error comes from) or a count for every pass (0: none)")
        ->check(CLI::Validator(
            [](std::string& s) -> std::string {
                if (s == "auto") return {};
                std::string error;
                if (!parseCount(s, &error))
                    return "--visible-photons takes auto or a count: " + error;
                return {};
            },
            "auto|N"))
        ->capture_default_str();
    addCount(sub, "--rays-per-pixel", o.raysPerPixel, "backward rays per pixel per pass");
    addCount(sub, "--tile-rays", o.tileRays,
             "the most backward rays (view points) a pass holds at once: past it the sensor is "
             "rendered in tiles, the photons traced again for each (less memory, more time)")
        ->check(CLI::Range(uint64_t{1}, RenderOptions::kMaxTileRays));
    addMaxMemory(sub, o.maxMemory, "render");
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
    sub->add_option("--photon-guide", o.photonGuide,
                    "share of each pass's photons emitted where the photons of the passes before "
                    "it gathered light, in [0, 1) (0: as the sources emit)")
        ->check(CLI::Range(0.0, 0.99))
        ->capture_default_str();
    sub->add_option("--scatter-guide", o.scatterGuide,
                    "share of the photons' scattered directions drawn toward where the photons "
                    "of the passes before gathered light after scattering at the same place, in "
                    "[0, 1) (0: as the surfaces scatter)")
        ->check(CLI::Range(0.0, 0.99))
        ->capture_default_str();
    sub->add_option("--weight-window", o.weightWindow,
                    "photons that expect more than W times an average photon's gathered light "
                    "where they scatter split, those below 1/W play roulette, from what the "
                    "passes before learned (0: off; W in [1, 1e6])")
        ->check(CLI::Range(0.0, 1e6))
        ->capture_default_str();
    sub->add_option("--follow-lobes-below", o.followLobesBelow,
                    "scatter lobes narrower than this half width (degrees) are followed by the "
                    "pixel rays instead of gathering photons (0: every surface gathers)")
        ->check(CLI::Range(0.0, 90.0))
        ->capture_default_str();
    sub->add_option("--splat-lobes-below", o.splatLobesBelow,
                    "scatter lobes narrower than this half width (degrees), unless followed: "
                    "photons scattering there trace --lobe-splats directions from the lobe "
                    "to the sensor instead of gathering (0: every surface gathers)")
        ->check(CLI::Range(0.0, 90.0))
        ->capture_default_str();
    sub->add_option("--lobe-splats", o.lobeSplats,
                    "directions drawn from a splatted lobe per photon scatter there")
        ->check(CLI::Range(1, 4096))
        ->capture_default_str();
    sub->add_option("--aimed-splats", o.aimedSplats,
                    "share of a narrow lobe's splats aimed at the face their light goes on "
                    "through as designed (the rest drawn from the lobe; weighed by multiple "
                    "importance sampling)")
        ->check(CLI::Range(0.0, 1.0))
        ->capture_default_str();
    sub->add_option("--connect", o.connect,
                    "light of collimated, sun and point sources that reaches a scattering "
                    "surface through the lens as designed: solved through the lens at every "
                    "view point and followed lobe (on), or left to the photons (off)")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    sub->add_option("--ghost-routes", o.ghostRoutes,
                    "with --connect on, the light a bare face's Fresnel reflections (at most "
                    "two) bring to a part is solved through the lens as well, on the routes "
                    "the pilot finds carrying at least 5 % of the part's light (on), or left "
                    "to the photons (off)")
        ->check(CLI::IsMember({"on", "off"}))
        ->capture_default_str();
    addCount(sub, "--part-samples", o.partSamples,
             "points drawn per pass on the small parts the lens lights and the pixels see "
             "through it (a stop's edge, butt ends, flats), their light traced to the pixels "
             "(0: off; needs --connect on)",
             0);
    sub->add_option("--part-directions", o.partDirections,
                    "directions each of those points sends on toward the pixels (the light "
                    "solved at the point shared among them)")
        ->check(CLI::Range(1, 1024))
        ->capture_default_str();
    addCount(sub, "--part-photons", o.partPhotons,
             "photons drawn per pass on the parts the lens lights, with the light solved "
             "through the lens, scattering on from there, where the scene has splatted lobes "
             "(--splat-lobes-below; 0: off; needs --connect on)",
             0);
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
    addPreviewFlags(sub, o.preview);
}

// The run's spec from the options, every option checked before the scene is read.
RenderRunSpec renderSpec(const RenderCommandOptions& o) {
    RenderRunSpec spec;
    const std::optional<double> timeLimit = parseDuration(o.timeLimit);
    if (!timeLimit)
        throw ParseError({"--time-limit", 1, 1},
                         "'" + o.timeLimit +
                             "' is no time limit: write a duration above 0 such as 90s, 10m or "
                             "1h30m, or none");
    if (!std::isfinite(*timeLimit) && o.passes == 0 && o.targetError <= 0.0)
        throw ParseError({"--time-limit", 1, 1}, "the run would never stop");
    if (o.prune && o.where.empty())
        throw ParseError({"--prune", 0, 0}, "--prune needs at least one --where");
    if (o.where.size() > 64) throw ParseError({"--where", 0, 0}, "at most 64 criteria");
    spec.stop = {o.targetError, RenderTarget::parse(o.targetOn, o.where.size()), *timeLimit,
                 o.passes};
    if (!o.resume.empty() && !std::filesystem::exists(std::filesystem::path(o.resume) / kCheckpoint))
        throw ParseError({"--resume", 1, 1}, o.resume + " holds no " + kCheckpoint + " to continue");
    RenderOptions& ro = spec.options;
    ro.raysPerPixel = o.raysPerPixel;
    ro.tileRays = o.tileRays;
    if (o.photons == "auto" || o.photons == "work") {
        ro.balancePhotons = true;
        ro.balancePhotonsByError = o.photons == "auto";
    } else {
        ro.photonsPerPass = *parseCount(o.photons, nullptr);
    }
    ro.ghostPhotonsPerPass = o.ghostPhotons;
    if (o.visiblePhotons == "auto") {
        // For a target the visible light is a part of (the stray light, the total, the
        // visible component): as many as the photons of a pass, up to 65536 (a run of few
        // photons is a quick one). For a criterion or another component: the fewest, from
        // where the balance grows them if the target's error calls for them.
        const RenderTarget& t = spec.stop.target;
        const bool visibleTarget =
            t.component ? *t.component == RenderComponent::Visible : t.criterion < 0;
        ro.visiblePhotonsPerPass =
            visibleTarget ? std::min(kAutoVisiblePhotons, ro.photonsPerPass) : kMinVisiblePhotons;
        ro.balanceVisible = true;
    } else {
        ro.visiblePhotonsPerPass = *parseCount(o.visiblePhotons, nullptr);
    }
    ro.alpha = o.alpha;
    ro.seed = o.seed;
    ro.rouletteRelativeFlux = o.roulette;
    ro.splitBackward = o.backward == "split";
    ro.quasiRandomPhotons = o.photonPoints == "sobol";
    ro.minRelativeWeight = o.minWeight;
    ro.initialRadiusMm = o.radiusMm;  // 0: the scene's default
    ro.prune = o.prune;
    ro.areaSamples = o.areaSamples;
    ro.guideFraction = o.guide;
    ro.photonGuideFraction = o.photonGuide;
    ro.scatterGuideFraction = o.scatterGuide;
    ro.weightWindow = o.weightWindow;
    ro.followLobesBelowDeg = o.followLobesBelow;
    ro.splatLobesBelowDeg = o.splatLobesBelow;
    ro.lobeSplats = o.lobeSplats;
    ro.aimedSplats = o.aimedSplats;
    ro.partDirections = o.partDirections;
    ro.connectThroughLens = o.connect == "on";
    ro.ghostRoutes = o.ghostRoutes == "on";
    ro.partSamples = o.partSamples;
    ro.partPhotons = o.partPhotons;
    spec.detector = o.detector;
    spec.maxMemoryBytes = static_cast<double>(o.maxMemory);
    spec.where = o.where;
    spec.scene = o.file;
    if (!o.resume.empty()) spec.resume = std::filesystem::path(o.resume) / kCheckpoint;
    // Under mpirun every pass splits over the ranks; rank 0 decides when to stop, writes the
    // checkpoint and the images (docs/scaling.md).
    spec.ranks = Ranks::world();
    return spec;
}

std::filesystem::path renderFolder(const RenderCommandOptions& o) {
    if (!o.output.empty()) return o.output;
    if (!o.resume.empty()) return o.resume;
    return o.json ? std::filesystem::path() : std::filesystem::path("render");
}

RenderCommandRun renderIntoFolder(const PreparedScene& scene, RenderRunSpec spec,
                                  const RenderCommandOptions& o, const std::filesystem::path& dir) {
    const bool root = spec.ranks.root();
    if (!dir.empty()) spec.checkpoint = dir / kCheckpoint;
    RenderRun run(scene, std::move(spec));
    // A resumed run continues the folder's files; a new one clears the older run's away.
    WrittenFiles written;
    if (root && !dir.empty()) {
        written.beginRun(dir, !o.resume.empty());
        std::filesystem::create_directories(dir);
    }
    const auto limit = limitThreads(o.threads);
    RenderCommandRun out{run.run(), {}};
    if (!root || dir.empty()) return out;  // a rank's share went to rank 0
    for (const std::filesystem::path& f :
         writeRenderFiles(out.result, dir, previewScale(o.preview)))
        written.add(f);
    written.add(dir / kCheckpoint);
    written.finishRun();
    out.written = std::move(written);
    return out;
}

int runRender(const CommonOptions& common, const RenderCommandOptions& o) {
    RenderRunSpec spec = renderSpec(o);
    const bool root = spec.ranks.root();
    const GlassCatalog catalog = loadCatalog(common);
    const std::unique_ptr<const PreparedScene> prepared =
        prepareTracedScene(common, o.file, o.fields, catalog);
    reportSceneNotes(*prepared);
    const std::filesystem::path dir = renderFolder(o);
    if (!dir.empty()) requireWritableFolder(dir, "-o");
    ProgressReporter progress;
    if (!o.quiet) spec.progress = progress.sink();
    const RenderCommandRun run = renderIntoFolder(*prepared, std::move(spec), o, dir);
    if (!root) return 0;
    progress.finish();
    const RenderResult& result = run.result;
    if (o.passes > 0 && result.passesBefore >= o.passes && !o.quiet)
        std::cerr << "veil: the run already had " << result.passesBefore << " passes (--passes "
                  << o.passes << "): its images written again\n";
    if (o.prune && result.prunedBranches + result.prunedPhotons == 0 &&
        result.passes() > result.passesBefore)
        std::cerr << "veil: warning: --prune stopped no branch: no --where criterion turned "
                     "false on any path, so pruning saved nothing\n";
    if (o.json) {
        nlohmann::json summary = result.summary();
        summary["files"] = run.written.json();
        std::cout << summary.dump(2) << "\n";
        return 0;
    }
    std::cout << result.text(dir.string());
    if (!o.quiet) {
        std::cout << "\n";
        run.written.print(std::cout);
    }
    return 0;
}

}  // namespace veil::cli
