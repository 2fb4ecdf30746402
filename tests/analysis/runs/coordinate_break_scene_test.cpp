// Coordinate breaks beyond the sequential trace: the TOML and ZMX readers, the 3D scene
// (faces placed in their surfaces' frames), nonsequential light through a fold, the mount
// generator's refusal, and the ghost tracer on a folded system.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "analysis/ghosts/ghost_tracer.h"
#include "analysis/lens/default_scene.h"
#include "analysis/runs/stray_light_run.h"
#include "geometry/mechanics.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/lens_file.h"
#include "lensdata/prescription.h"
#include "tracer/records/detector.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/scene/scene_transport.h"

namespace veil {
namespace {

std::filesystem::path writeText(const std::string& name, const std::string& text) {
    const std::filesystem::path p = std::filesystem::temp_directory_path() / name;
    std::ofstream(p) << text;
    return p;
}

// A Newtonian telescope: a paraboloid (R = -200 mm, focus 100 mm in front of it) and a flat
// fold 70 mm in front of it, tilted 45 degrees about x, sending the focus to (0, 30, -20)
// beside the tube. Surface 1 is a dummy entrance plane 50 mm in front of the primary.
const char* kNewtonian = R"(
[system]
name = "Newtonian"
aperture = { epd_mm = 36.0 }
fields_deg = [0.0, 0.5]
surfaces = [
  { r = inf, t = 50.0, sd = 21.0, name = "entrance" },
  { r = -200.0, conic = -1.0, t = -70.0, mirror = true, sd = 20.0, stop = true, name = "primary" },
  { break = { tilt_deg = [45.0, 0.0, 0.0] }, t = 0.0 },
  { r = inf, t = 0.0, mirror = true, sd = 10.0, name = "fold" },
  { break = { tilt_deg = [45.0, 0.0, 0.0] }, t = 30.0 },
  { image = true },
]
)";

TEST(CoordinateBreakScene, TomlBreakRowsBuildTheFoldedModel) {
    const auto path = writeText("veil_cb_newtonian.toml", kNewtonian);
    const Prescription p = readLensFile(path, GlassCatalog::builtIn());
    ASSERT_EQ(p.surfaces.size(), 7u);
    ASSERT_TRUE(p.surfaces[3].coordinateBreak);
    EXPECT_EQ(p.surfaces[3].coordinateBreak->tiltXDeg, 45.0);
    EXPECT_FALSE(p.surfaces[3].coordinateBreak->tiltFirst);
    EXPECT_TRUE(p.surfaces[3].material.isAir());
    const auto scene = PreparedScene::read(path, GlassCatalog::builtIn());
    const Vec3 image = scene->model().surface(6).frame.translation;
    EXPECT_NEAR(image.x, 0.0, 1e-12);
    EXPECT_NEAR(image.y, 30.0, 1e-12);
    EXPECT_NEAR(image.z, -20.0, 1e-12);
    // The fold's face sits in the fold's frame, the sensor in the image's.
    const SceneObject* fold = scene->scene().find("fold");
    ASSERT_NE(fold, nullptr);
    EXPECT_NEAR(fold->frame.rotation[2].y, std::sqrt(0.5), 1e-15);
    const SceneObject* sensor = scene->scene().find("sensor");
    ASSERT_NE(sensor, nullptr);
    EXPECT_NEAR(sensor->frame.translation.y, 30.0, 1e-12);
}

// Wrong rows name the value at fault.
TEST(CoordinateBreakScene, BadBreakRowsAreReportedAtTheValue) {
    auto message = [](const std::string& row) {
        const std::string text =
            "[system]\naperture = { epd_mm = 10.0 }\nsurfaces = [\n"
            "  { r = 50.0, t = 4.0, glass = \"N-BK7\", sd = 6.0 },\n  " +
            row + ",\n  { r = inf, t = 40.0, sd = 6.0 },\n]\n";
        try {
            readLensFile(writeText("veil_cb_bad.toml", text), GlassCatalog::builtIn());
        } catch (const std::exception& e) {
            return std::string(e.what());
        }
        return std::string("no error");
    };
    EXPECT_NE(message("{ break = { tilt_deg = [1.0, 2.0] }, t = 0.0, glass = \"N-BK7\" }")
                  .find("tilt_deg = [x, y, z]"),
              std::string::npos);
    EXPECT_NE(message("{ break = { tilt_deg = [1.0, 0.0, 0.0] }, t = 0.0, r = 10.0 }")
                  .find("takes no 'r'"),
              std::string::npos);
    // Inside L1 a break repeats the glass or leaves it out; another glass is an error.
    EXPECT_NE(message("{ break = { decenter_mm = [1.0, 0.0] }, t = 0.0, glass = \"AIR\" }")
                  .find("keeps the medium N-BK7"),
              std::string::npos);
    EXPECT_EQ(message("{ break = { tilt_deg = [1.0, 0.0, 0.0] }, t = 0.0, glass = \"N-BK7\" }"),
              "no error");
    EXPECT_EQ(message("{ break = { decenter_mm = [1.0, 0.0], tilt_first = true }, t = 0.0, "
                      "name = \"wedge_in\", comment = \"a decenter\" }"),
              "no error");
}

// Collimated light down the tube: the fold's back blocks the centre (the Newtonian's central
// obscuration), the rest reflects off the paraboloid and the fold onto the sensor beside
// the tube, all of it into the pixel at the centre of the image (a paraboloid's focus is
// perfect on its axis).
TEST(CoordinateBreakScene, NonsequentialLightFocusesWhereTheFoldSendsIt) {
    const std::string text = std::string(kNewtonian) + R"(
[[source]]
name = "star"
kind = "collimated"
field_deg = [0.0, 0.0]
radius_mm = 18.0

[[detector]]
name = "focus"
size_mm = [4.1, 4.1]
pixels = [41, 41]
)";
    const auto scene = PreparedScene::read(writeText("veil_cb_newtonian_scene.toml", text),
                                           GlassCatalog::builtIn());
    StrayLightSpec spec;
    spec.raysPerSource = 20000;
    const StrayLightResult r = runStrayLight(*scene, spec);
    ASSERT_EQ(r.images.size(), 1u);
    const DetectorImage& img = r.images[0];
    double total = 0.0;
    for (int p = 0; p < img.pixelCount(); ++p) total += img.flux(p);
    const double centre = img.flux(img.pixelIndex(20, 20));
    ASSERT_GT(total, 0.0);
    EXPECT_GT(centre / total, 0.999) << centre << " of " << total;
    // The fold's shadow: seen along z, the fold (a = 10 mm) tilted by 45 degrees covers an
    // ellipse of area pi a^2 cos 45 inside the beam (radius R, within the primary's 20 mm).
    // With perfect mirrors (the default) and the fold large enough for the converging cone
    // (its far edge ray meets the fold 9.4 mm from the centre),
    // everything else reaches the sensor: a binomial share, checked at 4 sigma.
    const double R =
        std::get<CollimatedSource>(scene->transport().view.sources[0].shape()).beam.radiusMm;
    ASSERT_GE(R, 18.0);
    ASSERT_LT(R, 20.0);
    const double expected = 1.0 - 100.0 * std::sqrt(0.5) / (R * R);
    const double sigma = std::sqrt(expected * (1.0 - expected) / 20000.0);
    EXPECT_NEAR(total / r.budget.emitted, expected, 4.0 * sigma) << r.budget;
}

// The mount generator builds about one axis: a tilted system with [mechanics] is refused,
// naming the surface and the break.
TEST(CoordinateBreakScene, MechanicsRefuseATiltedSystem) {
    const auto path = writeText("veil_cb_newtonian_mech.toml", std::string(kNewtonian) + R"(
[mechanics]
)");
    try {
        PreparedScene::read(path, GlassCatalog::builtIn());
        FAIL() << "expected a ModelError";
    } catch (const ModelError& e) {
        const std::string what = e.what();
        EXPECT_NE(what.find("fold"), std::string::npos) << what;
        EXPECT_NE(what.find("coordinate break"), std::string::npos) << what;
    }
}

// Zemax COORDBRK: PARM 1..5 are decenter x, y (lens units) and tilts (degrees), PARM 6 the
// order flag; the break takes the incoming medium and no aperture.
TEST(CoordinateBreakScene, ZmxCoordinateBreaksAreImported) {
    const std::string zmx = R"(VERS 190000 0
MODE SEQ
UNIT CM X W X CM MR CPMM
ENPD 2
WAVM 1 0.5875618 1
SURF 0
  TYPE STANDARD
  CURV 0.0
  DISZ INFINITY
SURF 1
  STOP
  TYPE STANDARD
  CURV 0.02
  DISZ 0.5
  GLAS N-BK7 0 0 1.5168 64.17
  DIAM 1.5 1
SURF 2
  TYPE COORDBRK
  CURV 0.0
  DISZ 0.0
  PARM 1 0.1
  PARM 2 -0.05
  PARM 3 2.5
  PARM 4 0
  PARM 5 -1
  PARM 6 1
  DIAM 0 0
SURF 3
  TYPE STANDARD
  CURV -0.005
  DISZ 9.0
  DIAM 1.5 1
SURF 4
  TYPE STANDARD
  CURV 0.0
  DISZ 0.0
)";
    const Prescription p = readLensFile(writeText("veil_cb.zmx", zmx), GlassCatalog::builtIn());
    ASSERT_TRUE(p.surfaces[2].coordinateBreak);
    const CoordinateBreak& b = *p.surfaces[2].coordinateBreak;
    EXPECT_DOUBLE_EQ(b.decenterXMm, 1.0);
    EXPECT_DOUBLE_EQ(b.decenterYMm, -0.5);
    EXPECT_EQ(b.tiltXDeg, 2.5);
    EXPECT_EQ(b.tiltZDeg, -1.0);
    EXPECT_TRUE(b.tiltFirst);
    // Inside the glass: the break keeps N-BK7, and L1 runs through it to surface 3.
    EXPECT_EQ(p.surfaces[2].material, p.surfaces[1].material);
    EXPECT_EQ(p.surfaces[2].clearSemiDiameterMm, 0.0);
    for (const ImportNote& n : p.report) EXPECT_NE(n.severity, ImportNote::Severity::Error) << n;
    const std::vector<Element> e = p.elements();
    ASSERT_EQ(e.size(), 1u);
    EXPECT_EQ(e[0].backSurface, 3);
    // A wedge (a break between an element's faces) has no 3D solid: the scene says so.
    try {
        PreparedScene::read(writeText("veil_cb.zmx", zmx), GlassCatalog::builtIn());
        FAIL() << "expected a ModelError";
    } catch (const ModelError& err) {
        EXPECT_NE(std::string(err.what()).find("coordinate break between its faces"),
                  std::string::npos)
            << err.what();
    }
}

// A plate's ghost through a 60 degree fold (two breaks of 30 degrees around a flat mirror)
// is the ghost of the unfolded plate: the same flux, footprint and displacement from the
// nominal image, the fold being a perfect mirror that only turns the light.
TEST(CoordinateBreakScene, GhostsThroughAFoldAreTheUnfoldedGhosts) {
    auto analyse = [](bool folded, double fieldDeg) {
        std::string rows =
            "  { stop = true, t = 5.0, sd = 5.0, mech_sd = 14.0 },\n"
            "  { t = 10.0, glass = { nd = 1.5, vd = 0 }, sd = 12.0, mech_sd = 14.0 },\n";
        if (folded)
            rows +=
                "  { t = 10.0, sd = 12.0, mech_sd = 14.0 },\n"
                "  { break = { tilt_deg = [30.0, 0.0, 0.0] }, t = 0.0 },\n"
                "  { t = 0.0, mirror = true, sd = 20.0, name = \"fold\" },\n"
                "  { break = { tilt_deg = [30.0, 0.0, 0.0] }, t = -10.0 },\n";
        else
            rows += "  { t = 20.0, sd = 12.0, mech_sd = 14.0 },\n";
        const std::string text =
            "[system]\nname = \"plate\"\nwavelengths_nm = [587.5618]\n"
            "aperture = { epd_mm = 10.0 }\nfields_deg = [0.0]\nsurfaces = [\n" +
            rows + "  { image = true, sd = 30.0 },\n]\n";
        const GlassCatalog& catalog = GlassCatalog::builtIn();
        SceneSpec file = readSceneFile(
            writeText(folded ? "veil_cb_plate_folded.toml" : "veil_cb_plate.toml", text), catalog);
        // Field sources alone (no stop plate), the same for both.
        setFieldSources(file, catalog, {{0.0, fieldDeg}});
        const SceneGeometry setup = buildSceneGeometry(file, catalog);
        const SceneTransport trace = prepareTransport(file, setup, catalog);
        const GhostTracer tracer(setup, trace, catalog);
        return tracer.analyse();
    };
    for (double field : {0.0, 8.0}) {
        const GhostAnalysis a = analyse(false, field), b = analyse(true, field);
        ASSERT_EQ(a.ghosts.size(), 1u);
        ASSERT_EQ(b.ghosts.size(), 1u);
        const GhostSourceResult& ga = a.ghosts[0].sources[0];
        const GhostSourceResult& gb = b.ghosts[0].sources[0];
        EXPECT_GT(ga.raysArrived, 0);
        EXPECT_EQ(gb.raysArrived, ga.raysArrived);
        EXPECT_NEAR(gb.flux, ga.flux, 1e-12 * ga.flux);
        EXPECT_NEAR(gb.relativeFlux, ga.relativeFlux, 1e-12);
        EXPECT_NEAR(gb.footprintMm, ga.footprintMm, 1e-9);
        // Displacement from the nominal image: the fold mirrors the image (y turns over).
        const Vec2 da = ga.centroidMm - a.nominal.sources[0].centroidMm;
        const Vec2 db = gb.centroidMm - b.nominal.sources[0].centroidMm;
        EXPECT_NEAR(glm::length(db), glm::length(da), 1e-9);
        EXPECT_NEAR(std::abs(db.y), std::abs(da.y), 1e-9);
        // Off axis the ghost walks off the nominal image (by 2 t tan(r) for the unclipped
        // beam; here the plate's sd clips the 14 mm beams differently).
        if (field > 0.0) {
            EXPECT_GT(std::abs(db.y), 0.5);
        }
    }
}

}  // namespace
}  // namespace veil
