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
// gives bitwise the same images with any number of threads. A run writing into a folder keeps
// DIR/trace.checkpoint (at most every --checkpoint-every seconds, removed once the run is
// whole): `veil trace SCENE -n RAYS --resume DIR` goes on after a kill, to the same files.

#include "cli/trace_command.h"

#include <filesystem>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "analysis/runs/ray_statistics.h"
#include "analysis/runs/saved_rays.h"
#include "cli/progress.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/output_file.h"
#include "tracer/records/path_history.h"
#include "tracer/records/ray_database.h"
#include "tracer/runtime/ranks.h"
#include "tracer/scene/prepared_scene.h"

namespace veil::cli {

namespace {
constexpr const char* kTraceCheckpoint = "trace.checkpoint";  // in the run's folder
}  // namespace

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
    addPreviewFlags(sub, o.preview);
    addMaxMemory(sub, o.maxMemory, "trace");
    sub->add_option("--resume", o.resume,
                    "go on with the killed run in this folder (its trace.checkpoint): same scene "
                    "and options; the files come out as the run would have written them");
    sub->add_option("--checkpoint-every", o.checkpointSeconds,
                    "seconds between the run's checkpoints in its folder (after a block of rays; "
                    "0: after every block)")
        ->check(CLI::Range(0.0, 1e9))
        ->capture_default_str();
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
    // Criteria are compiled (and their errors raised) before any record is read.
    std::vector<CriterionFlux> split;
    if (!o.where.empty()) split = criterionFluxes(reader, o.where);
    const RayStatistics s = rayStatistics(reader);
    if (o.json)
        std::cout << rayStatisticsJson(reader.info(), s, split).dump(2) << "\n";
    else
        std::cout << rayStatisticsText(o.file, reader.info(), s, split);
    return 0;
}

// The trace's spec from the options, checked before the scene is read.
StrayLightSpec traceSpec(const TraceOptions& o) {
    if (o.prune && o.where.empty())
        throw ParseError({"--prune", 0, 0}, "--prune needs at least one --where");
    if (o.eventsOnly && o.saveRays.empty())
        throw ParseError({"--events-only", 0, 0}, "--events-only needs --save-rays FILE");
    StrayLightSpec spec;
    spec.scene = o.file;
    spec.raysPerSource = o.rays;
    applyTransportFlags(o.transport, spec.transport);
    spec.transport.seed = o.seed;
    // Under mpirun the rays split over the ranks; rank 0 writes everything (docs/scaling.md).
    spec.transport.ranks = Ranks::world();
    if (!spec.transport.ranks.single() && !o.saveRays.empty())
        throw ParseError({"--save-rays " + o.saveRays, 0, 0},
                         "the ray database is written by one process: run veil trace "
                         "--save-rays without mpirun");
    spec.where = o.where;
    spec.prune = o.prune;
    spec.maxMemoryBytes = static_cast<double>(o.maxMemory);
    spec.checkpointSeconds = o.checkpointSeconds;
    if (!o.resume.empty()) {
        if (!spec.transport.ranks.single())
            throw ParseError({"--resume " + o.resume, 0, 0},
                             "a trace goes on in one process: run it without mpirun");
        if (!std::filesystem::exists(std::filesystem::path(o.resume) / kTraceCheckpoint))
            throw ParseError({"--resume " + o.resume, 0, 0},
                             "holds no " + std::string(kTraceCheckpoint) + " to go on from");
        if (!o.output.empty() && std::filesystem::weakly_canonical(o.output) !=
                                     std::filesystem::weakly_canonical(o.resume))
            throw ParseError({"--resume " + o.resume, 0, 0},
                             "the run goes on in its own folder: leave out -o " + o.output);
        spec.resume = true;
    }
    if (!o.saveRays.empty()) {
        // A file veil may create, before the sample traced to size it.
        if (std::filesystem::is_directory(o.saveRays))
            throw ParseError({"--save-rays " + o.saveRays, 0, 0},
                             "is a folder: give the ray database's file name");
        const std::filesystem::path parent = std::filesystem::path(o.saveRays).parent_path();
        requireWritableFolder(parent.empty() ? "." : parent, "--save-rays", o.saveRays);
    }
    return spec;
}

namespace {

PathEncoding rayEncoding(const TraceOptions& o) {
    if (o.eventsOnly) return PathEncoding{};
    return PathEncoding{.positions = true, .directions = true, .doublePrecision = false};
}

// The ray database, sized before tracing (a run whose database would not fit stops here) and
// opened once the run's spec has been checked, just before the first ray; a resumed run's
// goes on from its checkpoint's mark.
std::unique_ptr<RayDatabaseWriter> openRayDatabase(const PreparedScene& scene,
                                                   const TraceOptions& o,
                                                   const RayDatabaseMark* mark) {
    const std::filesystem::path parent = std::filesystem::path(o.saveRays).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent);
    RayDatabaseInfo info = rayDatabaseInfo(scene, o.file, rayEncoding(o), o.seed);
    if (mark)
        return std::make_unique<RayDatabaseWriter>(o.saveRays, std::move(info),
                                                   RayDatabaseOptions{}, *mark);
    return std::make_unique<RayDatabaseWriter>(o.saveRays, std::move(info));
}

// The ray database's mark as a checkpoint holds it, and back.
std::string encodeMark(const RayDatabaseMark& m) {
    ByteWriter w;
    w.put(m.bytes);
    w.put(m.nextRay);
    w.putVector(m.index);
    w.put(m.summary);
    w.put(static_cast<uint8_t>(m.anyRay));
    w.put(m.highest);
    const Bytes b = w.take();
    return std::string(reinterpret_cast<const char*>(b.data()), b.size());
}
RayDatabaseMark decodeMark(const std::string& text, const std::filesystem::path& checkpoint) {
    const Bytes b(reinterpret_cast<const std::byte*>(text.data()),
                  reinterpret_cast<const std::byte*>(text.data()) + text.size());
    try {
        ByteReader r(b);
        RayDatabaseMark m;
        m.bytes = r.get<uint64_t>();
        m.nextRay = r.get<uint64_t>();
        m.index = r.getVector<RayDatabaseChunk>();
        m.summary = r.get<RayDatabaseSummary>();
        m.anyRay = r.get<uint8_t>() != 0;
        m.highest = r.get<uint64_t>();
        if (!r.done()) throw std::runtime_error("trailing bytes");
        return m;
    } catch (const std::exception&) {
        throw ParseError({"--resume", 0, 0},
                         checkpoint.string() + ": its ray database mark is damaged");
    }
}

}  // namespace

std::string checkRayDatabase(const PreparedScene& scene, const StrayLightSpec& spec,
                             const TraceOptions& o) {
    if (o.saveRays.empty()) return "";
    const RayDatabaseEstimate e =
        estimateRayDatabase(scene.transport(), spec.transport, o.rays, rayEncoding(o));
    e.checkFits(o.saveRays);
    return e.note(o.saveRays, rayEncoding(o));
}

TraceCommandRun traceIntoFolder(const PreparedScene& scene, StrayLightSpec spec,
                                const TraceOptions& o, const std::filesystem::path& dir) {
    const bool root = spec.transport.ranks.root();
    // Once the spec is checked (criteria included), just before the first ray, the folder's
    // older run gives way (WrittenFiles::beginRun) and the ray database opens.
    WrittenFiles written;
    std::unique_ptr<RayDatabaseWriter> db;
    const bool resume = !o.resume.empty();
    const std::filesystem::path checkpoint = dir.empty() ? dir : dir / kTraceCheckpoint;
    // One process writes checkpoints into the run's folder; a resumed run goes on from it.
    if (!dir.empty() && spec.transport.ranks.single()) spec.checkpoint = checkpoint;
    std::optional<RayDatabaseMark> mark;
    if (!o.saveRays.empty()) {
        spec.consumerKey = "--save-rays " + o.saveRays + (o.eventsOnly ? " --events-only" : "");
        spec.consumerMark = [&]() {
            const RayDatabaseMark m = db->mark();
            return ConsumerMark{m.nextRay, encodeMark(m)};
        };
        spec.restoreConsumer = [&](const ConsumerMark& m) {
            mark = decodeMark(m.bytes, checkpoint);
        };
    }
    spec.openConsumer = [&]() -> RayCallback {
        if (!root) return {};
        // A resumed run keeps the folder's files and its ray database's partial file.
        std::vector<std::filesystem::path> keep;
        if (resume && !o.saveRays.empty()) keep.push_back(o.saveRays + ".partial");
        written.beginRun(dir, resume, keep);
        if (!resume && !checkpoint.empty()) removeQuietly(checkpoint);  // an older run's
        if (o.saveRays.empty()) return {};
        db = openRayDatabase(scene, o, mark ? &*mark : nullptr);
        return [&db](uint64_t i, const PathHistory& h) { db->add(i, h); };
    };
    const auto limit = limitThreads(o.threads);
    TraceCommandRun out{runStrayLight(scene, spec), {}};
    if (!root) return out;  // its share went to rank 0
    if (db) {
        db->setEmittedRays(out.result.emittedRays);
        db->close();
        written.add(o.saveRays);
    }
    if (!dir.empty())
        for (const std::filesystem::path& f :
             writeTraceFiles(out.result, dir, previewScale(o.preview)))
            written.add(f);
    if (!checkpoint.empty()) removeQuietly(checkpoint);  // the run is whole
    written.finishRun();
    out.written = std::move(written);
    return out;
}

int runTrace(const CommonOptions& common, const TraceOptions& o) {
    StrayLightSpec spec = traceSpec(o);
    const bool root = spec.transport.ranks.root();
    const GlassCatalog catalog = loadCatalog(common);
    const std::unique_ptr<const PreparedScene> prepared =
        prepareTracedScene(common, o.file, o.fields, catalog);
    reportSceneNotes(*prepared);
    const std::filesystem::path dir =
        outputFolder(o.output.empty() ? o.resume : o.output, "trace", o.json);
    const std::string note = checkRayDatabase(*prepared, spec, o);
    if (!note.empty() && !o.quiet) std::cerr << "veil: --save-rays: " << note << "\n";
    ProgressReporter reporter;
    if (!o.quiet && root) spec.progress = reporter.sink();
    const TraceCommandRun run = traceIntoFolder(*prepared, std::move(spec), o, dir);
    if (!root) return 0;
    reporter.finish();
    const StrayLightResult& result = run.result;
    if (!o.resume.empty())
        std::cerr << "veil: went on from ray " << result.resumedFromRay << " of "
                  << result.emittedRays << " (the rays before it from "
                  << (std::filesystem::path(o.resume) / kTraceCheckpoint).string() << ")\n";
    if (o.prune && result.budget.prunedBranches == 0)
        std::cerr << "veil: warning: --prune stopped no branch: no --where criterion turned false "
                     "before its path ended (seq(...), hit(...) and counts without an upper "
                     "bound can only fail when a path ends; not, {0,1}-style counts and "
                     "detector(...) can end a branch early), so the run cost the same\n";
    if (o.json) {
        nlohmann::json summary = result.summary();
        summary["files"] = run.written.json();
        std::cout << summary.dump(2) << "\n";
        return 0;
    }
    std::cout << result.text();
    if (!o.quiet) {
        std::cout << "\n";
        run.written.print(std::cout);
    }
    return 0;
}

}  // namespace veil::cli
