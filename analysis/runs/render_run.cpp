#include "analysis/runs/render_run.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>

#include "analysis/criteria/criterion_names.h"
#include "analysis/criteria/render_criteria.h"
#include "analysis/reports/format.h"
#include "analysis/reports/image_output.h"
#include "analysis/runs/memory_check.h"
#include "analysis/runs/scene_fingerprint.h"
#include "lensdata/errors.h"
#include "lensdata/output_file.h"
#include "tracer/records/detector.h"
#include "tracer/runtime/deadline.h"
#include "tracer/runtime/fingerprint.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/transport/interaction.h"

namespace veil {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// FNV-1a over the text that determines a run's numbers: the scene as the renderer sees it and
// the options that change what a pass computes.
uint64_t fingerprintOf(const TransportView& ts, const DetectorGeometry& g, const ExitAperture& a,
                       const RenderOptions& o, const std::vector<std::string>& where) {
    std::ostringstream os;
    putSceneFingerprint(os, ts);
    os << g << "\n" << a << "\n";
    os << o.raysPerPixel << " " << o.photonsPerPass << " " << o.initialRadiusMm << " " << o.alpha
       << " " << o.seed << " " << o.splitBackward << " " << o.minRelativeWeight << " "
       << o.maxSpecularDepth << " " << o.detectorRadiusPixels << " " << o.viewPointRelativeWeight
       << " " << o.rouletteRelativeFlux << " " << o.maxPhotonSegments << " " << o.prune << " "
       << o.areaSamples << " " << o.quasiRandomPhotons << " " << o.ghostPhotons() << " "
       << o.photonRescueRelativeFlux << " " << o.guideFraction << " " << o.followLobesBelowDeg
       << " " << o.balancePhotons << " " << o.maxPhotonsPerPass << " " << o.connectThroughLens
       << " " << o.partSamples << " " << o.photonGuideFraction << " " << o.scatterGuideFraction
       << " " << o.weightWindow << " " << o.visiblePhotonsPerPass << " " << o.balanceVisible << " "
       << o.splatLobesBelowDeg << " " << o.lobeSplats << " " << o.partPhotons << " "
       << o.balancePhotonsByError << " " << o.aimedSplats << " " << o.partDirections << " "
       << o.ghostRoutes << " " << o.partSplitByLight;
    // Tiles change the order of the guides' sums, so a run resumes with the same ones.
    if (o.tilePixels(g.pixelCount()) < g.pixelCount())
        os << " tiles " << o.tilePixels(g.pixelCount());
    for (const std::string& w : where) os << "\nwhere " << w;
    return fnv1a64(os.str());
}

double targetErrorOf(const RenderState& state, const RenderTarget& target) {
    if (target.component) return state.meanRelativeError(*target.component);
    if (target.criterion >= 0) return state.criterionMeanRelativeError(target.criterion);
    if (target.stray) return state.strayMeanRelativeError();
    return state.meanRelativeError();
}

// The visible photons per source of the next pass (balancedVisiblePhotons) for the target's
// error: its image and that image's visible component.
uint64_t nextVisiblePhotons(const RenderState& state, const RenderTarget& target,
                            const RenderOptions& o, const RenderPass& pass) {
    const int k = state.passes();
    const double inverse = state.visibleInverseSum();
    if (target.component) {
        const DetectorImage c = state.component(*target.component);
        const bool visible = *target.component == RenderComponent::Visible;
        return balancedVisiblePhotons(o, pass, c, visible ? &c : nullptr, k, inverse);
    }
    if (target.criterion >= 0) {
        const DetectorImage v =
            state.criterionComponent(target.criterion, RenderComponent::Visible);
        return balancedVisiblePhotons(o, pass, state.criterionTotal(target.criterion), &v, k,
                                      inverse);
    }
    const DetectorImage v = state.component(RenderComponent::Visible);
    return balancedVisiblePhotons(o, pass, target.stray ? state.strayLight() : state.total(), &v, k,
                                  inverse);
}

// The photons per source of the next pass (balancedPhotonsByError) for the target's error:
// its image and the pass's photon halves of the same light. A target the photons do not
// gather for (the visible or the direct component) keeps the balance by work.
uint64_t nextPhotons(const RenderState& state, const RenderTarget& target, const RenderOptions& o,
                     const RenderPass& pass) {
    const int k = state.passes();
    if (target.component) {
        if (*target.component == RenderComponent::Visible ||
            *target.component == RenderComponent::Direct)
            return pass.nextPhotonsPerSource;
        return balancedPhotonsByError(o, pass, state.component(*target.component),
                                      pass.photonParity, k);
    }
    if (target.criterion >= 0)
        return balancedPhotonsByError(
            o, pass, state.criterionTotal(target.criterion),
            pass.criteriaPhotonParity.at(static_cast<size_t>(target.criterion)), k);
    return balancedPhotonsByError(o, pass, target.stray ? state.strayLight() : state.total(),
                                  pass.photonParity, k);
}

std::string percent(double relativeError) {
    return std::isfinite(relativeError) ? std::to_string(100.0 * relativeError).substr(0, 5) + " %"
                                        : "-";
}

std::string layerName(int k) { return "where" + std::to_string(k + 1); }

}  // namespace

// Spec

RenderTarget RenderTarget::parse(const std::string& text, size_t criteria) {
    RenderTarget t;
    t.text = text;
    if (text == "stray") return t;
    t.stray = false;
    if (text == "total") return t;
    for (int c = 0; c < kRenderComponents; ++c)
        if (text == toString(static_cast<RenderComponent>(c)))
            t.component = static_cast<RenderComponent>(c);
    if (t.component) return t;
    int k = 0;
    if (text.rfind("where", 0) == 0 && text.size() > 5 &&
        text.find_first_not_of("0123456789", 5) == std::string::npos)
        k = std::stoi(text.substr(5, 3));
    if (k < 1 || k > static_cast<int>(criteria))
        throw ParseError({"--target-on", 1, 1},
                         "'" + text +
                             "' is no image of this run: stray, total, visible, direct, "
                             "caustic, secondary" +
                             (criteria == 0 ? std::string(", or where<k> with --where")
                                            : ", where1 to where" + std::to_string(criteria)));
    t.criterion = k - 1;
    return t;
}

double RenderPassTotals::total() const {
    double t = 0.0;
    for (double c : components) t += c;
    return t;
}

RenderPassTotals passTotals(const RenderPass& pass) {
    RenderPassTotals totals;
    for (int c = 0; c < kRenderComponents; ++c)
        for (double v : pass.pixels[static_cast<size_t>(c)])
            totals.components[static_cast<size_t>(c)] += v;
    for (const auto& byComponent : pass.criteria) {
        double sum = 0.0;
        for (const auto& pixels : byComponent)
            for (double v : pixels) sum += v;
        totals.criteria.push_back(sum);
    }
    return totals;
}

size_t findDetector(const SceneTransport& trace, const std::string& name) {
    if (name.empty()) return 0;
    std::string names;
    for (size_t d = 0; d < trace.images.size(); ++d) {
        names += (d ? ", " : "") + trace.images[d].geometry().name;
        if (trace.images[d].geometry().name == name) return d;
    }
    throw ParseError({"--detector", 1, 1},
                     "no detector '" + name + "' in the scene (it has " + names + ")");
}

// The Run

RenderRun::RenderRun(const PreparedScene& scene, RenderRunSpec spec)
    : scene_(scene), spec_(std::move(spec)) {
    const SceneTransport& trace = scene_.transport();
    const TransportView& ts = trace.view;
    const std::string file = spec_.scene.empty() ? scene_.spec().path.string() : spec_.scene;
    if (ts.sources.empty()) throw ModelError(file, "the scene has no light source to render");
    if (trace.images.empty()) throw ModelError(file, "the scene has no detector to render");
    detector_ = &trace.images[findDetector(trace, spec_.detector)];
    const DetectorGeometry& geometry = detector_->geometry();
    RenderOptions& o = spec_.options;
    if (o.initialRadiusMm <= 0.0) o.initialRadiusMm = defaultInitialRadius(ts);
    o.check();
    // The memory the render will take, before any of it is taken (1e9 rays per pixel had
    // allocated 16 GB at 1.5 GB/s before anything said so).
    memoryBytes_ = residentBytes() + renderMemoryBytes(static_cast<uint64_t>(geometry.pixelCount()),
                                                       o, spec_.where.size(), ts.sources.size());
    {
        const int tile = o.tilePixels(geometry.pixelCount());
        std::ostringstream detail;
        detail << geometry.pixelCount() << " pixels";
        if (tile < geometry.pixelCount()) detail << " in tiles of " << tile;
        detail << " x " << o.raysPerPixel << " rays per pixel, one view point each";
        checkMemory(file, "render", memoryBytes_, detail.str(),
                    "lower --tile-rays, --rays-per-pixel or the detector's pixels",
                    spec_.maxMemoryBytes);
    }
    if (!spec_.where.empty()) {
        const NameTable names = criterionNames(*ts.scene, ts);
        criteria_ = std::make_unique<RenderCriteria>(compileWhereList(spec_.where, names), names);
    }
    aperture_ = exitApertureFor(*ts.scene, geometry);
    // The renderer's set-up can take seconds (the pilots of the lit parts' light).
    if (spec_.progress && spec_.ranks.root())
        spec_.progress(
            {"render: preparing (the lens connections, the lit parts' pilots; memory about " +
                 gigabytes(memoryBytes_) + ")",
             0, 0, ""});
    renderer_ =
        std::make_unique<Renderer>(ts, *detector_, aperture_, o, criteria_.get(), spec_.ranks);
    fingerprint_ = fingerprintOf(ts, geometry, aperture_, o, spec_.where);
    state_ = RenderState(geometry, o.initialRadiusMm, o.alpha, static_cast<int>(spec_.where.size()));
    if (!spec_.resume.empty() && spec_.ranks.root()) {
        if (!std::filesystem::exists(spec_.resume))
            throw ParseError({"--resume", 1, 1}, spec_.resume.parent_path().string() +
                                                     " holds no " +
                                                     spec_.resume.filename().string() +
                                                     " to continue");
        state_ = RenderState::read(spec_.resume, fingerprint_, geometry);
    }
    state_.shareFromRoot(spec_.ranks);
}

RenderRun::~RenderRun() = default;

std::string RenderRun::stopReason(double seconds) const {
    const RenderStopRules& s = spec_.stop;
    if (s.targetError > 0.0 && state_.passes() >= 2 &&
        targetErrorOf(state_, s.target) <= s.targetError)
        return "target error reached";
    if (s.passes > 0 && state_.passes() >= s.passes) return "pass limit reached";
    if (seconds >= s.timeLimitSeconds) return "time limit reached";
    return "";
}

RenderResult RenderRun::run(const std::function<void(const RenderPassEvent&)>& onPass) {
    const Ranks& ranks = spec_.ranks;
    RenderResult r;
    r.passesBefore = state_.passes();
    r.memoryBytes = memoryBytes_;
    const auto start = std::chrono::steady_clock::now();
    auto seconds = [&] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    };
    // The passes' clock starts now, not at the first pass's end.
    if (spec_.progress && ranks.root()) {
        ProgressEvent e{"render", static_cast<uint64_t>(r.passesBefore),
                        static_cast<uint64_t>(std::max(spec_.stop.passes, 0)), "passes"};
        e.state = "pass " + std::to_string(r.passesBefore + 1) + " running";
        spec_.progress(e);
    }
    // The time limit holds inside a pass in one process: the pass under way when it passes is
    // cut at its next block and left out, so the images are those of the passes that finished
    // (bitwise a run stopped after them). Ranks must stop together: across several, the limit
    // is checked between passes.
    const Deadline deadline =
        ranks.single() && std::isfinite(spec_.stop.timeLimitSeconds)
            ? Deadline(start + std::chrono::duration_cast<Deadline::Clock::duration>(
                                   std::chrono::duration<double>(spec_.stop.timeLimitSeconds)))
            : Deadline();
    while (true) {
        if (ranks.root()) r.stopReason = stopReason(seconds());
        if (!ranks.broadcastFlag(r.stopReason.empty())) break;
        RenderPass pass;
        try {
            pass = renderer_->runPass(state_.passes() + 1, state_.radiusMm(), state_.learned(),
                                      state_.photonsPerPass(), state_.visiblePhotons(), deadline);
        } catch (const DeadlinePassed&) {
            r.stopReason = "time limit reached (the pass under way was cut and left out)";
            r.passCut = true;
            break;
        }
        state_.add(pass, ranks);
        if (spec_.options.balanceVisible) {
            ByteWriter w;
            if (ranks.root())
                w.put(nextVisiblePhotons(state_, spec_.stop.target, spec_.options, pass));
            Bytes bytes = w.take();
            ranks.broadcast(bytes);
            state_.setVisiblePhotons(ByteReader(bytes).get<uint64_t>());
        }
        if (spec_.options.balancePhotons && spec_.options.balancePhotonsByError) {
            ByteWriter w;
            if (ranks.root()) w.put(nextPhotons(state_, spec_.stop.target, spec_.options, pass));
            Bytes bytes = w.take();
            ranks.broadcast(bytes);
            state_.setPhotonsPerPass(ByteReader(bytes).get<uint64_t>());
        }
        if (!ranks.root()) continue;
        if (!spec_.checkpoint.empty()) state_.write(spec_.checkpoint, fingerprint_);
        r.photons += pass.photons;
        r.gathers += pass.gathers;
        r.viewPoints += pass.viewPoints;
        r.backwardSegments += pass.backwardSegments;
        r.connectionRays += pass.connectionRays;
        r.lastPhotonsPerSource = pass.photonsPerSource;
        r.lastVisiblePerSource = pass.visiblePerSource;
        r.viewPointWork += pass.viewPointWork;
        r.photonWork += pass.photonWork;
        r.photonSegments += pass.photonSegments;
        r.prunedBranches += pass.prunedBranches;
        r.prunedPhotons += pass.prunedPhotons;
        r.backwardSeconds += pass.backwardSeconds;
        r.photonSeconds += pass.photonSeconds;
        r.partSamples += pass.partSamples;
        r.partFound += pass.partFound;
        r.partRays += pass.partRays;
        r.partSeconds += pass.partSeconds;
        const double t = seconds();
        if (onPass) onPass({state_.passes(), &pass, &state_, t});
        if (spec_.progress) {
            // Passes still needed: the error falls as n^(-alpha / 2).
            const double err = targetErrorOf(state_, spec_.stop.target);
            const double target = spec_.stop.targetError;
            ProgressEvent e{"render", static_cast<uint64_t>(state_.passes()),
                            static_cast<uint64_t>(std::max(spec_.stop.passes, 0)), "passes"};
            if (std::isfinite(err) && target > 0.0 && err > target) {
                const double need =
                    state_.passes() * std::pow(err / target, 2.0 / spec_.options.alpha);
                e.etaSeconds = (need - state_.passes()) * t / (state_.passes() - r.passesBefore);
            } else if (std::isfinite(err) && target > 0.0) {
                e.etaSeconds = 0.0;
            }
            std::ostringstream s;
            s << "error " << percent(err) << ", radius " << std::setprecision(3) << pass.radiusMm
              << " mm, " << std::fixed << std::setprecision(0) << r.photons / std::max(t, 1e-9)
              << " photons/s";
            e.state = s.str();
            spec_.progress(e);
        }
    }
    r.seconds = seconds();
    r.root = ranks.root();
    r.spec = spec_;
    r.aperture = aperture_;
    r.state = state_;
    if (!r.root) return r;  // its share went to rank 0
    if (state_.passes() == 0)
        throw ModelError(spec_.scene.empty() ? scene_.spec().path.string() : spec_.scene,
                         "no pass finished (the time limit ended the run first)");
    const TransportView& ts = scene_.transport().view;
    r.scene = spec_.scene;
    r.detector = detector_->geometry().name;
    r.unit = ts.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
    for (const Source& s : ts.sources) r.emittedFlux += s.totalFlux();
    r.traffic = rankTraffic();
    return r;
}

// Result

double RenderResult::targetError() const { return targetErrorOf(state, spec.stop.target); }

namespace {

// Whether the gathered light rests on few photons (RenderState::kFewPhotons) while it is at least
// 1 % of the stray light: its error bar need not hold.
bool fewPhotons(const RenderState& state) {
    const double n = state.effectivePhotons();
    const double gathered = state.component(RenderComponent::Caustic).totalFlux() +
                            state.component(RenderComponent::Secondary).totalFlux();
    return n > 0.0 && n < RenderState::kFewPhotons &&
           std::abs(gathered) >= 0.01 * std::abs(state.strayLight().totalFlux());
}

// Whether the light the pixel rays brought back rests on few rays while it is at least 1 % of
// the stray light.
bool fewRays(const RenderState& state) {
    const double n = state.effectiveRays();
    return n > 0.0 && n < RenderState::kFewPhotons &&
           std::abs(state.rayLight()) >= 0.01 * std::abs(state.strayLight().totalFlux());
}

// One line on the gathered light's radius bias (RadiusBias).
std::string radiusBiasText(const RadiusBias& b, double gathered) {
    std::ostringstream os;
    os << std::defaultfloat << std::setprecision(2);
    if (!(gathered != 0.0)) return "radius bias: no gathered light";
    const double relEstimate = 100.0 * b.estimate() / gathered;
    const double relBound = 100.0 * b.bound() / gathered;
    if (b.detected() && !b.bounded(gathered))
        os << "radius bias DETECTED and NOT BOUNDED: the gathered light changes by " << relEstimate
           << " % between r and r/2 (x2), the light varies on a scale below the radius; the "
              "errors include the change, but the bias may be larger. Lower --radius";
    else if (b.detected())
        os << "radius bias DETECTED: the gathered light changes by " << relEstimate
           << " % between r and r/2 (x2); the errors with it include it. Lower --radius, or "
              "run more passes";
    else if (!std::isfinite(relBound) || relBound > 100.0)
        os << "radius bias not bounded (the half-radius estimate is too noisy yet)";
    else {
        os << "radius bias not detected: at most " << relBound << " % of the gathered light";
        if (b.included() > 0.0)
            os << "; the errors include " << 100.0 * b.included() / std::abs(gathered)
               << " % (its estimate beyond one sigma of its noise)";
    }
    return os.str();
}

}  // namespace

nlohmann::json RenderResult::summary() const {
    const RenderOptions& ro = spec.options;
    const uint64_t n = static_cast<uint64_t>(state.passes());
    const int criterionCount = state.criteria();
    nlohmann::json summary;
    summary["scene"] = scene;
    summary["detector"] = detector;
    summary["unit"] = unit;
    summary["passes"] = state.passes();
    summary["passes_this_run"] = state.passes() - passesBefore;
    summary["seconds_this_run"] = seconds;
    summary["stopped"] = stopReason;
    summary["pass_cut"] = passCut;
    summary["seed"] = ro.seed;
    summary["memory_estimate_bytes"] = memoryBytes;
    if (!spec.ranks.single())
        summary["ranks"] = {{"count", spec.ranks.size()},
                            {"rank0_bytes_received", traffic.received},
                            {"rank0_bytes_sent", traffic.sent},
                            {"rank0_seconds_in_mpi", traffic.seconds}};
    summary["options"] = {
        {"rays_per_pixel", ro.raysPerPixel},
        {"tile_rays", ro.tileRays},
        {"tile_pixels", ro.tilePixels(state.pixelCount())},
        {"photons_per_source_per_pass", ro.photonsPerPass},
        {"balanced_photons", ro.balancePhotons},
        {"photons_balanced_by_error", ro.balancePhotons && ro.balancePhotonsByError},
        {"max_photons_per_source_per_pass", ro.maxPhotonsPerPass},
        {"ghost_photons_per_source_per_pass", ro.ghostPhotons()},
        {"visible_photons_per_source_per_pass", ro.visiblePhotonsPerPass},
        {"balanced_visible_photons", ro.balanceVisible},
        {"initial_radius_mm", ro.initialRadiusMm},
        {"alpha", ro.alpha},
        {"roulette", ro.rouletteRelativeFlux},
        {"area_samples", ro.areaSamples},
        {"guide", ro.guideFraction},
        {"photon_guide", ro.photonGuideFraction},
        {"follow_lobes_below_deg", ro.followLobesBelowDeg},
        {"connect_through_lens", ro.connectThroughLens},
        {"ghost_routes", ro.ghostRoutes},
        {"part_samples_per_pass", ro.partSamples},
        {"part_split_by_light", ro.partSplitByLight},
        {"splat_lobes_below_deg", ro.splatLobesBelowDeg},
        {"lobe_splats", ro.lobeSplats},
        {"aimed_splats", ro.aimedSplats},
        {"part_directions", ro.partDirections},
        {"part_photons_per_pass", ro.partPhotons},
        {"photon_points", ro.quasiRandomPhotons ? "sobol" : "random"}};
    summary["final_radius_mm"] = state.radiusMm();
    summary["photons_per_source_last_pass"] = lastPhotonsPerSource;
    summary["visible_photons_per_source_last_pass"] = lastVisiblePerSource;
    summary["exit_aperture"] = {
        {"center_mm", {aperture.centerMm.x, aperture.centerMm.y, aperture.centerMm.z}},
        {"radius_mm", aperture.radiusMm}};
    summary["mean_relative_error"] = jsonNumber(state.meanRelativeError());
    summary["stray_mean_relative_error"] = jsonNumber(state.strayMeanRelativeError());
    summary["target_error"] = spec.stop.targetError;
    summary["target_on"] = spec.stop.target.text;
    summary["target_mean_relative_error"] = jsonNumber(targetError());
    summary["lit_pixels"] = state.litPixels();
    summary["emitted_flux"] = emittedFlux;
    auto fluxJson = [&](const DetectorImage& img, const RadiusBias* bias = nullptr) {
        const double f = img.totalFlux();
        const double sigma = std::sqrt(img.totalVariance(n));
        const double error = bias ? bias->errorWith(sigma) : sigma;
        nlohmann::json j{{"flux", f},
                         {"relative_error", jsonNumber(f != 0.0 ? error / std::abs(f) : kInf)},
                         {"transmittance", emittedFlux > 0.0 ? f / emittedFlux : 0.0}};
        if (bias)
            j["statistical_relative_error"] = jsonNumber(f != 0.0 ? sigma / std::abs(f) : kInf);
        return j;
    };
    auto biasJson = [&](const RadiusBias& b, double gathered) {
        auto share = [&](double x) { return jsonNumber(gathered != 0.0 ? x / gathered : kInf); };
        return nlohmann::json{{"half_radius_difference", b.difference},
                              {"half_radius_difference_sigma", b.sigma},
                              {"estimate", b.estimate()},
                              {"bound", b.bound()},
                              {"relative_estimate", share(b.estimate())},
                              {"relative_bound", share(b.bound())},
                              {"included", b.included()},
                              {"detected", b.detected()},
                              {"bounded", b.bounded(gathered)}};
    };
    auto gatheredOf = [&](const DetectorImage& caustic, const DetectorImage& secondary) {
        return caustic.totalFlux() + secondary.totalFlux();
    };
    const RadiusBias bias = state.radiusBias();
    summary["total"] = fluxJson(state.total(), &bias);
    summary["image_forming"] = fluxJson(state.imageForming());
    summary["stray"] = fluxJson(state.strayLight(), &bias);
    summary["stray"]["mean_relative_error"] = jsonNumber(state.strayMeanRelativeError());
    summary["gathered_effective_photons"] = state.effectivePhotons();
    summary["few_photons"] = fewPhotons(state);
    summary["backward_effective_rays"] = state.effectiveRays();
    summary["few_rays"] = fewRays(state);
    summary["radius_bias"] =
        biasJson(bias, gatheredOf(state.component(RenderComponent::Caustic),
                                  state.component(RenderComponent::Secondary)));
    for (int c = 0; c < kRenderComponents; ++c) {
        const auto rc = static_cast<RenderComponent>(c);
        nlohmann::json j = fluxJson(state.component(rc));
        j["mean_relative_error"] = jsonNumber(state.meanRelativeError(rc));
        summary["components"][std::string(toString(rc))] = j;
    }
    summary["criteria"] = nlohmann::json::array();
    for (int k = 0; k < criterionCount; ++k) {
        const RadiusBias kb = state.criterionRadiusBias(k);
        nlohmann::json j = fluxJson(state.criterionTotal(k), &kb);
        j["radius_bias"] =
            biasJson(kb, gatheredOf(state.criterionComponent(k, RenderComponent::Caustic),
                                    state.criterionComponent(k, RenderComponent::Secondary)));
        j["layer"] = layerName(k);
        j["where"] = spec.where[static_cast<size_t>(k)];
        j["mean_relative_error"] = jsonNumber(state.criterionMeanRelativeError(k));
        for (int c = 0; c < kRenderComponents; ++c) {
            const auto rc = static_cast<RenderComponent>(c);
            j["components"][std::string(toString(rc))] = fluxJson(state.criterionComponent(k, rc));
        }
        summary["criteria"].push_back(j);
    }
    summary["prune"] = ro.prune;
    if (ro.prune) {
        summary["pruned_backward_branches_this_run"] = prunedBranches;
        summary["pruned_photon_branches_this_run"] = prunedPhotons;
    }
    summary["photons_this_run"] = photons;
    summary["view_points_this_run"] = viewPoints;
    summary["gathers_this_run"] = gathers;
    summary["backward_segments_this_run"] = backwardSegments;
    summary["connection_rays_this_run"] = connectionRays;
    summary["photon_segments_this_run"] = photonSegments;
    summary["view_point_work_this_run"] = viewPointWork;
    summary["photon_work_this_run"] = photonWork;
    summary["backward_seconds_this_run"] = backwardSeconds;
    summary["photon_seconds_this_run"] = photonSeconds;
    summary["part_samples_this_run"] = partSamples;
    summary["part_samples_found_this_run"] = partFound;
    summary["part_rays_this_run"] = partRays;
    summary["part_seconds_this_run"] = partSeconds;
    return summary;
}

std::string RenderResult::text(const std::string& folder) const {
    const RenderOptions& ro = spec.options;
    const uint64_t n = static_cast<uint64_t>(state.passes());
    const double error = state.meanRelativeError();
    std::ostringstream text;
    auto rel = [&](const DetectorImage& img, const RadiusBias* bias = nullptr) {
        const double sigma = std::sqrt(img.totalVariance(n));
        return img.totalFlux() != 0.0
                   ? (bias ? bias->errorWith(sigma) : sigma) / std::abs(img.totalFlux())
                   : kInf;
    };
    const DetectorImage total = state.total();
    const RadiusBias bias = state.radiusBias();
    const DetectorImage formed = state.imageForming(), stray = state.strayLight();
    text << "Light on " << detector << " (" << unit << ", mean of " << passesText(n) << ")"
         << (ro.prune ? ": only light whose path matches a --where (--prune)" : "") << "\n";
    text << "  stray light " << formatFlux(stray.totalFlux(), rel(stray, &bias), unit)
         << "   transmittance " << std::scientific << std::setprecision(3)
         << (emittedFlux > 0 ? stray.totalFlux() / emittedFlux : 0.0) << std::defaultfloat
         << ", mean pixel error " << percent(state.strayMeanRelativeError()) << "\n";
    text << "  image       " << formatFlux(formed.totalFlux(), rel(formed), unit)
         << "   the sources' image-forming light (through the lens as designed)\n";
    text << "  total       " << formatFlux(total.totalFlux(), rel(total, &bias), unit)
         << "   transmittance " << std::scientific << std::setprecision(3)
         << (emittedFlux > 0 ? total.totalFlux() / emittedFlux : 0.0) << "\n";
    for (int c = 0; c < kRenderComponents; ++c) {
        const auto rc = static_cast<RenderComponent>(c);
        const DetectorImage img = state.component(rc);
        text << "  " << std::left << std::setw(11) << std::string(toString(rc)) << " "
             << std::right << formatFlux(img.totalFlux(), rel(img), unit) << "\n";
    }
    const double gathered = state.component(RenderComponent::Caustic).totalFlux() +
                            state.component(RenderComponent::Secondary).totalFlux();
    text << "  " << radiusBiasText(bias, gathered) << "\n";
    if (fewPhotons(state))
        text << "  FEW PHOTONS: the gathered light rests on " << std::defaultfloat
             << std::setprecision(2) << state.effectivePhotons()
             << " effective photons over the passes (fewer than "
             << static_cast<int>(RenderState::kFewPhotons)
             << "): its error bar may not hold, a pass that missed the rare photons looks like "
                "one that did not need them. Run longer (docs/render.md, \"Error bars from few "
                "passes\")\n"
             << std::setprecision(6);
    if (fewRays(state))
        text << "  FEW RAYS: the light the pixel rays found (a source seen directly or through "
                "the lens, next-event and connected light) rests on "
             << std::defaultfloat << std::setprecision(2) << state.effectiveRays()
             << " effective rays over the passes (fewer than "
             << static_cast<int>(RenderState::kFewPhotons)
             << "): its error bar may not hold. Run longer or raise --rays-per-pixel "
                "(docs/render.md, \"Error bars from few passes\")\n"
             << std::setprecision(6);
    for (int k = 0; k < state.criteria(); ++k) {
        const DetectorImage img = state.criterionTotal(k);
        const RadiusBias kb = state.criterionRadiusBias(k);
        text << "  " << std::left << std::setw(11) << layerName(k) << " " << std::right
             << formatFlux(img.totalFlux(), rel(img, &kb), unit) << "   "
             << spec.where[static_cast<size_t>(k)]
             << (kb.detected() ? " (radius bias detected, included)" : "") << "\n";
    }
    if (ro.prune)
        text << "  pruned " << prunedBranches << " backward and " << prunedPhotons
             << " photon branches (--prune)\n";
    text << std::defaultfloat << std::setprecision(4) << "  " << passesText(state.passes()) << " ("
         << state.passes() - passesBefore << " this run, " << elapsed(seconds) << "), "
         << stopReason << "; mean pixel error of the total "
         << (std::isfinite(error)
                 ? std::to_string(100.0 * error).substr(0, 5) + " %"
                 : std::string(state.passes() < 2 ? "unknown (it takes two passes)" : "unknown"))
         << " over " << state.litPixels() << " lit pixels (target " << 100.0 * spec.stop.targetError
         << " %";
    const double finalTargetError = targetError();
    if (spec.stop.target.text != "total")
        text << " on " << spec.stop.target.text << ": "
             << (std::isfinite(finalTargetError)
                     ? std::to_string(100.0 * finalTargetError).substr(0, 5) + " %"
                     : "unknown");
    text << ")\n";
    text << "  radius " << ro.initialRadiusMm << " mm -> " << state.radiusMm() << " mm, ";
    if (ro.balancePhotons && lastPhotonsPerSource != ro.photonsPerPass)
        text << "photons per source balanced against "
             << (ro.balancePhotonsByError ? "the target's error" : "the view points") << " ("
             << ro.photonsPerPass << " in the first pass, " << lastPhotonsPerSource
             << " in the last)";
    else
        text << ro.photonsPerPass << " photons per source";
    text << " and " << ro.raysPerPixel << " rays per pixel per pass";
    if (lastVisiblePerSource > 0) {
        text << ", " << lastVisiblePerSource << " visible photons per source in the last";
        if (ro.balanceVisible) text << " (balanced against the target's error)";
    }
    text << "\n";
    if (!spec.ranks.single())
        text << "  across " << spec.ranks.size() << " ranks: rank 0 received "
             << static_cast<double>(traffic.received) / 1e6 << " MB and sent "
             << static_cast<double>(traffic.sent) / 1e6 << " MB, " << elapsed(traffic.seconds)
             << " in those calls\n";
    if (stopReason != "target error reached" && std::isfinite(finalTargetError) &&
        finalTargetError > spec.stop.targetError)
        text << "  the target error was not reached: continue with --resume " << folder << "\n";
    return text.str();
}

// Files

std::vector<std::pair<std::string, DetectorImage>> RenderResult::imageLayers() const {
    std::vector<std::pair<std::string, DetectorImage>> out;
    out.emplace_back("total", state.total());
    for (int c = 0; c < kRenderComponents; ++c)
        out.emplace_back(toString(static_cast<RenderComponent>(c)),
                         state.component(static_cast<RenderComponent>(c)));
    for (int k = 0; k < state.criteria(); ++k) {
        out.emplace_back(layerName(k), state.criterionTotal(k));
        for (int c = 0; c < kRenderComponents; ++c)
            out.emplace_back(
                layerName(k) + "." + std::string(toString(static_cast<RenderComponent>(c))),
                state.criterionComponent(k, static_cast<RenderComponent>(c)));
    }
    out.emplace_back("stray", state.strayLight());
    out.emplace_back("image", state.imageForming());
    return out;
}

std::vector<std::filesystem::path> writeRenderFiles(const RenderResult& r,
                                                    const std::filesystem::path& dir,
                                                    const PreviewScale& scale) {
    std::vector<std::filesystem::path> written;
    const int criterionCount = r.state.criteria();
    const std::vector<std::pair<std::string, DetectorImage>> images = r.imageLayers();
    std::vector<ImageLayer> layers;
    for (const auto& [layer, image] : images) layers.push_back({layer, &image});
    const DetectorImage& total = images[0].second;
    auto component = [&](int c) -> const DetectorImage& { return images[1 + c].second; };
    auto criterion = [&](int k) -> const DetectorImage& {
        return images[1 + kRenderComponents + k * (kRenderComponents + 1)].second;
    };
    const uint64_t n = static_cast<uint64_t>(r.state.passes());
    const std::string& name = r.detector;
    writeDetectorExr(dir / (name + ".exr"), layers, ExrInfo{r.unit, n});
    written.push_back(dir / (name + ".exr"));
    PreviewOptions po;
    po.fluxUnit = r.unit;
    po.emittedRays = n;
    po.scale = scale;
    const DetectorImage& stray = images[images.size() - 2].second;
    const DetectorImage& formed = images[images.size() - 1].second;
    po.title =
        name + (formed.totalFlux() != 0.0 ? ": all light, " : ": stray light, ") + passesText(n);
    // All the light on the stray light's scale: the sources' image above it.
    PreviewOptions all = po;
    if (formed.totalFlux() != 0.0 && stray.totalFlux() != 0.0) {
        all.rangeImage = &stray;
        all.rangeName = "stray light";
    }
    writeDetectorPng(dir / (name + ".png"), total, all);
    written.push_back(dir / (name + ".png"));
    if (formed.totalFlux() != 0.0 && stray.totalFlux() != 0.0) {
        PreviewOptions sp = po;
        sp.title = name + ": stray light (without the image-forming light), " + passesText(n);
        writeDetectorPng(dir / (name + ".stray.png"), stray, sp);
        written.push_back(dir / (name + ".stray.png"));
    }
    for (int c = 0; c < kRenderComponents; ++c) {
        const std::string comp(toString(static_cast<RenderComponent>(c)));
        if (component(c).totalFlux() == 0.0) continue;
        PreviewOptions cp = po;
        cp.title = name + ": " + comp + " component, " + passesText(n);
        writeDetectorPng(dir / (name + "." + comp + ".png"), component(c), cp);
        written.push_back(dir / (name + "." + comp + ".png"));
    }
    for (int k = 0; k < criterionCount; ++k) {
        PreviewOptions cp = po;
        cp.title = name + ": " + r.spec.where[static_cast<size_t>(k)] + ", " + passesText(n);
        const std::filesystem::path png = dir / (name + "." + layerName(k) + ".png");
        writeDetectorPng(png, criterion(k), cp);
        written.push_back(png);
    }
    writeTextFile(dir / "summary.json", r.summary().dump(2) + "\n");
    written.push_back(dir / "summary.json");
    return written;
}

}  // namespace veil
