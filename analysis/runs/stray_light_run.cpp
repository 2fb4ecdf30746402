#include "analysis/runs/stray_light_run.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <limits>
#include <optional>
#include <sstream>

#include "analysis/criteria/criterion_names.h"
#include "analysis/reports/format.h"
#include "analysis/reports/image_output.h"
#include "analysis/runs/memory_check.h"
#include "analysis/runs/scene_fingerprint.h"
#include "lensdata/errors.h"
#include "lensdata/output_file.h"
#include "tracer/records/detector.h"
#include "tracer/records/path_history.h"
#include "tracer/runtime/fingerprint.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_transport.h"

namespace veil {

std::vector<StrayLightRow> StrayLightResult::report() const {
    std::vector<StrayLightRow> rows;
    for (size_t d = 0; d < images.size(); ++d) {
        const DetectorImage& img = images[d];
        const std::string name = img.geometry().name;
        rows.push_back({name, "", "", img.totalFlux(), img.totalRelativeError(emittedRays)});
        if (!layers) continue;
        for (size_t c = 0; c <= layers->criterionCount(); ++c) {
            const DetectorImage& layer = layers->images()[c][d];
            const bool rest = c == layers->criterionCount();
            rows.push_back({name, rest ? "rest" : "where" + std::to_string(c + 1),
                            rest ? "none of the above" : layers->text(c), layer.totalFlux(),
                            layer.totalRelativeError(emittedRays)});
        }
    }
    return rows;
}

double traceMemoryBytes(const std::vector<DetectorImage>& detectors, size_t criteria) {
    double pixels = 0.0;
    for (const DetectorImage& d : detectors)
        pixels += static_cast<double>(d.geometry().pixelCount());
    // The images, the criterion layers (the criteria and the rest), the PNG's range copy
    // (writeTraceFiles) and the EXR's float channels while a file is written.
    const double layers = criteria > 0 ? static_cast<double>(criteria + 1) : 0.0;
    return pixels * (kImageBytesPerPixel * (2.0 + layers) + 16.0 * (1.0 + layers));
}

namespace {

// FNV-1a over what determines a trace's numbers: the scene as the tracer sees it, the rays, the
// transport options, the criteria and the per-ray consumer.
uint64_t traceFingerprint(const TransportView& ts, const std::vector<DetectorImage>& detectors,
                          const StrayLightSpec& spec, const TransportOptions& o) {
    std::ostringstream os;
    putSceneFingerprint(os, ts);
    for (const DetectorImage& d : detectors) os << d.geometry() << "\n";
    os << spec.raysPerSource << " " << o << " " << o.raysPerBlock << " " << spec.prune << "\n";
    for (const std::string& w : spec.where) os << "where " << w << "\n";
    os << "consumer " << spec.consumerKey;
    return fnv1a64(os.str());
}

}  // namespace

StrayLightResult runStrayLight(const PreparedScene& scene, const StrayLightSpec& spec) {
    const SceneTransport& ts = scene.transport();
    StrayLightResult result;
    result.scene = spec.scene.empty() ? scene.spec().path.string() : spec.scene;
    result.raysPerSource = spec.raysPerSource;
    result.seed = spec.transport.seed;
    result.prune = spec.prune;
    for (const DetectorImage& img : ts.images)
        result.detectorObjects.push_back(scene.scene().object(img.geometry().object).name);
    result.emittedRays = spec.raysPerSource * ts.view.sources.size();
    result.fluxUnit = ts.view.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
    if (spec.prune && spec.where.empty())
        throw ModelError(scene.spec().path.string(), "pruning needs at least one criterion");

    // The memory the trace will take, before any of it is taken (a 16384 x 16384 detector
    // holds 6.4 GB an image).
    result.memoryBytes = residentBytes() + traceMemoryBytes(ts.images, spec.where.size());
    {
        uint64_t pixels = 0;
        for (const DetectorImage& d : ts.images)
            pixels += static_cast<uint64_t>(d.geometry().pixelCount());
        std::ostringstream detail;
        detail << pixels << " pixels on " << ts.images.size() << " detector"
               << (ts.images.size() == 1 ? "" : "s");
        if (!spec.where.empty())
            detail << ", " << spec.where.size() + 1 << " criterion layers each";
        checkMemory(result.scene, "trace", result.memoryBytes, detail.str(),
                    spec.where.empty()
                        ? "lower the detectors' pixels"
                        : "lower the detectors' pixels or use fewer --where criteria",
                    spec.maxMemoryBytes);
    }
    TransportOptions options = spec.transport;
    if (!spec.where.empty()) {
        const NameTable names = criterionNames(scene.scene(), ts.view);
        result.layers = std::make_unique<CriterionImages>(
            spec.where, compileWhereList(spec.where, names), ts.images, ts.view.detectorOfObject,
            ts.view.nextDetector);
    }
    std::unique_ptr<CriteriaFilter> filter;
    if (spec.prune) {
        filter = std::make_unique<CriteriaFilter>(result.layers->criteria());
        options.filter = filter.get();
    }
    // A run that goes on from its checkpoint: every part (the images, the layers, the
    // consumer) back at its own mark, before the consumer opens.
    const bool checkpoints = !spec.checkpoint.empty();
    if (checkpoints && !options.ranks.single())
        throw ModelError(result.scene, "checkpoints need one process (not mpirun)");
    const uint64_t fingerprint =
        checkpoints ? traceFingerprint(ts.view, ts.images, spec, options) : 0;
    std::optional<TraceCheckpoint> resumed;
    if (checkpoints && spec.resume) {
        resumed = readTraceCheckpoint(spec.checkpoint, fingerprint, ts.images,
                                      spec.where.empty() ? 0 : spec.where.size() + 1);
        if (resumed->hasConsumer && spec.restoreConsumer) spec.restoreConsumer(resumed->consumer);
    }
    const RayCallback extra = spec.openConsumer ? spec.openConsumer() : RayCallback{};
    RayCallback onRay;
    if (result.layers || extra) {
        options.recordHistories = true;
        RayCallback layerCallback =
            result.layers ? result.layers->callback(options.ranks.single()) : RayCallback{};
        onRay = [layerCallback, extra](uint64_t i, const PathHistory& h) {
            if (layerCallback) layerCallback(i, h);
            if (extra) extra(i, h);
        };
    }
    const uint64_t total = spec.raysPerSource * ts.view.sources.size();
    TraceContinuation continuation;
    if (resumed) {
        const uint64_t block = std::max<uint64_t>(1, options.raysPerBlock);
        uint64_t lowest = resumed->added;
        if (resumed->hasLayers) {
            lowest = std::min(lowest, resumed->layersNextRay);
            result.layers->restore(resumed->layersNextRay, std::move(resumed->layers));
        }
        if (resumed->hasConsumer) lowest = std::min(lowest, resumed->consumer.nextRay);
        if (resumed->added > total)
            throw ParseError({"--resume", 0, 0},
                             spec.checkpoint.string() + ": is damaged (more rays than the run's)");
        continuation.start = lowest / block * block;
        result.resumedFromRay = continuation.start;
        continuation.added = resumed->added;
        continuation.budget = resumed->budget;
        continuation.images = std::move(resumed->images);
    }
    auto lastCheckpoint = std::chrono::steady_clock::now();
    if (checkpoints)
        continuation.afterBlock = [&](uint64_t added, const FluxBudget& b,
                                      const std::vector<DetectorImage>& images) {
            const auto now = std::chrono::steady_clock::now();
            if (added >= total || std::chrono::duration<double>(now - lastCheckpoint).count() <
                                      spec.checkpointSeconds)
                return;
            const ConsumerMark mark = spec.consumerMark ? spec.consumerMark() : ConsumerMark{};
            writeTraceCheckpoint(spec.checkpoint, fingerprint, added, b, images,
                                 result.layers.get(), spec.consumerMark ? &mark : nullptr);
            lastCheckpoint = now;
        };
    const auto start = std::chrono::steady_clock::now();
    std::function<void(uint64_t)> progress;
    if (spec.progress) {
        const std::string memory = "memory about " + gigabytes(result.memoryBytes);
        progress = [&spec, total, memory](uint64_t done) {
            ProgressEvent e("trace", done, total);
            e.state = memory;
            spec.progress(e);
        };
        progress(continuation.start);
    }
    TraceResult traced = traceNonsequential(ts.view, ts.images, spec.raysPerSource, options,
                                            progress, onRay, checkpoints ? &continuation : nullptr);
    if (result.layers) result.layers->finish(options.ranks);
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    result.budget = traced.budget;
    result.images = std::move(traced.detectors);
    return result;
}

nlohmann::json StrayLightResult::summary() const {
    nlohmann::json summary;
    const FluxBudget& b = budget;
    summary["scene"] = scene;
    summary["rays_per_source"] = raysPerSource;
    summary["seed"] = seed;
    summary["seconds"] = seconds;
    summary["unit"] = fluxUnit;
    summary["budget"] = {{"emitted", b.emitted},
                         {"detected", b.detected},
                         {"absorbed_surface", b.absorbedSurface},
                         {"absorbed_volume", b.absorbedVolume},
                         {"escaped", b.escaped},
                         {"culled", b.culled},
                         {"cut", b.cut},
                         {"dropped", b.dropped},
                         {"dropped_branches",
                          {{"no_refracted_direction", b.droppedBranches[0]},
                           {"no_scatter_direction", b.droppedBranches[1]}}},
                         {"roulette_gain", b.rouletteGain},
                         {"imbalance", b.imbalance()},
                         {"segments", b.segments},
                         {"branches", b.branches},
                         {"pruned_branches", b.prunedBranches}};
    summary["detectors"] = nlohmann::json::array();
    size_t d = 0;
    for (const StrayLightRow& row : report()) {
        if (row.layer.empty()) {
            nlohmann::json jd{{"name", row.detector},
                              {"object", detectorObjects[d++]},
                              {"flux", row.flux},
                              {"relative_error", jsonNumber(row.relativeError)}};
            if (layers) jd["by_criterion"] = nlohmann::json::array();
            summary["detectors"].push_back(jd);
            continue;
        }
        summary["detectors"].back()["by_criterion"].push_back(
            {{"layer", row.layer},
             {"criterion", row.criterion},
             {"flux", row.flux},
             {"relative_error", jsonNumber(row.relativeError)}});
    }
    return summary;
}

std::string StrayLightResult::text() const {
    const FluxBudget& b = budget;
    std::ostringstream text;
    text << "Flux budget (" << fluxUnit << ")\n";
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
    // Flux cut without roulette (--min-flux-cut, the split depth, the segments): what the
    // detectors may lack.
    if (b.cut > 0) line("  of which cut", b.cut);
    if (b.dropped > 0 || b.droppedBranches[0] + b.droppedBranches[1] > 0) {
        line("dropped", b.dropped);
        text << "    (" << b.droppedBranches[0] << " " << DropReason::NoRefractedDirection << ", "
             << b.droppedBranches[1] << " " << DropReason::NoScatterDirection << ")\n";
    }
    if (b.rouletteGain > 0) line("roulette gain", b.rouletteGain);
    if (prune) text << "  pruned " << b.prunedBranches << " branches (--prune)\n";
    text << "  imbalance " << std::scientific << b.imbalance() << " (relative "
         << (b.emitted > 0 ? b.imbalance() / b.emitted : 0.0) << ")\n";
    text << std::fixed << std::setprecision(1) << "  " << emittedRays << " rays, " << b.segments
         << " segments in " << seconds << " s (" << std::setprecision(0)
         << emittedRays / std::max(seconds, 1e-9) << " rays/s)\n\nDetectors\n";
    // A detector named apart from its object is shown with it: "sensor_image (on sensor)",
    // the object name veil rays and criteria use as well.
    size_t d = 0;
    for (const StrayLightRow& row : report()) {
        if (row.layer.empty()) {
            const std::string& object = detectorObjects[d++];
            text << "  " << row.detector << (object != row.detector ? " (on " + object + ")" : "")
                 << ": " << formatFlux(row.flux, row.relativeError, fluxUnit) << "\n";
            continue;
        }
        text << "    " << std::left << std::setw(8) << row.layer << std::right
             << formatFlux(row.flux, row.relativeError, fluxUnit) << "  " << row.criterion << "\n";
    }
    return text.str();
}

std::vector<std::pair<std::string, const DetectorImage*>> StrayLightResult::imageLayers(
    size_t d) const {
    std::vector<std::pair<std::string, const DetectorImage*>> out{
        {layers ? "all" : "", &images[d]}};
    const size_t n = layers ? layers->criterionCount() : 0;
    if (layers)
        for (size_t c = 0; c <= n; ++c)
            out.emplace_back(c < n ? "where" + std::to_string(c + 1) : "rest",
                             &layers->images()[c][d]);
    return out;
}

std::vector<std::filesystem::path> writeTraceFiles(const StrayLightResult& result,
                                                   const std::filesystem::path& dir,
                                                   const PreviewScale& scale) {
    std::vector<std::filesystem::path> written;
    std::filesystem::create_directories(dir);
    const uint64_t total = result.emittedRays;
    for (size_t d = 0; d < result.images.size(); ++d) {
        const DetectorImage& img = result.images[d];
        const std::string name = img.geometry().name;
        std::vector<ImageLayer> layers;
        for (const auto& [layer, image] : result.imageLayers(d)) layers.push_back({layer, image});
        const size_t n = result.layers ? result.layers->criterionCount() : 0;
        auto tag = [n](size_t c) { return c < n ? "where" + std::to_string(c + 1) : "rest"; };
        writeDetectorExr(dir / (name + ".exr"), layers, ExrInfo{result.fluxUnit, total});
        written.push_back(dir / (name + ".exr"));
        PreviewOptions po;
        po.fluxUnit = result.fluxUnit;
        po.emittedRays = total;
        po.scale = scale;
        // With criteria, all the light on the scale of the light they match: the light the
        // run asked for, which a source's image in the frame would otherwise black out.
        PreviewOptions all = po;
        DetectorImage asked(img.geometry());
        if (result.layers && n > 0) {
            for (size_t c = 0; c < n; ++c) asked.merge(result.layers->images()[c][d]);
            if (asked.totalFlux() > 0.0) {
                all.rangeImage = &asked;
                all.rangeName = n == 1 ? "--where light" : "--where criteria's light";
            }
        }
        writeDetectorPng(dir / (name + ".png"), img, all);
        written.push_back(dir / (name + ".png"));
        if (!result.layers) continue;
        for (size_t c = 0; c <= n; ++c) {
            PreviewOptions lp = po;
            lp.title = name + ": " + (c < n ? result.layers->text(c) : "none of the above");
            const std::filesystem::path png = dir / (name + "." + tag(c) + ".png");
            writeDetectorPng(png, result.layers->images()[c][d], lp);
            written.push_back(png);
        }
    }
    writeTextFile(dir / "summary.json", result.summary().dump(2) + "\n");
    written.push_back(dir / "summary.json");
    return written;
}

void runStrayLightBatches(const PreparedScene& scene, const StrayLightSpec& spec, int batches,
                          const std::function<void(int batch, const StrayLightResult&)>& onBatch) {
    const uint64_t n = static_cast<uint64_t>(batches);
    for (uint64_t b = 0; b < n; ++b) {
        StrayLightSpec run = spec;
        run.raysPerSource = spec.raysPerSource / n + (b < spec.raysPerSource % n ? 1 : 0);
        run.transport.seed = spec.transport.seed + b;
        onBatch(static_cast<int>(b), runStrayLight(scene, run));
    }
}

BatchMean batchMean(const std::vector<double>& v) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    if (v.empty()) return {nan, nan};
    double sum = 0.0;
    for (double x : v) sum += x;
    const double m = sum / static_cast<double>(v.size());
    if (v.size() < 2) return {m, nan};
    double ss = 0.0;
    for (double x : v) ss += (x - m) * (x - m);
    return {m, std::sqrt(ss / static_cast<double>(v.size() - 1) / static_cast<double>(v.size()))};
}

}  // namespace veil
