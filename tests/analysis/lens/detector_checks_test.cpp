// Misplaced detectors are warned about, with the distances; well placed ones (every example
// scene) are not.

#include "analysis/lens/detector_checks.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "analysis/lens/first_order.h"
#include "geometry/lens_solid.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {
namespace {

// The double Gauss with one [detector] given by `detector` (TOML lines).
std::vector<ImportNote> warningsFor(const std::string& detector) {
    // One file per test: ctest runs the tests of this file in parallel processes.
    const std::string path = ::testing::TempDir() + "veil_detector_check_" +
                             ::testing::UnitTest::GetInstance()->current_test_info()->name() +
                             ".toml";
    FILE* f = fopen(path.c_str(), "w");
    EXPECT_TRUE(f);
    fprintf(f, "lens = \"%s/examples/lenses/double_gauss_50mm.toml\"\n[detector]\n%s\n",
            VEIL_SOURCE_DIR, detector.c_str());
    fclose(f);
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec file = readSceneFile(path, catalog);
    const SceneGeometry setup = buildSceneGeometry(file, catalog);
    return detectorPlacementWarnings(file, setup);
}

std::string text(const std::vector<ImportNote>& notes) {
    std::string s;
    for (const ImportNote& n : notes) s += n.message + "\n";
    return s;
}

TEST(DetectorChecks, FreeDetectorInsideTheFirstElement) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec lens =
        readSceneFile(VEIL_SOURCE_DIR "/examples/lenses/double_gauss_50mm.toml", catalog);
    const std::vector<LensSolid> solids = lensSolids(lens.prescription);
    ASSERT_FALSE(solids.empty());
    const double z = 0.5 * (solids[0].frontZ(0.0) + solids[0].backZ(0.0));
    const auto notes =
        warningsFor("name = \"det\"\nsize_mm = [10.0, 10.0]\nz_mm = " + std::to_string(z));
    ASSERT_EQ(notes.size(), 1u) << text(notes);
    EXPECT_NE(notes[0].message.find("detector 'det' (centre at z = "), std::string::npos);
    EXPECT_NE(notes[0].message.find("lies inside lens element " + solids[0].name),
              std::string::npos)
        << notes[0].message;
    EXPECT_EQ(notes[0].loc.line, 2);  // the [detector] table
    EXPECT_EQ(notes[0].severity, ImportNote::Severity::Warning);
}

TEST(DetectorChecks, FreeDetectorFarFromTheImagePlane) {
    // In front of the lens, and a metre behind it: both named with their distance.
    auto front = warningsFor("name = \"det\"\nsize_mm = [10.0, 10.0]\nz_mm = -20.0");
    ASSERT_EQ(front.size(), 1u) << text(front);
    EXPECT_NE(front[0].message.find("before the paraxial image plane"), std::string::npos)
        << front[0].message;
    EXPECT_NE(front[0].message.find("in front of the lens"), std::string::npos);
    auto far = warningsFor("name = \"det\"\nsize_mm = [10.0, 10.0]\nz_mm = 1000.0");
    ASSERT_EQ(far.size(), 1u) << text(far);
    EXPECT_NE(far[0].message.find("behind the paraxial image plane"), std::string::npos)
        << far[0].message;
    // The distance stated is the one from the paraxial focus.
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec lens =
        readSceneFile(VEIL_SOURCE_DIR "/examples/lenses/double_gauss_50mm.toml", catalog);
    const SequentialModel& m = *lens.model;
    const double zImage = m.surface(m.imageIndex()).zMm +
                          computeFirstOrder(m, m.primaryWavelength()).paraxialImageDistanceMm;
    std::ostringstream distance;
    distance << std::setprecision(5) << 1000.0 - zImage << " mm behind";
    EXPECT_NE(far[0].message.find(distance.str()), std::string::npos) << far[0].message;
}

TEST(DetectorChecks, DetectorBesideTheImageCircle) {
    // On the sensor, but 60 mm off axis: the 50 mm lens images its 22 degree field within
    // about 20 mm of the axis.
    const auto notes = warningsFor("size_mm = [10.0, 10.0]\ncenter_mm = [0.0, 60.0]");
    ASSERT_EQ(notes.size(), 1u) << text(notes);
    EXPECT_NE(notes[0].message.find("outside the image circle"), std::string::npos)
        << notes[0].message;
}

// A single concave mirror images toward -z: the light reaches the sensor (sensitive side
// toward -z) from behind.
TEST(DetectorChecks, LightArrivingOnTheBackIsSaid) {
    const std::string path = ::testing::TempDir() + "veil_mirror_detector.toml";
    FILE* f = fopen(path.c_str(), "w");
    ASSERT_TRUE(f);
    fputs(
        "[system]\nname = \"f/5 mirror\"\naperture = { f_number = 5.0 }\n"
        "fields_deg = [0.0, 0.5]\nsurfaces = [\n"
        "  { stop = true, r = -1000.0, t = -500.0, mirror = true, sd = 60.0 },\n]\n",
        f);
    fclose(f);
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec file = readSceneFile(path, catalog);
    const SceneGeometry setup = buildSceneGeometry(file, catalog);
    const auto notes = detectorPlacementWarnings(file, setup);
    ASSERT_EQ(notes.size(), 1u) << text(notes);
    EXPECT_NE(notes[0].message.find("faces away from the image-space light"), std::string::npos)
        << notes[0].message;
}

TEST(DetectorChecks, ExampleScenesAreQuiet) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    for (const auto& e : std::filesystem::directory_iterator(VEIL_SOURCE_DIR "/examples/scenes")) {
        SCOPED_TRACE(e.path().string());
        const SceneSpec file = readSceneFile(e.path(), catalog);
        const SceneGeometry setup = buildSceneGeometry(file, catalog);
        EXPECT_TRUE(detectorPlacementWarnings(file, setup).empty())
            << text(detectorPlacementWarnings(file, setup));
    }
    // And the default detector of a bare lens, on its image surface.
    const SceneSpec lens =
        readSceneFile(VEIL_SOURCE_DIR "/examples/lenses/double_gauss_50mm.toml", catalog);
    EXPECT_TRUE(detectorPlacementWarnings(lens, buildSceneGeometry(lens, catalog)).empty());
}

}  // namespace
}  // namespace veil
