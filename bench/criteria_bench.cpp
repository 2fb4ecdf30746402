// The streaming three-state evaluator on recorded histories: events per second for criteria
// of about 5, 50 and 500 nodes.
//
//   build/bench/veil_criteria_bench --benchmark_min_time=2
//
// The paths are every complete path of 300 rays traced through the Sun scene
// (examples/scenes/longfocus_360mm_sun.toml, split mode): about a million paths of ghosts,
// scatter and refraction. The criteria are random trees (fixed seed) of and / or / not / seq
// over the scene's lens faces, mechanics and sensor, with counts. For each path the evaluator
// is reset and fed events until it decides (or the path ends); the rate counts the events
// actually pushed. BM_EventScan is the baseline measured in the same process: reading the
// same events and testing one leaf's object set per event, the least work per event any
// criterion can cost.

#include <benchmark/benchmark.h>

#include <map>
#include <mutex>
#include <random>

#include "analysis/criteria/criteria.h"
#include "analysis/criteria/criterion_names.h"
#include "lensdata/glass_catalog.h"
#include "tracer/records/path_history.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/scene/scene_transport.h"

namespace {

using namespace veil;

struct Fixture {
    NameTable names;
    std::vector<std::vector<PathEvent>> paths;
};

const Fixture& recorded() {
    static const std::unique_ptr<Fixture> f = [] {
        const GlassCatalog& catalog = GlassCatalog::builtIn();
        auto fx = std::make_unique<Fixture>();
        const SceneSpec file =
            readSceneFile(VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml", catalog);
        const SceneGeometry setup = buildSceneGeometry(file, catalog);
        const SceneTransport ts = prepareTransport(file, setup, catalog);
        fx->names = criterionNames(setup.scene, ts.view);
        TransportOptions o;
        o.recordHistories = true;
        std::mutex m;
        std::map<uint64_t, std::vector<std::vector<PathEvent>>> byRay;
        traceNonsequential(ts.view, ts.images, 300, o, {},
                           [&](uint64_t i, const PathHistory& h) {
                               std::vector<std::vector<PathEvent>> paths;
                               h.forEachPath([&](const PathView& v) {
                                   std::vector<PathEvent> ev;
                                   for (size_t k = 0; k < v.size(); ++k) ev.push_back(v.event(k));
                                   paths.push_back(std::move(ev));
                               });
                               std::lock_guard<std::mutex> lock(m);
                               byRay[i] = std::move(paths);
                           });
        for (auto& [i, ps] : byRay)
            for (auto& p : ps) fx->paths.push_back(std::move(p));
        return fx;
    }();
    return *f;
}

// A random criterion text with about `leaves` leaves.
std::string randomCriterion(std::mt19937_64& rng, int leaves) {
    static const char* kLeaves[] = {"fresnel(L4.back)", "fresnel(L4.front)", "refract(L*.front)",
                                    "reflect(L2.*)",    "scatter(barrel)",   "scatter(spacer*)",
                                    "hit(sensor)",      "tir(L*)",           "scatter(stop.edge)",
                                    "refract(L6.back)", "fresnel(*){2,}",    "hit(retainer*){,1}"};
    if (leaves <= 1) return kLeaves[rng() % std::size(kLeaves)];
    const int k = 2 + static_cast<int>(rng() % 3);
    std::string op;
    switch (rng() % 4) {
        case 0:
            op = " and ";
            break;
        case 1:
            op = " or ";
            break;
        default:
            op = ", ";
            break;  // seq
    }
    std::string s = op == ", " ? "seq(" : "(";
    for (int i = 0; i < k; ++i) {
        if (i) s += op;
        std::string child = randomCriterion(rng, leaves / k);
        if (rng() % 8 == 0) child = "not " + child;
        s += child;
    }
    return s + ")";
}

void BM_Evaluate(benchmark::State& state) {
    const Fixture& f = recorded();
    std::mt19937_64 rng(42);
    // Keep drawing until the tree has roughly the wanted number of nodes.
    CompiledCriterion c;
    const int target = static_cast<int>(state.range(0));
    for (int tries = 0; tries < 1000; ++tries) {
        c = compile(parseCriterion(randomCriterion(rng, target / 2 + 1)), f.names);
        if (static_cast<int>(c.nodes.size()) >= target * 4 / 5 &&
            static_cast<int>(c.nodes.size()) <= target * 6 / 5)
            break;
    }
    StreamingEvaluator ev(c);
    double events = 0, matched = 0;
    for (auto _ : state) {
        for (const auto& p : f.paths) {
            ev.reset();
            size_t k = 0;
            for (; k < p.size() && !ev.decided(); ++k) ev.push(p[k]);
            events += static_cast<double>(k);
            matched += ev.finish() == CriterionState::True;
        }
    }
    state.counters["nodes"] = static_cast<double>(c.nodes.size());
    state.counters["events_per_s"] = benchmark::Counter(events, benchmark::Counter::kIsRate);
    state.counters["match_fraction"] =
        matched / (static_cast<double>(state.iterations()) * f.paths.size());
}
BENCHMARK(BM_Evaluate)->Arg(5)->Arg(50)->Arg(500)->Unit(benchmark::kMillisecond);

void BM_EventScan(benchmark::State& state) {
    const Fixture& f = recorded();
    const CompiledCriterion c = compile(parseCriterion("hit(sensor)"), f.names);
    double events = 0, hits = 0;
    for (auto _ : state) {
        for (const auto& p : f.paths) {
            for (const PathEvent& e : p) hits += c.leaves[0].matches(e);
            events += static_cast<double>(p.size());
        }
    }
    benchmark::DoNotOptimize(hits);
    state.counters["events_per_s"] = benchmark::Counter(events, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_EventScan)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
