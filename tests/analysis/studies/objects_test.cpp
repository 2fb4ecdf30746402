// Critical and illuminated objects (analysis/studies/objects.h) against independent truth: the
// share of a collimated beam an annular plate intercepts (areas), the share of a detector's
// Lambertian view that falls on an annulus in front of it (the closed-form view factor of a
// disk, integrated over the detector), and a scene built so that one part alone is both lit
// and seen, which must rank first.

#include "analysis/studies/objects.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include "analysis/runs/stray_light_run.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "tracer/records/detector.h"
#include "tracer/scene/prepared_scene.h"

namespace veil {
namespace {

std::unique_ptr<PreparedScene> prepareText(const std::string& name, const std::string& body) {
    const std::filesystem::path p = std::filesystem::temp_directory_path() / (name + ".toml");
    std::ofstream(p) << "lens = \"" VEIL_SOURCE_DIR "/examples/lenses/singlet.toml\"\n" << body;
    return PreparedScene::read(p, GlassCatalog::builtIn());
}

// Only the parts the test names, meshed finely (polygon areas within 1e-4 of the circles').
const char* kBareMechanics = R"(
[mechanics]
barrel = false
retainers = false
spacers = false
stop = false
chord_tolerance_mm = 0.001

[[assign]]
objects = ["L1.front", "L1.back"]
property = "ideal_ar"
)";

const ObjectRow& rowOf(const ObjectsResult& r, const std::string& name) {
    for (const ObjectRow& row : r.rows)
        if (row.name == name) return row;
    throw std::runtime_error("no row " + name);
}

const ObjectSide* sideOf(const ObjectRow& row, const std::string& name) {
    for (const ObjectSide& s : row.sides)
        if (s.name == name) return &s;
    return nullptr;
}

// An on-axis beam of radius R over an annular plate in front of the lens (hole radius a,
// rim beyond the beam): the plate's front intercepts 1 - a^2 / R^2 of the beam.
TEST(Objects, APlateInTheBeamIsLitByTheShareOfItsArea) {
    const auto scene = prepareText("veil_objects_lit", std::string(kBareMechanics) + R"(
[[mechanics.parts]]
name = "plate"
profile_mm = [[6.0, -3.0], [30.0, -3.0], [30.0, -2.0], [6.0, -2.0]]

[[source]]
name = "beam"
kind = "collimated"
field_deg = [0.0, 0.0]
)");
    const auto& beam = std::get<CollimatedSource>(scene->transport().view.sources[0].shape()).beam;
    ASSERT_GT(beam.radiusMm, 6.0);
    ASSERT_LT(beam.radiusMm, 30.0);
    ObjectsSpec spec;
    spec.rays = 40000;
    const ObjectsResult r = runObjects(*scene, spec);
    const ObjectRow& plate = rowOf(r, "plate");
    const ObjectSide* front = sideOf(plate, "front (-z)");
    ASSERT_NE(front, nullptr);
    const double expected = 1.0 - std::pow(6.0 / beam.radiusMm, 2);
    EXPECT_NEAR(front->lit, expected, 4.0 * front->litError + 1e-4)
        << front->lit << " +- " << front->litError;
    EXPECT_GT(front->litError, 0.0);
    // The beam passes the hole through an ideal AR lens to the detector: nothing comes back.
    EXPECT_EQ(sideOf(plate, "back (+z)") ? sideOf(plate, "back (+z)")->lit : 0.0, 0.0);
}

// The view factor from a point at height h over a parallel disk of radius R whose axis is rho
// away (a classic closed form).
double diskViewFactor(double h, double rho, double R) {
    const double s = h * h + rho * rho + R * R;
    return 0.5 * (1.0 - (h * h + rho * rho - R * R) / std::sqrt(s * s - 4.0 * rho * rho * R * R));
}

// An annular plate between the lens and the detector, facing it: the share of the detector's
// Lambertian view that lands on its back face is the view factor to the annulus averaged over
// the detector's area.
TEST(Objects, APlateBeforeTheDetectorIsSeenByItsViewFactor) {
    const auto scene = prepareText("veil_objects_seen", std::string(kBareMechanics) + R"(
[[mechanics.parts]]
name = "plate"
profile_mm = [[3.0, 60.0], [20.0, 60.0], [20.0, 61.0], [3.0, 61.0]]

[[source]]
name = "beam"
kind = "collimated"
field_deg = [0.0, 0.0]
)");
    const DetectorGeometry& det = scene->geometry().detectors.front();
    const double h = det.frame.translation.z - 61.0;
    ASSERT_GT(h, 30.0);
    ASSERT_LT(std::abs(det.frame.translation.x) + std::abs(det.frame.translation.y), 1e-9);
    // The default detector is the box of the round image surface: it records on the disk.
    ASSERT_DOUBLE_EQ(det.widthMm, det.heightMm);
    const double radius = 0.5 * det.widthMm;
    const int n = 400;
    double sum = 0.0;
    int inside = 0;
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j) {
            const double x = det.widthMm * ((i + 0.5) / n - 0.5);
            const double y = det.heightMm * ((j + 0.5) / n - 0.5);
            const double rho = std::hypot(x, y);
            if (rho > radius) continue;
            sum += diskViewFactor(h, rho, 20.0) - diskViewFactor(h, rho, 3.0);
            ++inside;
        }
    const double expected = sum / inside;
    ObjectsSpec spec;
    spec.rays = 40000;
    const ObjectsResult r = runObjects(*scene, spec);
    const ObjectSide* back = sideOf(rowOf(r, "plate"), "back (+z)");
    ASSERT_NE(back, nullptr);
    EXPECT_NEAR(back->seen, expected, 4.0 * back->seenError + 1e-4)
        << back->seen << " +- " << back->seenError << ", view factor " << expected;
    EXPECT_GT(expected, 0.1);
    // The disk's area, from the share of the grid's rays that start on it.
    EXPECT_NEAR(r.detectorAreaMm2, std::numbers::pi * radius * radius,
                0.01 * std::numbers::pi * radius * radius);
}

// A thin coaxial Lambertian ring facing the detector, lit by a point source on the axis: the
// light and the view are spread evenly around it and nearly evenly across its 1 mm width, so
// the first-order estimate must equal the traced first scatter (the flux that reaches the
// detector after one scatter, on the ring).
TEST(Objects, TheEstimateIsTheFirstScatterWhereLightAndViewAreEven) {
    const auto scene = prepareText("veil_objects_estimate", std::string(kBareMechanics) + R"(
[properties.white]
scatter = { model = "lambertian", reflectance = 0.5 }

[[mechanics.parts]]
name = "ring"
profile_mm = [[10.0, 60.0], [11.0, 60.0], [11.0, 61.0], [10.0, 61.0]]
property = "white"

[[source]]
name = "lamp"
kind = "point"
position_mm = [0.0, 0.0, 95.0]
axis = [0.0, 0.0, -1.0]
half_angle_deg = 18.7
)");
    ObjectsSpec spec;
    spec.rays = 400000;
    const ObjectsResult r = runObjects(*scene, spec);
    const ObjectRow& ring = rowOf(r, "ring");
    const ObjectSide* back = sideOf(ring, "back (+z)");
    ASSERT_NE(back, nullptr);
    // The finish scatters half of what lands, exactly.
    EXPECT_NEAR(back->scattered, 0.5 * back->lit, 1e-12 * back->lit);
    EXPECT_GT(ring.estimate, 0.0);

    StrayLightSpec traced;
    traced.raysPerSource = 400000;
    traced.where = {"scatter(ring) and scatter{1}"};
    const StrayLightResult t = runStrayLight(*scene, traced);
    const double emitted = scene->transport().view.sources[0].totalFlux();
    const StrayLightRow row = t.report()[1];
    ASSERT_EQ(row.layer, "where1");
    const double first = row.flux / emitted;
    const double sigma = std::hypot(first * row.relativeError, ring.estimateError);
    EXPECT_NEAR(first, ring.estimate, 4.0 * sigma + 0.02 * ring.estimate)
        << "traced " << first << " +- " << first * row.relativeError << ", estimate "
        << ring.estimate << " +- " << ring.estimateError;
}

// The scene of the ranking: a 12 degree beam converges onto the bore of a tube the detector
// looks straight at (lit and seen); a ring beside the detector is seen but the tube takes the
// beam before it (seen only); a hood in front of the lens is lit on its front and seen, through
// the lens, on its back only (both, but on different sides).
const char* kRankingScene = R"(
[[mechanics.parts]]
name = "tube"
profile_mm = [[11.0, 40.0], [12.0, 40.0], [12.0, 90.0], [11.0, 90.0]]

[[mechanics.parts]]
name = "ring"
profile_mm = [[14.0, 95.0], [16.0, 95.0], [16.0, 99.0], [14.0, 99.0]]

[[mechanics.parts]]
name = "hood"
profile_mm = [[10.6, -3.0], [20.0, -3.0], [20.0, -2.0], [10.6, -2.0]]

[[source]]
name = "beam"
kind = "collimated"
field_deg = [0.0, 12.0]
)";

TEST(Objects, TheOnePartBothLitAndSeenRanksFirst) {
    const auto scene =
        prepareText("veil_objects_rank", std::string(kBareMechanics) + kRankingScene);
    ObjectsSpec spec;
    spec.rays = 20000;
    const ObjectsResult r = runObjects(*scene, spec);
    ASSERT_FALSE(r.rows.empty());
    EXPECT_EQ(r.rows.front().name, "tube");
    EXPECT_EQ(r.rows.front().rank, 1);
    const ObjectRow& tube = rowOf(r, "tube");
    const ObjectRow& ring = rowOf(r, "ring");
    const ObjectRow& hood = rowOf(r, "hood");
    EXPECT_EQ(tube.sides.front().name, "bore");
    EXPECT_GT(tube.lit, 0.3);
    EXPECT_GT(tube.seen, 0.2);
    // The ring: seen, never lit, not ranked.
    EXPECT_GT(ring.seen, 0.1);
    EXPECT_EQ(ring.lit, 0.0);
    EXPECT_EQ(ring.rank, 0);
    // The hood: lit and seen, but not on the same side.
    EXPECT_GT(hood.lit, 0.1);
    EXPECT_GT(hood.seen, 0.003);
    EXPECT_LT(hood.product, 1e-3 * tube.product);
    EXPECT_LT(hood.product, 1e-2 * hood.lit * hood.seen);
    // Polished faces are listed apart unless asked for.
    for (const ObjectRow& row : r.rows)
        if (row.optical) {
            EXPECT_EQ(row.rank, 0) << row.name;
        }
    spec.includeOptical = true;
    const ObjectsResult all = runObjects(*scene, spec);
    EXPECT_GT(rowOf(all, "L1.back").rank, 0);
}

TEST(Objects, EveryThreadCountGivesTheSameNumbers) {
    const auto scene =
        prepareText("veil_objects_threads", std::string(kBareMechanics) + kRankingScene);
    ObjectsSpec spec;
    spec.rays = 10000;
    std::string one, many;
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
        one = runObjects(*scene, spec).csv();
    }
    {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 4);
        many = runObjects(*scene, spec).csv();
    }
    EXPECT_EQ(one, many);
}

TEST(Objects, AnUnknownSourceOrDetectorStopsBeforeAnyRay) {
    const auto scene =
        prepareText("veil_objects_names", std::string(kBareMechanics) + kRankingScene);
    ObjectsSpec spec;
    spec.rays = 1000000000;  // would take minutes: the error must come first
    spec.source = "bem";
    try {
        runObjects(*scene, spec);
        FAIL() << "no error";
    } catch (const ParseError& e) {
        EXPECT_NE(std::string(e.what()).find("no source 'bem' (the scene has beam)"),
                  std::string::npos)
            << e.what();
    }
    spec.source = "";
    spec.detector = "sensr";
    EXPECT_THROW(runObjects(*scene, spec), ParseError);
}

}  // namespace
}  // namespace veil
