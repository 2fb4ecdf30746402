// Fields given as image heights (tracer/sequential/image_fields.h), checked by what the resolved
// fields do: the paraxial first-order data put the paraxial chief ray at the given height, the real
// chief ray (aimed and traced as veil info's spots do) lands at the real height, and a finite
// object gets heights scaled by the paraxial magnification.

#include "tracer/sequential/image_fields.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <regex>

#include "analysis/lens/first_order.h"
#include "analysis/lens/spot.h"
#include "lensdata/errors.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/scene_spec.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {
namespace {

// The singlet example with its fields_deg line replaced.
std::filesystem::path singletWith(const std::string& name, const std::string& fieldsLine) {
    std::ifstream in(VEIL_SOURCE_DIR "/examples/lenses/singlet.toml");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text = std::regex_replace(text, std::regex("fields_deg = \\[0.0, 3.5, 5.0\\]"), fieldsLine);
    const std::filesystem::path p = std::filesystem::temp_directory_path() / (name + ".toml");
    std::ofstream(p) << text;
    return p;
}

TEST(ImageFields, ParaxialHeightsBecomeTheAnglesWhoseParaxialImageIsThere) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec file = readSceneFile(
        singletWith("veil_fields_paraxial", "fields_paraxial_image_mm = [0.0, [3.0, 4.0], 8.5]"),
        catalog);
    const SystemData& sys = file.prescription.system;
    EXPECT_EQ(sys.fieldKind, SystemData::FieldKind::AngleDeg);
    EXPECT_EQ(sys.givenFieldKind, SystemData::FieldKind::ParaxialImageHeightMm);
    ASSERT_EQ(sys.imageHeights.size(), 3u);
    EXPECT_EQ(sys.imageHeights[2].y, 8.5);
    // Paraxially h' = EFL tan(angle) at the back focus, for x and y alike.
    const FirstOrderData fo = computeFirstOrder(*file.model, file.model->primaryWavelength());
    const double deg = M_PI / 180.0;
    EXPECT_NEAR(std::tan(sys.fields[1].x * deg) * fo.eflMm, 3.0, 1e-9);
    EXPECT_NEAR(std::tan(sys.fields[1].y * deg) * fo.eflMm, 4.0, 1e-9);
    EXPECT_NEAR(std::tan(sys.fields[2].y * deg) * fo.eflMm, 8.5, 1e-9);
    EXPECT_EQ(sys.fields[0].y, 0.0);
    // veil info's paraxial image heights (analysis/lens/first_order.cpp) agree.
    ASSERT_EQ(fo.paraxialImageHeightsMm.size(), 3u);
    EXPECT_NEAR(fo.paraxialImageHeightsMm[2], 8.5, 1e-9);
}

TEST(ImageFields, RealHeightsAreWhereTheRealChiefRayLands) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const SceneSpec file = readSceneFile(
        singletWith("veil_fields_real", "fields_real_image_mm = [0.0, [3.0, 4.0], 8.5]"), catalog);
    const SystemData& sys = file.prescription.system;
    EXPECT_EQ(sys.fieldKind, SystemData::FieldKind::AngleDeg);
    EXPECT_EQ(sys.givenFieldKind, SystemData::FieldKind::RealImageHeightMm);
    const RayAimer aimer(*file.model, AimMode::Real);
    const int w = file.model->primaryWavelength();
    const SpotResult edge = computeSpot(*file.model, aimer, 2, w);
    EXPECT_NEAR(edge.chiefMm.x, 0.0, 1e-9);
    EXPECT_NEAR(edge.chiefMm.y, 8.5, 1e-6);
    const SpotResult corner = computeSpot(*file.model, aimer, 1, w);
    EXPECT_NEAR(corner.chiefMm.x, 3.0, 1e-6);
    EXPECT_NEAR(corner.chiefMm.y, 4.0, 1e-6);
    // Not the paraxial answer: the singlet's image surface sits 1 mm inside the paraxial
    // focus and its chief ray is distorted, so the angle differs a little.
    const FirstOrderData fo = computeFirstOrder(*file.model, w);
    const double paraxialDeg = std::atan(8.5 / fo.eflMm) * 180.0 / M_PI;
    EXPECT_GT(std::abs(sys.fields[2].y - paraxialDeg), 1e-3);
    EXPECT_LT(std::abs(sys.fields[2].y - paraxialDeg), 0.2);
}

// A finite object: image heights become object heights, h = h' / m paraxially.
TEST(ImageFields, AFiniteObjectGetsObjectHeights) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const std::filesystem::path p =
        std::filesystem::temp_directory_path() / "veil_fields_finite.toml";
    std::ofstream(p) << R"([system]
wavelengths_nm = [587.5618]
aperture = { object_na = 0.05 }
object_distance_mm = 300.0
fields_paraxial_image_mm = [0.0, 2.0]
surfaces = [
  { r = 59.26, t = 4.0, glass = "N-BK7", sd = 12.0, stop = true },
  { r = -394.56, t = 140.0, sd = 12.0 },
]
)";
    const SceneSpec file = readSceneFile(p, catalog);
    const SystemData& sys = file.prescription.system;
    EXPECT_EQ(sys.fieldKind, SystemData::FieldKind::ObjectHeightMm);
    const FirstOrderData fo = computeFirstOrder(*file.model, 0);
    ASSERT_NE(fo.paraxialMagnification, 0.0);
    EXPECT_NEAR(sys.fields[1].y * fo.paraxialMagnification, 2.0, 1e-9);
    ASSERT_EQ(fo.paraxialImageHeightsMm.size(), 2u);
}

// A Zemax file with FTYP 3 (real image height) loads with its fields, no error.
TEST(ImageFields, ZemaxRealImageHeightFieldsLoad) {
    const std::filesystem::path p = std::filesystem::temp_directory_path() / "veil_ftyp3.zmx";
    std::ofstream(p) << "VERS 190513 80 123\nMODE SEQ\nNAME singlet\nUNIT MM X W X CM MR CPMM\n"
                        "ENPD 20\nFTYP 3 0 2 1 0 0 0\nXFLN 0 0\nYFLN 0 8\nWAVM 1 0.5875618 1\n"
                        "PWAV 1\nSURF 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  CURV 0.016874789\n"
                        "  DISZ 4\n  GLAS N-BK7 0 0 1.5168 64.17\n  DIAM 12\nSURF 2\n"
                        "  CURV -0.0025344687\n  DISZ 96.71\n  DIAM 12\nSURF 3\n";
    const SceneSpec file = readSceneFile(p, GlassCatalog::builtIn());
    for (const ImportNote& n : file.prescription.report)
        EXPECT_NE(n.severity, ImportNote::Severity::Error) << n;
    const SystemData& sys = file.prescription.system;
    EXPECT_EQ(sys.givenFieldKind, SystemData::FieldKind::RealImageHeightMm);
    ASSERT_EQ(sys.fields.size(), 2u);
    const RayAimer aimer(*file.model, AimMode::Real);
    EXPECT_NEAR(computeSpot(*file.model, aimer, 1, 0).chiefMm.y, 8.0, 1e-6);
}

TEST(ImageFields, AHeightNoChiefRayReachesIsAnErrorNamingTheField) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const auto p = singletWith("veil_fields_far", "fields_real_image_mm = [0.0, 5000.0]");
    try {
        readSceneFile(p, catalog);
        FAIL() << "no error";
    } catch (const ModelError& e) {
        EXPECT_NE(std::string(e.what()).find("field 2"), std::string::npos) << e.what();
    }
}

TEST(ImageFields, TwoFieldFormsAreAnError) {
    const auto p = singletWith("veil_fields_two",
                               "fields_deg = [0.0, 3.0]\nfields_real_image_mm = [0.0, 5.0]");
    EXPECT_THROW(readSceneFile(p, GlassCatalog::builtIn()), ParseError);
}

}  // namespace
}  // namespace veil
