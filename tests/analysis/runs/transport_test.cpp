// Nonsequential transport on real scenes: the flux budget closes, a plane-parallel window
// transmits the analytic irradiance, and any thread count gives bitwise the same images.

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <memory>
#include <sstream>
#include <variant>

#include "analysis/criteria/criterion_images.h"
#include "analysis/criteria/criterion_names.h"
#include "analysis/runs/ray_statistics.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tests/analysis/prepared_scene.h"
#include "tracer/records/detector.h"
#include "tracer/records/path_history.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {
namespace {

using test::prepare;
using test::Prepared;
using test::writeScene;

const std::string kLenses = VEIL_SOURCE_DIR "/examples/lenses/";

// Splitting without culling loses nothing: emitted = detected + absorbed + escaped + culled
// to 1e-12, here through the double Gauss in its barrel (uncoated faces, ground-glass edges,
// 5 % Lambertian mechanics), with glass absorption where the catalog has it.
TEST(Transport, FluxBudgetClosesInSplitMode) {
    const auto path = writeScene("budget", "lens = \"" + kLenses + "longfocus_360mm.toml\"\n" + R"(
[mechanics]
property = "mount"
[properties.mount]
scatter = { model = "lambertian", reflectance = 0.05 }
[[source]]
kind = "sun"
field_deg = [0.0, 3.0]
)");
    Prepared r = prepare(path);
    TransportOptions o;
    o.minRelativeFlux = 1e-3;
    o.seed = 3;
    const uint64_t n = 2000;
    const TraceResult res = traceNonsequential(r.trace.view, r.trace.images, n, o);
    const FluxBudget& b = res.budget;
    // Emission is exact: every ray of a watt source sampled radiometrically carries
    // totalFlux / n, so n rays emit the total to rounding. The default sun beam is normalised
    // to 1 W through the aperture disk (radius a, seen at 3 deg): its start disk (radius
    // rb >= a) carries 1 W * rb^2 / (a^2 cos 3 deg).
    ASSERT_EQ(r.trace.view.sources.size(), 1u);
    const Source& sun = r.trace.view.sources[0];
    const Beam& beam = std::get<SunSource>(sun.shape()).beam;
    EXPECT_EQ(b.rays, n);
    EXPECT_NEAR(b.emitted, sun.totalFlux(), 1e-12 * sun.totalFlux());
    const double cos3 = std::cos(3.0 * M_PI / 180.0);
    const double normalised = std::pow(beam.radiusMm / beam.apertureRadiusMm, 2) / cos3;
    EXPECT_NEAR(b.emitted, normalised, 1e-12 * normalised) << beam;
    EXPECT_GT(b.detected, 0.3);
    EXPECT_GT(b.absorbedVolume, 0.0);  // the catalog glasses absorb a little
    EXPECT_LT(std::abs(b.imbalance()), 1e-12 * b.emitted) << b;
    double imageSum = 0.0;
    for (double f : res.detectors[0].fluxes()) imageSum += f;
    EXPECT_NEAR(imageSum, res.detectors[0].totalFlux(), 1e-12);
    EXPECT_NEAR(res.detectors[0].totalFlux(), b.detected, 1e-12);  // one detector
}

// A collimated beam at normal incidence through a plane-parallel plate (index nd, no
// absorption, uncoated): the irradiance behind it is E0 (1 - R)^2 (1 + R^2 + R^4 + ...)
// = E0 (1 - R) / (1 + R), R = ((n - 1)/(n + 1))^2, with E0 = 1 W / (pi r^2) for the
// normalised beam over the plate's 10 mm aperture. Checked with a z-score.
struct WindowCase {
    const char* name;
    TransportOptions::Mode mode;
    double roulette;
};
void PrintTo(const WindowCase& c, std::ostream* os) { *os << c.name; }  // in failure messages

struct WindowRun {
    Prepared scene;
    TraceResult result;
    double e0 = 0.0;  // W/mm^2 in front of the plate
};

// The plate, 5 mm thick, in front of an 8 x 8 mm detector of 16 x 16 pixels, traced with n
// rays. `name` keeps the scene files of concurrently running tests apart.
WindowRun traceWindow(const std::string& name, double nd, const TransportOptions& o, uint64_t n) {
    std::ostringstream text;
    text << std::setprecision(17) << R"(
[system]
aperture = { epd_mm = 10 }
surfaces = [
  { r = 0, t = 5, glass = { nd = )"
         << nd << R"(, vd = 0 }, sd = 10, stop = true },
  { r = 0, t = 20, sd = 10 },
]
[[source]]
kind = "collimated"
field_deg = 0.0
[detector]
size_mm = [8.0, 8.0]
pixels = [16, 16]
)";
    WindowRun w;
    w.scene = prepare(writeScene(name, text.str()));
    w.result = traceNonsequential(w.scene.trace.view, w.scene.trace.images, n, o);
    w.e0 = 1.0 / (M_PI * 100.0);
    return w;
}

class WindowIrradiance : public ::testing::TestWithParam<WindowCase> {};

// Split mode, random branch choice and Russian roulette are all unbiased: each gives the
// analytic irradiance within its Monte Carlo error.
TEST_P(WindowIrradiance, MatchesTheAnalyticValue) {
    TransportOptions o;
    o.minRelativeFlux = 1e-14;  // keep the inter-reflections down to R^6
    o.seed = 11;
    o.mode = GetParam().mode;
    o.rouletteRelativeFlux = GetParam().roulette;
    const uint64_t n = 200000;
    const WindowRun w = traceWindow(std::string("window_") + GetParam().name, 1.5, o, n);
    const TraceResult& res = w.result;
    const double R = std::pow(0.5 / 2.5, 2);
    const double expected = w.e0 * (1.0 - R) / (1.0 + R) * 64.0;  // over the 8 x 8 mm detector
    const DetectorImage& img = res.detectors[0];
    const double sigma = img.totalRelativeError(n) * img.totalFlux();
    EXPECT_LT(std::abs(img.totalFlux() - expected), 5.0 * sigma)
        << "flux " << img.totalFlux() << " expected " << expected << " sigma " << sigma;
    EXPECT_LT(sigma, 0.02 * expected);  // the test has power: 2 % or better
    EXPECT_LT(std::abs(res.budget.imbalance()), 1e-12);
    if (GetParam().roulette > 0.0) {
        EXPECT_GT(res.budget.rouletteGain, 0.0);
    }
    // Every pixel sees the same irradiance (chi-square over the 256 pixels).
    double chi2 = 0.0;
    for (int p = 0; p < img.geometry().pixelCount(); ++p) {
        const double mean = expected / img.geometry().pixelCount();
        const double var = img.pixelVariance(p, n);
        ASSERT_GT(var, 0.0);
        chi2 += std::pow(img.flux(p) - mean, 2) / var;
    }
    EXPECT_LT(chi2, 256.0 + 5.0 * std::sqrt(2.0 * 256.0));
}

INSTANTIATE_TEST_SUITE_P(
    Modes, WindowIrradiance,
    ::testing::Values(WindowCase{"split", TransportOptions::Mode::Split, 0.0},
                      WindowCase{"random", TransportOptions::Mode::Random, 0.0},
                      WindowCase{"roulette", TransportOptions::Mode::Split, 0.5}),
    [](const ::testing::TestParamInfo<WindowCase>& i) { return i.param.name; });

// At n = 1.5 (R = 0.04) the inter-reflections add R^2 = 0.16 % to the single pass, far below
// the test's 2 % resolution: it could not tell (1 - R)/(1 + R) from (1 - R)^2. A
// germanium-like plate, n = 4 and absorption-free, has R = 0.36: the series gives
// (1 - R)/(1 + R) = 0.4706 against 0.4096 for light that crosses once, 13 % apart. With a
// relative sigma below 1 % the estimate must lie within 4 sigma of the first and more than
// 5 sigma from the second. Split mode sums the series branch by branch; random mode samples
// it (a ray goes back and forth with probability R at every face), so both are checked.
class HighIndexWindow : public ::testing::TestWithParam<WindowCase> {};

TEST_P(HighIndexWindow, ResolvesTheInterReflections) {
    TransportOptions o;
    // Split mode: the branch inside the plate carries (1 - R) R^m and is culled below 1e-10,
    // after m = 22 reflections: what is lost is R^22 ~ 2e-10 of the result.
    o.minRelativeFlux = 1e-10;
    o.seed = 12;
    o.mode = GetParam().mode;
    o.rouletteRelativeFlux = GetParam().roulette;
    // Split mode follows ~47 segments per ray; random mode ~3 but with more variance. Both
    // give a relative sigma near 0.6 % (the geometric part: 20 % of the beam lands on the
    // detector; the random part: 47 % of those get through).
    const uint64_t n = GetParam().mode == TransportOptions::Mode::Split ? 100000 : 200000;
    const double nd = 4.0;
    const WindowRun w = traceWindow(std::string("window_n4_") + GetParam().name, nd, o, n);
    const double R = std::pow((nd - 1.0) / (nd + 1.0), 2);
    const double area = 64.0;  // the 8 x 8 mm detector, inside the beam
    const double series = w.e0 * area * (1.0 - R) / (1.0 + R);
    const double onePass = w.e0 * area * (1.0 - R) * (1.0 - R);
    const DetectorImage& img = w.result.detectors[0];
    const double flux = img.totalFlux();
    const double sigma = img.totalRelativeError(n) * flux;
    ASSERT_GT(sigma, 0.0);
    EXPECT_LT(sigma, 0.01 * series) << "the test must resolve the two models";
    EXPECT_LT(std::abs(flux - series), 4.0 * sigma)
        << "flux " << flux << " expected " << series << " sigma " << sigma;
    EXPECT_GT(std::abs(flux - onePass), 5.0 * sigma)
        << "flux " << flux << " single pass " << onePass << " sigma " << sigma;
    EXPECT_EQ(w.result.budget.absorbedVolume, 0.0);  // a model glass does not absorb
    EXPECT_LT(std::abs(w.result.budget.imbalance()), 1e-12);
    std::cout << "[ measured ] n = 4 plate, " << GetParam().name << ": " << flux / (w.e0 * area)
              << " +- " << sigma / (w.e0 * area)
              << " of E0 A; (1-R)/(1+R) = " << series / (w.e0 * area)
              << ", (1-R)^2 = " << onePass / (w.e0 * area) << "; "
              << double(w.result.budget.segments) / n << " segments per ray\n";
}

INSTANTIATE_TEST_SUITE_P(
    Modes, HighIndexWindow,
    ::testing::Values(WindowCase{"split", TransportOptions::Mode::Split, 0.0},
                      WindowCase{"random", TransportOptions::Mode::Random, 0.0}),
    [](const ::testing::TestParamInfo<WindowCase>& i) { return i.param.name; });

// The min flux of the n = 4 plate above at 0.2 of the ray: the first branch reflected inside
// (0.64 x 0.36 = 0.23) goes on, its next reflection (0.083) is below. Cut, that leaves the
// light that crosses once, (1 - R)^2, 13 % low, and the budget's cut bounds what the detector
// lacks; played as Russian roulette kept at 0.5 (veil trace's way, there 1e-4 and 1e-2) the
// survivors carry it, and the series (1 - R)/(1 + R) comes back.
TEST(Transport, RouletteBelowTheMinFluxKeepsTheInterReflections) {
    const double nd = 4.0, R = std::pow((nd - 1.0) / (nd + 1.0), 2), area = 64.0;
    for (const bool roulette : {false, true}) {
        TransportOptions o;
        o.minRelativeFlux = 0.2;
        o.rescueRelativeFlux = roulette ? 0.5 : 0.0;
        o.seed = 13;
        const uint64_t n = 200000;
        const WindowRun w =
            traceWindow(std::string("window_n4_min_") + (roulette ? "rr" : "cut"), nd, o, n);
        const DetectorImage& img = w.result.detectors[0];
        const double flux = img.totalFlux(), sigma = img.totalRelativeError(n) * flux;
        const double series = w.e0 * area * (1.0 - R) / (1.0 + R);
        const double onePass = w.e0 * area * (1.0 - R) * (1.0 - R);
        ASSERT_GT(sigma, 0.0);
        EXPECT_LT(sigma, 0.015 * series) << "the test must resolve the two";
        EXPECT_LT(std::abs(flux - (roulette ? series : onePass)), 4.0 * sigma)
            << (roulette ? "roulette" : "cut") << ": flux " << flux << " +- " << sigma
            << ", series " << series << ", one pass " << onePass;
        EXPECT_LT(std::abs(w.result.budget.imbalance()), 1e-12);
        if (roulette) {
            EXPECT_EQ(w.result.budget.cut, 0.0);
            EXPECT_GT(w.result.budget.rouletteGain, 0.0);
        } else {
            // What the detector lacks is at most what was cut.
            EXPECT_GE(w.result.budget.cut, series - flux);
            EXPECT_EQ(w.result.budget.cut, w.result.budget.culled);
        }
    }
}

// Ray i always draws the same numbers and blocks are reduced in a fixed order: 1 and 2
// threads give bitwise the same images and budget.
TEST(Transport, OneAndTwoThreadsGiveIdenticalImages) {
    const auto path =
        writeScene("threads", "lens = \"" + kLenses + "double_gauss_50mm.toml\"\n" + R"(
[mechanics]
[[source]]
kind = "sun"
field_deg = [0.0, 25.0]
)");
    Prepared r = prepare(path);
    TransportOptions o;
    o.raysPerBlock = 128;
    o.seed = 5;
    auto run = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        return traceNonsequential(r.trace.view, r.trace.images, 3000, o);
    };
    const TraceResult one = run(1), two = run(2);
    EXPECT_TRUE(one.detectors[0].sameSums(two.detectors[0]));
    EXPECT_EQ(one.budget.detected, two.budget.detected);
    EXPECT_EQ(one.budget.absorbedSurface, two.budget.absorbedSurface);
    EXPECT_EQ(one.budget.segments, two.budget.segments);
    EXPECT_GT(one.detectors[0].totalFlux(), 0.0);
}

// An on-axis point source 100 m in front of the double Gauss, through the real stop plate of
// its mechanics, with ideal AR faces and absorbing edges: the detector image is the spot
// diagram. Its centroid and RMS radius agree with the sequential trace of the same lens
// (object at 100 m, aperture set by the same stop) within Monte Carlo error.
TEST(Transport, PointSourceThroughTheDoubleGaussGivesTheSequentialSpot) {
    const auto path = writeScene("spot", "lens = \"" + kLenses + "double_gauss_50mm.toml\"\n" + R"(
[mechanics]
chord_tolerance_mm = 0.001
barrel = { clearance_mm = 0.01 }
[[assign]]
objects = ["L*.front", "L*.back"]
property = "ideal_ar"
[[assign]]
objects = ["*.edge", "*.flat*"]
property = "absorber"
[[source]]
kind = "point"
position_mm = [0.0, 0.0, -100000.0]
[detector]
size_mm = [0.3, 0.3]
pixels = [300, 300]
)");
    Prepared r = prepare(path);
    TransportOptions o;
    o.seed = 17;
    const uint64_t n = 300000;
    const TraceResult res = traceNonsequential(r.trace.view, r.trace.images, n, o);
    const DetectorImage& img = res.detectors[0];

    // Moments of the image about the axis, at pixel centres (flux per ray is constant).
    const DetectorGeometry& g = img.geometry();
    double s0 = 0, sx = 0, sy = 0, sxx = 0, sr4 = 0;
    uint64_t hits = 0;
    for (int p = 0; p < g.pixelCount(); ++p) {
        if (img.flux(p) == 0.0) continue;
        const Vec2 c = img.pixelCentreLocal(p);
        const double f = img.flux(p), r2 = glm::dot(c, c);
        s0 += f;
        sx += f * c.x;
        sy += f * c.y;
        sxx += f * r2;
        sr4 += f * r2 * r2;
        hits += img.count(p);
    }
    ASSERT_GT(hits, 50000u);
    const double cx = sx / s0, cy = sy / s0;
    const double ms = sxx / s0 - cx * cx - cy * cy;  // mean square radius about the centroid
    const double pixel = g.widthMm / g.pixelsX;
    const double msCorrected = ms - pixel * pixel / 6.0;  // pixel quantisation, both axes

    // Sequential reference: the same lens, object at 100 m, aperture floating on the stop.
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    Prescription p = r.file.prescription;
    p.surfaces[0].thicknessMm = 100000.0;
    p.system.aperture = {SystemAperture::Kind::FloatByStop, 0.0};
    p.system.fields = {{0.0, 0.0, 1.0}};
    p.system.fieldKind = SystemData::FieldKind::ObjectHeightMm;
    const SequentialModel m = SequentialModel::build(p, catalog);
    // The point source lights the entrance pupil uniformly; its rays are clipped by the real
    // stop. So: a fine uniform grid over a disk a little larger than the paraxial entrance
    // pupil, paraxial aiming (straight lines from the source point through the grid), and
    // each ray kept only if it passes inside the stop's semi-diameter.
    const RayAimer aimer(m, AimMode::Paraxial);
    const int stop = m.stopIndex();
    const double stopRadius = p.surfaces[stop].clearSemiDiameterMm;
    SequentialTraceOptions to;
    to.recordPath = true;
    double seqSum = 0.0;
    int seqCount = 0;
    const int grid = 160;
    for (int w = 0; w < m.wavelengthCount(); ++w) {  // equal weights: pool the wavelengths
        for (int i = 0; i < grid; ++i) {
            for (int j = 0; j < grid; ++j) {
                const double px = 1.1 * (2.0 * (i + 0.5) / grid - 1.0);
                const double py = 1.1 * (2.0 * (j + 0.5) / grid - 1.0);
                if (px * px + py * py > 1.21) continue;
                const AimedRay a = aimer.aim(0.0, 0.0, px, py, w);
                const SequentialRayResult tr = traceSequential(m, w, a.ray, to);
                if (!tr.ok()) continue;
                const Vec3& atStop = tr.path[stop - to.firstSurface].origin;
                if (std::hypot(atStop.x, atStop.y) > stopRadius) continue;
                seqSum += tr.ray.origin.x * tr.ray.origin.x + tr.ray.origin.y * tr.ray.origin.y;
                ++seqCount;
            }
        }
    }
    const double msSeq = seqSum / seqCount;
    // Standard error of the mean square radius: sqrt(Var(r^2) / N).
    const double varR2 = sr4 / s0 - (sxx / s0) * (sxx / s0);
    const double se = std::sqrt(varR2 / hits);
    EXPECT_LT(std::abs(msCorrected - msSeq), 5.0 * se + 0.002 * msSeq)
        << "MC RMS " << std::sqrt(msCorrected) * 1e3 << " um, sequential " << std::sqrt(msSeq) * 1e3
        << " um, se of r^2 " << se;
    const double seCentroid = std::sqrt(ms / hits);
    EXPECT_LT(std::abs(cx), 5.0 * seCentroid + pixel * 1e-9);
    EXPECT_LT(std::abs(cy), 5.0 * seCentroid + pixel * 1e-9);
    EXPECT_GT(std::sqrt(msSeq), 0.005);  // a real spot, not a point: the test has power
}

// Path histories: recording them changes nothing in the images; saved to a ray database and
// read back, they give the detector flux again without tracing, and every complete path ends
// in exactly one terminal event (detector, absorption, exit or cull).
TEST(Transport, HistoriesSavedAndReadBackReproduceTheDetectorFlux) {
    const auto path =
        writeScene("histories", "lens = \"" + kLenses + "double_gauss_50mm.toml\"\n" + R"(
[mechanics]
[[source]]
kind = "sun"
field_deg = [0.0, 25.0]
)");
    Prepared r = prepare(path);
    TransportOptions o;
    o.seed = 9;
    const uint64_t n = 1500;
    const TraceResult plain = traceNonsequential(r.trace.view, r.trace.images, n, o);

    const std::filesystem::path db = std::filesystem::path(::testing::TempDir()) / "histories.vrdb";
    RayDatabaseInfo info = describeScene(r.setup->scene, "histories");
    info.seed = o.seed;
    uint64_t terminalMismatch = 0;
    {
        RayDatabaseWriter writer(db, info);
        o.recordHistories = true;
        const TraceResult recorded = traceNonsequential(
            r.trace.view, r.trace.images, n, o, {}, [&](uint64_t i, const PathHistory& h) {
                // Every leaf is a terminal event (detectors absorb what they record); nothing
                // else is a leaf.
                for (size_t k = 0; k < h.size(); ++k) {
                    const auto idx = static_cast<NodeIndex>(k);
                    const EventType t = h.node(idx).type;
                    if (h.isLeaf(idx) != (isTerminal(t) || t == EventType::DetectorHit))
                        ++terminalMismatch;
                }
                writer.add(i, h);
            });
        writer.setEmittedRays(n);
        writer.close();
        EXPECT_TRUE(plain.detectors[0].sameSums(recorded.detectors[0]));
    }
    EXPECT_EQ(terminalMismatch, 0u);
    RayDatabaseReader reader(db);
    const RayStatistics st = rayStatistics(reader);
    EXPECT_EQ(st.rays, n);
    EXPECT_GT(st.paths, n);  // splitting: more paths than rays
    ASSERT_EQ(st.detectedFlux.count("sensor"), 1u);
    const double traced = plain.detectors[0].totalFlux();
    EXPECT_NEAR(st.detectedFlux.at("sensor"), traced, 1e-6 * traced);  // float32 fluxes
    EXPECT_GT(st.eventsByType[static_cast<size_t>(EventType::FresnelReflect)], 0u);
}

// The double Gauss with its mechanics and the Sun 12 degrees off axis (two-reflection ghosts
// on the detector), a 72 x 48 pixel detector: the criterion image tests' scene.
std::filesystem::path doubleGaussSunAt12(const std::string& name) {
    return writeScene(name, "lens = \"" + kLenses + "double_gauss_50mm.toml\"\n" + R"(
[mechanics]
[[source]]
kind = "sun"
field_deg = [0.0, 12.0]
[detector]
size_mm = [36.0, 24.0]
pixels = [72, 48]
)");
}

// The criteria compiled against the prepared scene's names.
std::vector<CompiledCriterion> compileAll(const Prepared& r,
                                          const std::vector<std::string>& texts) {
    const NameTable names = criterionNames(r.setup->scene, r.trace.view);
    std::vector<CompiledCriterion> compiled;
    for (const std::string& t : texts) compiled.push_back(compile(parseCriterion(t), names));
    return compiled;
}

// The seed's filtered images: on the double Gauss with the Sun off axis, the image of the
// two-reflection ghosts, the image of its complement, and the whole add up, pixel by pixel,
// to the unfiltered image within floating point; nothing is left for "the rest".
TEST(Transport, CriterionImagesAndTheirComplementAddUpToTheImage) {
    Prepared r = prepare(doubleGaussSunAt12("where"));
    const std::vector<std::string> texts = {"reflect{2}", "not reflect{2}"};
    const std::vector<CompiledCriterion> compiled = compileAll(r, texts);
    CriterionImages split(texts, compiled, r.trace.images, r.trace.view.detectorOfObject);
    TransportOptions o;
    o.seed = 21;
    o.recordHistories = true;
    const TraceResult res =
        traceNonsequential(r.trace.view, r.trace.images, 4000, o, {}, split.callback(true));
    split.finish();
    const DetectorImage& whole = res.detectors[0];
    const DetectorImage& ghosts = split.images()[0][0];
    const DetectorImage& others = split.images()[1][0];
    const DetectorImage& rest = split.images()[2][0];
    ASSERT_GT(ghosts.totalFlux(), 0.0);  // the sun at 12 deg makes two-reflection ghosts
    ASSERT_GT(others.totalFlux(), 0.0);
    EXPECT_EQ(rest.totalFlux(), 0.0);
    for (int p = 0; p < whole.geometry().pixelCount(); ++p)
        EXPECT_NEAR(ghosts.flux(p) + others.flux(p), whole.flux(p), 1e-12 * whole.totalFlux())
            << "pixel " << p;
    EXPECT_NEAR(ghosts.totalFlux() + others.totalFlux(), whole.totalFlux(),
                1e-12 * whole.totalFlux());
}

// The criterion layers of one process are added as their rays complete, in ray order: no ray
// is left waiting once the trace is done (memory is the images plus the rays in flight, not
// every detected path), and the images are bitwise those added after the trace, on 1 or 2
// threads.
TEST(Transport, CriterionImagesStreamInRayOrder) {
    Prepared r = prepare(doubleGaussSunAt12("where_stream"));
    const std::vector<std::string> texts = {"reflect{2}"};
    const std::vector<CompiledCriterion> compiled = compileAll(r, texts);
    auto run = [&](bool everyRay, int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        auto split = std::make_unique<CriterionImages>(texts, compiled, r.trace.images,
                                                       r.trace.view.detectorOfObject);
        TransportOptions o;
        o.seed = 23;
        o.raysPerBlock = 64;
        o.recordHistories = true;
        traceNonsequential(r.trace.view, r.trace.images, 3000, o, {}, split->callback(everyRay));
        if (everyRay) {
            EXPECT_EQ(split->pendingRays(), 0u);
        } else {
            EXPECT_GT(split->pendingRays(), 100u);
        }
        split->finish();
        return split;
    };
    const auto after = run(false, 2), streamed1 = run(true, 1), streamed2 = run(true, 2);
    ASSERT_GT(after->images()[0][0].totalFlux(), 0.0);
    for (size_t l = 0; l < 2; ++l) {
        EXPECT_TRUE(streamed1->images()[l][0].sameSums(after->images()[l][0])) << "layer " << l;
        EXPECT_TRUE(streamed2->images()[l][0].sameSums(after->images()[l][0])) << "layer " << l;
    }
}

// Online pruning: with the branches that can no longer match culled as they go, the
// criterion's image keeps its flux (within Monte Carlo error of both runs), while far fewer
// segments are traced. The criterion excludes scatter, so every scattered branch is dropped
// at its first diffuse event.
TEST(Transport, PruningKeepsTheCriterionFluxAndTracesLess) {
    const auto path = writeScene("prune", "lens = \"" + kLenses + "double_gauss_50mm.toml\"\n" + R"(
[mechanics]
property = "mount"
[properties.mount]
scatter = { model = "lambertian", reflectance = 0.05 }
[[source]]
kind = "sun"
field_deg = [0.0, 12.0]
[detector]
size_mm = [36.0, 24.0]
pixels = [36, 24]
)");
    Prepared r = prepare(path);
    const NameTable names = criterionNames(r.setup->scene, r.trace.view);
    const std::vector<std::string> texts = {"fresnel{2} and not scatter"};
    const std::vector<CompiledCriterion> compiled = {compile(parseCriterion(texts[0]), names)};
    const uint64_t n = 6000;
    auto run = [&](bool prune, uint64_t& segments) {
        CriterionImages split(texts, compiled, r.trace.images, r.trace.view.detectorOfObject);
        CriteriaFilter filter(split.criteria());
        TransportOptions o;
        o.seed = 31;
        o.recordHistories = true;
        o.filter = prune ? &filter : nullptr;
        const TraceResult res =
            traceNonsequential(r.trace.view, r.trace.images, n, o, {}, split.callback(true));
        split.finish();
        segments = res.budget.segments;
        EXPECT_LT(std::abs(res.budget.imbalance()), 1e-12 * res.budget.emitted);
        const DetectorImage& img = split.images()[0][0];
        return std::make_pair(img.totalFlux(), img.totalRelativeError(n) * img.totalFlux());
    };
    uint64_t full = 0, pruned = 0;
    const auto [f0, s0] = run(false, full);
    const auto [f1, s1] = run(true, pruned);
    ASSERT_GT(f0, 0.0);
    EXPECT_LT(std::abs(f1 - f0), 5.0 * std::hypot(s0, s1)) << f0 << " vs " << f1;
    EXPECT_LT(pruned, full / 2) << "segments " << full << " -> " << pruned;
}

}  // namespace
}  // namespace veil
