// Small kernels whose cost tests used to assert (a test must not time anything): the even
// asphere's bounded work on pathological input, the path-history byte encoding, and parsing
// the built-in glass catalog at program start. Each reports a rate next to a baseline
// measured in the same process, so the ratio carries from machine to machine.
//
//   build/bench/veil_kernels_bench --benchmark_min_time=1
//
// BM_PathologicalAsphere/k: intersectSequential + intersectFirst on the cases of
//   tests/geometry/surface_shape_test.cpp (PathologicalAspheresEndWithoutLooping): k = 0 a NaN
//   coefficient, 1 coefficients up to 1e30 over an infinite range, 2 a ray touching a quartic
//   bowl at its vertex. Baseline BM_TypicalAsphere: the same two calls on lens-like even
//   aspheres (r^4 to r^10 terms, sag up to ~1 mm over 10 mm). Their ratio is what a give-up
//   costs against an ordinary hit.
// BM_Anamorphic/k: the same two calls on lens-like biconic (k = 0), toroidal (1) and
//   cylindrical (2) surfaces, against the same baseline: what the interval search of an
//   anamorphic surface costs against an asphere's.
// BM_EncodeHistories / BM_DecodeHistories: events/s through encodeHistory / decodeHistory
//   (float32 positions and directions, the ray database's default) on real histories: the
//   seed's 360 mm lens in its barrel with the Sun 7 degrees off axis
//   (examples/scenes/longfocus_360mm_sun.toml), split mode. Baseline BM_CopyHistories: copying
//   the same histories node by node in memory.
// BM_ParseBuiltInGlassCatalog: bytes/s of the embedded AGF text (1496 glasses) into a
//   GlassCatalog. Baseline BM_ScanGlassText: the same text split into lines and blank-
//   separated tokens, every token read with strtod: the least a parser must do.

#include <benchmark/benchmark.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <random>
#include <string_view>
#include <vector>

#include "geometry/surface_shape.h"
#include "lensdata/glass_catalog.h"
#include "tracer/records/path_history.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/scene/scene_transport.h"

namespace veil::detail {
extern const char kBuiltinGlassData[];
extern const unsigned long kBuiltinGlassDataSize;
}  // namespace veil::detail

namespace {

using namespace veil;

constexpr double kInf = std::numeric_limits<double>::infinity();

// Even Aspheres

struct AsphereCase {
    SurfaceShape shape;
    Ray ray;            // local frame
    double tMin = 0.0;  // intersectFirst's range starts here
};

std::vector<AsphereCase> pathologicalAspheres() {
    const Ray ray{{0.3, 0.2, -10}, glm::normalize(Vec3(0.1, 0.05, 1.0))};
    EvenAsphereShape nan{0.01, 0.0, {}};
    nan.coefficients[2] = std::numeric_limits<double>::quiet_NaN();
    EvenAsphereShape wild{0.01, -1.0, {}};
    wild.coefficients = {1e3, -1e6, 1e9, -1e12, 1e15, -1e18, 1e21, -1e24, 1e27, -1e30};
    EvenAsphereShape bowl{0.0, 0.0, {}};
    bowl.coefficients[1] = 1e-3;
    return {{nan, ray, 0.0}, {wild, ray, -kInf}, {bowl, {{-5, 0, 0}, {1, 0, 0}}, 0.0}};
}

// Lens-like aspheres: radius 20 to 100 mm, conic -2 to 0, A4 to A10 giving up to ~0.1 mm
// at r = 10 mm each, crossed by rays within 10 mm of the axis at up to ~20 degrees.
std::vector<AsphereCase> typicalAspheres() {
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<AsphereCase> cases;
    for (int i = 0; i < 256; ++i) {
        EvenAsphereShape a{1.0 / (60.0 + 40.0 * u(rng)), -1.0 + u(rng), {}};
        for (int k = 1; k <= 4; ++k) a.coefficients[k] = 0.1 * u(rng) / std::pow(10.0, 2 * k + 2);
        const Vec3 o(10.0 * u(rng), 10.0 * u(rng), -5.0);
        const Vec3 d = glm::normalize(Vec3(0.3 * u(rng), 0.3 * u(rng), 1.0));
        cases.push_back({a, {o, d}});
    }
    return cases;
}

void runAspheres(benchmark::State& state, const std::vector<AsphereCase>& cases) {
    long long calls = 0, hits = 0;
    for (auto _ : state) {
        for (const AsphereCase& c : cases) {
            const auto t = intersectSequential(c.shape, c.ray);
            const auto h = intersectFirst(c.shape, c.ray, c.tMin, kInf, kInf, false);
            benchmark::DoNotOptimize(t);
            benchmark::DoNotOptimize(h);
            calls += 2;
            hits += t.has_value() + h.has_value();
        }
    }
    state.counters["intersections_per_s"] =
        benchmark::Counter(static_cast<double>(calls), benchmark::Counter::kIsRate);
    state.counters["hit_fraction"] = static_cast<double>(hits) / std::max(calls, 1LL);
}

void BM_PathologicalAsphere(benchmark::State& state) {
    const AsphereCase c = pathologicalAspheres()[state.range(0)];
    static const char* kLabels[] = {"NaN coefficient", "coefficients to 1e30",
                                    "touching quartic bowl"};
    state.SetLabel(kLabels[state.range(0)]);
    runAspheres(state, {c});
}
BENCHMARK(BM_PathologicalAsphere)->DenseRange(0, 2)->Unit(benchmark::kMicrosecond);

void BM_TypicalAsphere(benchmark::State& state) {
    static const std::vector<AsphereCase> cases = typicalAspheres();
    runAspheres(state, cases);
}
BENCHMARK(BM_TypicalAsphere)->Unit(benchmark::kMicrosecond);

// Lens-like anamorphic surfaces, crossed by the same kind of rays as the typical aspheres:
// k = 0 biconics (x and y radii 20 to 100 mm, conics -2 to 0), 1 toroids (profile radius and
// radius of rotation 20 to 100 mm, y^4 to y^10 terms as the aspheres'), 2 cylinders (a
// toroid with an infinite radius of rotation).
void BM_Anamorphic(benchmark::State& state) {
    static const char* kLabels[] = {"biconic", "toroid", "cylinder"};
    const int kind = static_cast<int>(state.range(0));
    state.SetLabel(kLabels[kind]);
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    std::vector<AsphereCase> cases;
    for (int i = 0; i < 256; ++i) {
        const double cy = 1.0 / (60.0 + 40.0 * u(rng)), cx = 1.0 / (60.0 + 40.0 * u(rng));
        SurfaceShape shape;
        if (kind == 0) {
            shape = BiconicShape{cx, -1.0 + u(rng), cy, -1.0 + u(rng)};
        } else {
            ToroidalShape t{cy, -1.0 + u(rng), {}, kind == 1 ? cx : 0.0};
            if (kind == 1)
                for (int k = 1; k <= 4; ++k)
                    t.yCoefficients[k] = 0.1 * u(rng) / std::pow(10.0, 2 * k + 2);
            shape = t;
        }
        const Vec3 o(10.0 * u(rng), 10.0 * u(rng), -5.0);
        const Vec3 d = glm::normalize(Vec3(0.3 * u(rng), 0.3 * u(rng), 1.0));
        cases.push_back({shape, {o, d}});
    }
    runAspheres(state, cases);
}
BENCHMARK(BM_Anamorphic)->DenseRange(0, 2)->Unit(benchmark::kMicrosecond);

// Path Histories

struct Histories {
    std::vector<PathHistory> histories;
    size_t events = 0;
    std::vector<uint8_t> bytes;  // all of them encoded back to back
};

const PathEncoding kEncoding{true, true, false};

const Histories& sunHistories() {
    static const Histories h = [] {
        const GlassCatalog& catalog = GlassCatalog::builtIn();
        const SceneSpec file =
            readSceneFile(VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml", catalog);
        const SceneGeometry setup = buildSceneGeometry(file, catalog);
        const SceneTransport trace = prepareTransport(file, setup, catalog);
        TransportOptions o;
        o.seed = 3;
        o.recordHistories = true;
        const uint64_t rays = 500;  // ~0.9 million events
        Histories out;
        out.histories.resize(rays);
        // onRay runs on worker threads, each ray once: ray i writes slot i only.
        traceNonsequential(trace.view, trace.images, rays, o, {},
                           [&](uint64_t i, const PathHistory& ph) { out.histories[i] = ph; });
        for (const PathHistory& ph : out.histories) {
            out.events += ph.size();
            encodeHistory(ph, kEncoding, out.bytes);
        }
        return out;
    }();
    return h;
}

void BM_EncodeHistories(benchmark::State& state) {
    const Histories& h = sunHistories();
    std::vector<uint8_t> bytes;
    bytes.reserve(h.bytes.size());
    double events = 0;
    for (auto _ : state) {
        bytes.clear();
        for (const PathHistory& ph : h.histories) encodeHistory(ph, kEncoding, bytes);
        benchmark::DoNotOptimize(bytes.data());
        events += static_cast<double>(h.events);
    }
    state.counters["events_per_s"] = benchmark::Counter(events, benchmark::Counter::kIsRate);
    state.counters["bytes_per_event"] = static_cast<double>(h.bytes.size()) / h.events;
    state.counters["events"] = static_cast<double>(h.events);
}
BENCHMARK(BM_EncodeHistories)->Unit(benchmark::kMillisecond);

void BM_DecodeHistories(benchmark::State& state) {
    const Histories& h = sunHistories();
    PathHistory out;
    double events = 0;
    for (auto _ : state) {
        size_t pos = 0, decoded = 0;
        while (pos < h.bytes.size()) {
            decodeHistory(h.bytes, pos, kEncoding, out);
            decoded += out.size();
        }
        if (decoded != h.events) state.SkipWithError("decoded a different number of events");
        events += static_cast<double>(decoded);
    }
    state.counters["events_per_s"] = benchmark::Counter(events, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_DecodeHistories)->Unit(benchmark::kMillisecond);

void BM_CopyHistories(benchmark::State& state) {
    const Histories& h = sunHistories();
    std::vector<PathHistory> copies(h.histories.size());
    double events = 0;
    for (auto _ : state) {
        for (size_t i = 0; i < h.histories.size(); ++i) copies[i] = h.histories[i];
        benchmark::DoNotOptimize(copies.data());
        events += static_cast<double>(h.events);
    }
    state.counters["events_per_s"] = benchmark::Counter(events, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_CopyHistories)->Unit(benchmark::kMillisecond);

// Glass Catalog

std::string_view builtInGlassText() {
    return {detail::kBuiltinGlassData, detail::kBuiltinGlassDataSize};
}

void BM_ParseBuiltInGlassCatalog(benchmark::State& state) {
    const std::string_view text = builtInGlassText();
    for (auto _ : state) {
        GlassCatalog c;
        c.loadAgfText(text, "<built-in glass data>", "BUILTIN");
        if (c.size() != 1496) state.SkipWithError("the built-in catalog holds 1496 glasses");
        benchmark::DoNotOptimize(c);
    }
    state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * text.size()));
}
BENCHMARK(BM_ParseBuiltInGlassCatalog)->Unit(benchmark::kMillisecond);

void BM_ScanGlassText(benchmark::State& state) {
    const std::string_view text = builtInGlassText();
    std::string line;
    for (auto _ : state) {
        double sum = 0.0;
        size_t start = 0;
        while (start < text.size()) {
            size_t end = text.find('\n', start);
            if (end == std::string_view::npos) end = text.size();
            line.assign(text.substr(start, end - start));  // strtod needs a terminator
            const char* p = line.c_str();
            while (*p) {
                char* next = nullptr;
                const double v = std::strtod(p, &next);
                if (next == p) {
                    while (*p && *p != ' ' && *p != '\t') ++p;  // not a number: skip the word
                    while (*p == ' ' || *p == '\t') ++p;
                } else {
                    sum += v;
                    p = next;
                }
            }
            start = end + 1;
        }
        benchmark::DoNotOptimize(sum);
    }
    state.SetBytesProcessed(static_cast<int64_t>(state.iterations() * text.size()));
}
BENCHMARK(BM_ScanGlassText)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
