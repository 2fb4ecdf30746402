#include "lensdata/toml_reader.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <sstream>
#include <string>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "lensdata/toml_document.h"
#include "lensdata/toml_writer.h"

namespace veil {
namespace {

using ::testing::ElementsAre;
using ::testing::HasSubstr;

// A small catalog built in the test, so these tests do not depend on the built-in data.
// Sellmeier 1 coefficients (K1, L1, K2, L2, K3, L3) from the Schott catalog; S-BSL7 reuses
// N-BK7's, which is close enough for a reader test.
const GlassCatalog& testCatalog() {
    static const GlassCatalog catalog = [] {
        GlassCatalog c;
        auto add = [&](const char* name, const char* cat, std::vector<double> k) {
            c.add(Glass(name, cat, DispersionFormula::Sellmeier1, std::move(k)));
        };
        add("N-BK7", "SCHOTT",
            {1.03961212, 0.00600069867, 0.231792344, 0.0200179144, 1.01046945, 103.560653});
        add("N-SK16", "SCHOTT",
            {1.34317774, 0.00704687339, 0.241144399, 0.0229005, 0.994317969, 92.7508526});
        add("F2", "SCHOTT",
            {1.34533359, 0.00997743871, 0.209073176, 0.0470450767, 0.937357162, 111.886764});
        add("N-SF6", "SCHOTT",
            {1.77931763, 0.0133714182, 0.338149866, 0.0617533621, 2.08734474, 174.01759});
        add("N-BAF10", "SCHOTT",
            {1.5851495, 0.00926681282, 0.143559385, 0.0424489805, 1.08521269, 105.613573});
        add("S-BSL7", "OHARA",
            {1.03961212, 0.00600069867, 0.231792344, 0.0200179144, 1.01046945, 103.560653});
        return c;
    }();
    return catalog;
}

Prescription read(std::string_view text, const std::string& fileName = "lens.toml") {
    return readTomlPrescriptionText(text, fileName, testCatalog());
}

ParseError parseErrorOf(std::string_view text) {
    try {
        read(text);
    } catch (const ParseError& e) {
        return e;
    }
    ADD_FAILURE() << "expected a ParseError";
    return ParseError({}, "none");
}

void expectAt(const ParseError& e, int line, int column) {
    EXPECT_EQ(e.loc().file, "lens.toml");
    EXPECT_EQ(e.loc().line, line) << e.what();
    EXPECT_EQ(e.loc().column, column) << e.what();
}

// Complete Lenses

TEST(TomlReader, SingletEveryFieldLands) {
    const Prescription p = read(R"([system]
name = "Singlet f/4"
notes = "plano-convex, N-BK7"
wavelengths_nm = [486.1327, 587.5618, 656.2725]
aperture = { epd_mm = 25.0 }
fields_deg = [0.0, 5.0, 7.0]
field_weights = [1.0, 2.0, 0.5]
surfaces = [
  { r = 51.68, t = 4, glass = "N-BK7", sd = 13, mech_sd = 14, coating = "MgF2", comment = "cx" },
  { r = inf, t = 97.0, sd = 13.0, mech_sd = 14.0 },
]
)",
                                "singlet.toml");
    EXPECT_EQ(p.sourceFile, "singlet.toml");
    const SystemData& s = p.system;
    EXPECT_EQ(s.name, "Singlet f/4");
    EXPECT_EQ(s.notes, "plano-convex, N-BK7");
    ASSERT_EQ(s.wavelengths.size(), 3u);
    EXPECT_EQ(s.wavelengths[0].nm, 486.1327);
    EXPECT_EQ(s.wavelengths[2].nm, 656.2725);
    EXPECT_EQ(s.wavelengths[1].weight, 1.0);
    EXPECT_EQ(s.primaryWavelength, 1);  // the middle one by default
    EXPECT_EQ(s.aperture.kind, SystemAperture::Kind::EntrancePupilDiameter);
    EXPECT_EQ(s.aperture.value, 25.0);
    EXPECT_EQ(s.fieldKind, SystemData::FieldKind::AngleDeg);
    ASSERT_EQ(s.fields.size(), 3u);
    EXPECT_EQ(s.fields[1].x, 0.0);
    EXPECT_EQ(s.fields[1].y, 5.0);
    EXPECT_EQ(s.fields[2].y, 7.0);
    EXPECT_EQ(s.fields[1].weight, 2.0);
    EXPECT_EQ(s.fields[2].weight, 0.5);
    EXPECT_FALSE(s.rectangularField);
    EXPECT_TRUE(s.glassCatalogs.empty());
    EXPECT_TRUE(p.report.empty());

    ASSERT_EQ(p.surfaces.size(), 4u);
    const Surface& object = p.surfaces[0];
    EXPECT_EQ(object.name, "object");
    EXPECT_EQ(object.thicknessMm, kInfinity);
    EXPECT_TRUE(object.material.isAir());
    EXPECT_EQ(object.origin.line, 1);  // the [system] header: object_distance_mm not given

    const Surface& front = p.surfaces[1];
    EXPECT_EQ(front.name, "L1.front");
    EXPECT_DOUBLE_EQ(front.curvature, 1.0 / 51.68);
    EXPECT_EQ(front.thicknessMm, 4.0);
    EXPECT_EQ(front.material, Material::catalog("N-BK7"));
    EXPECT_EQ(front.clearSemiDiameterMm, 13.0);
    EXPECT_EQ(front.mechSemiDiameterMm, 14.0);
    EXPECT_EQ(front.coating, "MgF2");
    EXPECT_EQ(front.comment, "cx");
    EXPECT_FALSE(front.stop);
    EXPECT_FALSE(front.mirror);
    EXPECT_FALSE(front.hasAsphere());
    EXPECT_EQ(front.conic, 0.0);
    EXPECT_EQ(front.origin.file, "singlet.toml");
    EXPECT_EQ(front.origin.line, 9);
    EXPECT_EQ(front.origin.column, 3);

    const Surface& back = p.surfaces[2];
    EXPECT_EQ(back.name, "L1.back");
    EXPECT_EQ(back.curvature, 0.0);  // r = inf
    EXPECT_EQ(back.thicknessMm, 97.0);
    EXPECT_TRUE(back.material.isAir());
    EXPECT_EQ(back.origin.line, 10);

    const Surface& image = p.surfaces[3];
    EXPECT_EQ(image.name, "image");
    EXPECT_EQ(image.curvature, 0.0);
    EXPECT_EQ(image.clearSemiDiameterMm, 0.0);
    EXPECT_TRUE(image.material.isAir());
    EXPECT_EQ(image.origin.line, 10);  // implicit: placed by the last row's t

    ASSERT_EQ(p.elements().size(), 1u);
    EXPECT_EQ(p.stopIndex(), 1);  // no stop flagged: the first surface
}

TEST(TomlReader, CementedDoubletWithImageRow) {
    const Prescription p = read(R"([system]
name = "Achromat"
wavelengths_nm = [{ nm = 486.1327, weight = 1 }, { nm = 587.5618, weight = 2 }, 656.2725]
primary_wavelength = 3
glass_catalogs = ["schott"]
object_distance_mm = 1000
aperture = { object_na = 0.0125 }
fields_mm = [0.0, [3.0, 4.0], -10]
rectangular_field = true
surfaces = [
  { r = 61.07, t = 6.0, glass = "n-baf10", sd = 12.5 },
  { r = -44.17, t = 2.5, glass = "N-SF6", sd = 12.5 },
  { c = -0.007764, t = 5.0, sd = 12.5 },
  { stop = true, t = 90.0, sd = 11.0, name = "aperture_stop" },
  { image = true, r = -100.0, sd = 21.6, coating = "sensor", comment = "curved sensor" },
]
)");
    const SystemData& s = p.system;
    EXPECT_EQ(s.name, "Achromat");
    ASSERT_EQ(s.wavelengths.size(), 3u);
    EXPECT_EQ(s.wavelengths[0].nm, 486.1327);
    EXPECT_EQ(s.wavelengths[1].weight, 2.0);
    EXPECT_EQ(s.wavelengths[2].nm, 656.2725);
    EXPECT_EQ(s.wavelengths[2].weight, 1.0);
    EXPECT_EQ(s.primaryWavelength, 2);                    // 1-based in the file
    EXPECT_THAT(s.glassCatalogs, ElementsAre("SCHOTT"));  // the catalog's own spelling
    EXPECT_EQ(s.aperture.kind, SystemAperture::Kind::ObjectSpaceNA);
    EXPECT_EQ(s.aperture.value, 0.0125);
    EXPECT_EQ(s.fieldKind, SystemData::FieldKind::ObjectHeightMm);
    ASSERT_EQ(s.fields.size(), 3u);
    EXPECT_EQ(s.fields[1].x, 3.0);
    EXPECT_EQ(s.fields[1].y, 4.0);
    EXPECT_EQ(s.fields[2].x, 0.0);
    EXPECT_EQ(s.fields[2].y, -10.0);
    EXPECT_TRUE(s.rectangularField);

    ASSERT_EQ(p.surfaces.size(), 6u);
    EXPECT_EQ(p.surfaces[0].thicknessMm, 1000.0);
    EXPECT_EQ(p.surfaces[0].origin.line, 6);
    EXPECT_EQ(p.surfaces[0].origin.column, 22);
    EXPECT_EQ(p.surfaces[1].material, Material::catalog("N-BAF10"));  // catalog spelling
    EXPECT_EQ(p.surfaces[2].material, Material::catalog("N-SF6"));
    EXPECT_DOUBLE_EQ(p.surfaces[2].radiusMm(), -44.17);
    EXPECT_EQ(p.surfaces[3].curvature, -0.007764);
    EXPECT_TRUE(p.surfaces[3].material.isAir());
    EXPECT_TRUE(p.surfaces[4].stop);
    EXPECT_EQ(p.surfaces[4].curvature, 0.0);
    EXPECT_EQ(p.surfaces[4].clearSemiDiameterMm, 11.0);
    EXPECT_EQ(p.stopIndex(), 4);

    const Surface& image = p.surfaces[5];
    EXPECT_EQ(image.curvature, -0.01);
    EXPECT_EQ(image.clearSemiDiameterMm, 21.6);
    EXPECT_EQ(image.coating, "sensor");
    EXPECT_EQ(image.comment, "curved sensor");
    EXPECT_EQ(image.thicknessMm, 0.0);
    EXPECT_EQ(image.origin.line, 15);
    EXPECT_EQ(image.origin.column, 3);

    std::vector<std::string> names;
    for (const Surface& surface : p.surfaces) names.push_back(surface.name);
    EXPECT_THAT(names,
                ElementsAre("object", "L1.front", "L1.back", "L2.back", "aperture_stop", "image"));
    EXPECT_THAT(p.aliasesOf(2), ElementsAre("L2.front"));  // the cemented face
    EXPECT_EQ(p.elements().size(), 2u);
}

TEST(TomlReader, CookeTripletFile) {
    const std::filesystem::path path =
        std::filesystem::path(VEIL_SOURCE_DIR) / "tests/data/toml/cooke_triplet.toml";
    const Prescription p = readTomlPrescriptionFile(path, testCatalog());
    EXPECT_EQ(p.sourceFile, path.string());
    ASSERT_EQ(p.surfaces.size(), 8u);
    EXPECT_EQ(p.stopIndex(), 4);
    EXPECT_EQ(p.surfaces[4].name, "L2.back");
    EXPECT_THAT(p.aliasesOf(4), ElementsAre("stop"));
    EXPECT_EQ(p.surfaces[3].material, Material::catalog("F2"));
    EXPECT_EQ(p.surfaces[5].material, Material::catalog("N-SK16"));
    EXPECT_EQ(p.surfaces[6].comment, "back focal distance to the image");
    double track = 0.0;  // the sum of the thicknesses as written in the file
    for (int i = 1; i < p.imageIndex(); ++i) track += p.surfaces[i].thicknessMm;
    EXPECT_NEAR(track, 60.17675, 1e-12);
    EXPECT_EQ(p.system.aperture.value, 10.0);
    EXPECT_EQ(p.elements().size(), 3u);
}

TEST(TomlReader, ArrayOfTablesSpellingReadsTheSameRows) {
    // TOML's [[system.surfaces]] builds the same array as inline rows, one key per line.
    const Prescription p = read(R"([system]
aperture = { f_number = 2 }

[[system.surfaces]]
r = 25.0
t = 5
glass = "N-BK7"
asph = [1.5e-5, -2e-8]

[[system.surfaces]]
r = -60
t = 40
)");
    ASSERT_EQ(p.surfaces.size(), 4u);
    EXPECT_EQ(p.surfaces[1].material, Material::catalog("N-BK7"));
    EXPECT_EQ(p.surfaces[1].asphere[2], -2e-8);
    EXPECT_EQ(p.surfaces[1].origin.line, 4);
    EXPECT_EQ(p.surfaces[2].origin.line, 10);
    EXPECT_EQ(p.surfaces[2].thicknessMm, 40.0);
}

TEST(TomlReader, CookeTripletReadsWithTheBuiltInCatalog) {
    const std::filesystem::path path =
        std::filesystem::path(VEIL_SOURCE_DIR) / "tests/data/toml/cooke_triplet.toml";
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const Prescription p = readTomlPrescriptionFile(path, catalog);
    EXPECT_THAT(p.system.glassCatalogs, ElementsAre("SCHOTT"));
    // glass_catalogs = ["SCHOTT"] picks Schott's F2 (nd 1.62004, Schott data sheet) over
    // other catalogs' glasses of the same name.
    const Glass* f2 = catalog.find(p.surfaces[3].material.name, p.system.glassCatalogs);
    ASSERT_NE(f2, nullptr);
    EXPECT_EQ(f2->catalog(), "SCHOTT");
    EXPECT_NEAR(f2->index(kLineD), 1.62004, 2e-5);
}

// Materials and Surface Types

TEST(TomlReader, ModelGlassAndDefaults) {
    const Prescription p = read(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, glass = { nd = 1.7, vd = 30.5, dpgf = 0.01 } },
  { r = -40, t = 35, glass = "air" },
]
)");
    EXPECT_EQ(p.surfaces[1].material, Material::model(1.7, 30.5, 0.01));
    EXPECT_TRUE(p.surfaces[2].material.isAir());
    // Defaults: the d line, one on-axis field, no name.
    ASSERT_EQ(p.system.wavelengths.size(), 1u);
    EXPECT_EQ(p.system.wavelengths[0].nm, kLineD);
    EXPECT_EQ(p.system.primaryWavelength, 0);
    ASSERT_EQ(p.system.fields.size(), 1u);
    EXPECT_EQ(p.system.fields[0].y, 0.0);
    EXPECT_EQ(p.system.aperture.kind, SystemAperture::Kind::ImageSpaceFNumber);
    EXPECT_EQ(p.system.aperture.value, 4.0);
    EXPECT_EQ(p.system.name, "");
}

TEST(TomlReader, ModelGlassNeedsNdAndVd) {
    ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, glass = { nd = 1.7 } },
]
)");
    expectAt(e, 4, 28);
    EXPECT_EQ(e.message(),
              "missing key 'vd' (Abbe number (0: no dispersion)) in system.surfaces[1].glass");

    e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5, glass = { nd = 0.9, vd = 40 } }]
)");
    expectAt(e, 3, 45);
    EXPECT_EQ(e.message(), "system.surfaces[1].glass.nd must be >= 1 (got 0.9)");

    e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5, glass = { nd = 1.5, vd = -2 } }]
)");
    expectAt(e, 3, 55);
    EXPECT_EQ(e.message(), "system.surfaces[1].glass.vd must be >= 0 (got -2)");
}

TEST(TomlReader, CassegrainMirrors) {
    const Prescription p = read(R"([system]
aperture = { epd_mm = 100 }
fields_deg = [0, 0.5]
surfaces = [
  { r = -400, t = -150, mirror = true, conic = -1, sd = 50, glass = "AIR" },
  { r = -150, t = 180, mirror = true, conic = -2.5, sd = 15 },
]
)");
    ASSERT_EQ(p.surfaces.size(), 4u);
    EXPECT_TRUE(p.surfaces[1].mirror);
    EXPECT_EQ(p.surfaces[1].name, "M1");
    EXPECT_EQ(p.surfaces[2].name, "M2");
    EXPECT_EQ(p.surfaces[1].thicknessMm, -150.0);
    EXPECT_EQ(p.surfaces[1].conic, -1.0);
    EXPECT_EQ(p.surfaces[2].conic, -2.5);
    for (const Surface& s : p.surfaces) EXPECT_TRUE(s.material.isAir()) << s;
    EXPECT_TRUE(p.elements().empty());
}

// A Cassegrain primary with a central hole: hole_sd is the inner edge of its clear annulus.
TEST(TomlReader, HoleSdIsTheInnerSemiDiameter) {
    const Prescription p = read(R"([system]
aperture = { epd_mm = 100 }
surfaces = [
  { r = -400, t = -150, mirror = true, conic = -1, sd = 50, hole_sd = 9.5 },
  { r = -150, t = 180, mirror = true, conic = -2.5, sd = 15 },
]
)");
    EXPECT_EQ(p.surfaces[1].innerSemiDiameterMm, 9.5);
    EXPECT_EQ(p.surfaces[1].clearSemiDiameterMm, 50.0);
    EXPECT_EQ(p.surfaces[2].innerSemiDiameterMm, 0.0);  // default: no hole
    std::ostringstream os;
    os << p.surfaces[1];
    EXPECT_THAT(os.str(), HasSubstr(" sd=50 hole=9.5"));
}

// The hole must lie inside the clear aperture: errors at the hole_sd value.
TEST(TomlReader, HoleSdErrors) {
    {
        const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = -400, t = -150, mirror = true, sd = 50, hole_sd = 50 }]
)");
        expectAt(e, 3, 69);
        EXPECT_EQ(e.message(),
                  "hole_sd = 50 mm must be smaller than the clear semi-diameter sd = 50 mm");
    }
    {
        const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = -400, t = -150, mirror = true, hole_sd = 5 }]
)");
        expectAt(e, 3, 60);
        EXPECT_EQ(e.message(),
                  "hole_sd needs the clear semi-diameter sd of the annulus around the hole");
    }
    {
        const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = -400, t = -150, mirror = true, sd = 50, hole_sd = -1 }]
)");
        expectAt(e, 3, 69);
        EXPECT_EQ(e.message(), "system.surfaces[1].hole_sd must be >= 0 (got -1)");
    }
    {
        const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5, sd = 10 }, { image = true, sd = 10, hole_sd = 2 }]
)");
        expectAt(e, 3, 76);
        EXPECT_EQ(e.message(), "the image row takes no 'hole_sd' (the image surface has no hole)");
    }
}

// Prescription::validate() checks holes built in code (or by an importer) and names the
// surface.
TEST(TomlReader, HoleModelErrorsNameTheSurface) {
    Prescription p = read(R"([system]
aperture = { epd_mm = 100 }
surfaces = [
  { r = -400, t = -150, mirror = true, sd = 50 },
  { r = -150, t = 180, mirror = true, sd = 15 },
]
)");
    auto modelErrorOf = [](const Prescription& q) -> std::string {
        try {
            q.validate();
        } catch (const ModelError& e) {
            return e.object() + " | " + e.what();
        }
        return "no error";
    };
    p.surfaces[1].innerSemiDiameterMm = 9.5;
    EXPECT_EQ(modelErrorOf(p), "no error");
    p.surfaces[1].innerSemiDiameterMm = 50.0;
    EXPECT_THAT(modelErrorOf(p),
                HasSubstr("M1 | M1: hole semi-diameter 50.000000 mm must be smaller than the clear "
                          "semi-diameter 50.000000 mm"));
    p.surfaces[1].innerSemiDiameterMm = -1.0;
    EXPECT_THAT(modelErrorOf(p), HasSubstr("M1 | M1: hole semi-diameter must be finite and >= 0"));
    p.surfaces[1].innerSemiDiameterMm = 0.0;
    p.surfaces[2].clearSemiDiameterMm = 0.0;
    p.surfaces[2].innerSemiDiameterMm = 3.0;
    // A hole without a clear semi-diameter: the scene traces one around it (a Maksutov's
    // meniscus obscuration, which files give without CIR).
    EXPECT_EQ(modelErrorOf(p), "no error");
    p.surfaces[2].innerSemiDiameterMm = 0.0;
    p.surfaces[3].clearSemiDiameterMm = 10.0;
    p.surfaces[3].innerSemiDiameterMm = 1.0;
    EXPECT_THAT(modelErrorOf(p),
                HasSubstr("image | image: the object and image surfaces cannot have a hole"));
}

TEST(TomlReader, ManginMirrorKeepsTheGlass) {
    const Prescription p = read(R"([system]
aperture = { epd_mm = 40 }
surfaces = [
  { r = 200, t = 8, glass = "N-BK7", sd = 30 },
  { r = 300, t = -8, mirror = true, sd = 30 },
  { r = 200, t = -100, sd = 30 },
]
)");
    // Behind the mirror the light runs back through the N-BK7 it came from.
    EXPECT_EQ(p.surfaces[2].material, Material::catalog("N-BK7"));
    EXPECT_TRUE(p.surfaces[3].material.isAir());
    EXPECT_EQ(p.elements().size(), 1u);
}

TEST(TomlReader, GlassOnAMirrorMustBeTheIncidentMedium) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { epd_mm = 40 }
surfaces = [
  { r = -400, t = -150, mirror = true, glass = "N-BK7" },
]
)");
    expectAt(e, 4, 48);
    EXPECT_THAT(e.message(), HasSubstr("a mirror keeps the medium"));
    EXPECT_THAT(e.message(), HasSubstr("incident medium AIR"));
}

TEST(TomlReader, EvenAsphere) {
    const Prescription p = read(R"([system]
aperture = { f_number = 2 }
surfaces = [
  { r = 25, t = 5, glass = "N-BK7", conic = -0.8, asph_r2 = 1e-3, asph = [1.5e-5, -2e-8, 3e-11] },
  { r = -60, t = 40 },
]
)");
    const Surface& s = p.surfaces[1];
    EXPECT_EQ(s.conic, -0.8);
    EXPECT_EQ(s.asphere[0], 1e-3);    // r^2
    EXPECT_EQ(s.asphere[1], 1.5e-5);  // A4
    EXPECT_EQ(s.asphere[2], -2e-8);   // A6
    EXPECT_EQ(s.asphere[3], 3e-11);   // A8
    for (size_t i = 4; i < s.asphere.size(); ++i) EXPECT_EQ(s.asphere[i], 0.0);
    EXPECT_TRUE(s.hasAsphere());
    EXPECT_FALSE(p.surfaces[2].hasAsphere());
}

TEST(TomlReader, AsphereHasAtMostNineTerms) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 2 }
surfaces = [{ r = 25, t = 5, asph = [1, 2, 3, 4, 5, 6, 7, 8, 9, 10] }]
)");
    expectAt(e, 3, 37);
    EXPECT_EQ(e.message(), "asph lists A4, A6, ..., A20: at most 9 terms (got 10)");
}

// Unknown Keys

TEST(TomlReader, UnknownKeyAtTopLevel) {
    const ParseError e = parseErrorOf(R"(title = "x"
[system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 1, 1);
    EXPECT_EQ(e.message(), "unknown key 'title' at the top level");
}

TEST(TomlReader, UnknownKeyInSystem) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
wavelength_nm = [550.0]
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 3, 1);
    EXPECT_EQ(e.message(),
              "unknown key 'wavelength_nm' in [system] (did you mean 'wavelengths_nm'?)");
}

TEST(TomlReader, UnknownKeyInsideASurfaceRow) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, glass = "N-BK7", sdd = 10 },
  { r = -40, t = 30 },
]
)");
    expectAt(e, 4, 37);
    EXPECT_EQ(e.message(), "unknown key 'sdd' in system.surfaces[1] (did you mean 'sd'?)");
}

TEST(TomlReader, UnknownKeyInsideTheAperture) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4, fnum = 4 }
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 2, 28);
    EXPECT_EQ(e.message(), "unknown key 'fnum' in [system.aperture]");
}

TEST(TomlReader, LensFileRejectsSectionsOfLaterFeatures) {
    const char* text = R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5 }]

[detector]
pixels = [640, 480]
)";
    const ParseError e = parseErrorOf(text);
    expectAt(e, 5, 2);
    EXPECT_EQ(e.message(), "unknown table [detector]");

    // As part of a scene, the lens reader leaves the other sections to their readers.
    TomlDocument doc = TomlDocument::fromString(text, "scene.toml");
    const Prescription p = readTomlPrescription(doc, testCatalog());
    EXPECT_EQ(p.surfaces.size(), 3u);
    EXPECT_THROW(doc.checkAllUsed(), ParseError);
    doc.root().require("detector").asTable().require("pixels");
    EXPECT_NO_THROW(doc.checkAllUsed());
}

// Wrong Values

TEST(TomlReader, WrongType) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = "5" }]
)");
    expectAt(e, 3, 27);
    EXPECT_EQ(e.message(), "system.surfaces[1].t must be a number, not a string");
}

TEST(TomlReader, TomlSyntaxError) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40 t = 5 }]
)");
    expectAt(e, 3, 22);
}

TEST(TomlReader, UnknownGlassSuggestsNames) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, glass = "N-BK8" },
  { r = -40, t = 30 },
]
)");
    expectAt(e, 4, 28);
    EXPECT_THAT(e.message(), HasSubstr("unknown glass 'N-BK8'"));
    EXPECT_THAT(e.message(), HasSubstr("did you mean 'N-BK7'"));
}

TEST(TomlReader, UnknownGlassCatalog) {
    const ParseError e = parseErrorOf(R"([system]
glass_catalogs = ["OHARA", "SHOTT"]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 2, 28);
    EXPECT_THAT(e.message(), HasSubstr("unknown glass catalog 'SHOTT'"));
    EXPECT_THAT(e.message(), HasSubstr("'SCHOTT'"));
}

// Q-type rows: qbfs or qcon with a normalisation radius and 1 to 9 terms; errors at the value.
TEST(TomlReader, QTypeRows) {
    const Prescription p = read(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, glass = "N-BK7", sd = 10, qbfs = { norm_radius_mm = 10.0, terms = [0.01, -0.002] } },
  { r = -60, conic = -1.2, t = 30, sd = 10, qcon = { norm_radius_mm = 10.5, terms = [1e-3] } },
]
)");
    ASSERT_TRUE(p.surfaces[1].qAsphere);
    EXPECT_EQ(p.surfaces[1].qAsphere->kind, QAsphere::Kind::Bfs);
    EXPECT_EQ(p.surfaces[1].qAsphere->normRadiusMm, 10.0);
    EXPECT_EQ(p.surfaces[1].qAsphere->terms, (std::vector<double>{0.01, -0.002}));
    ASSERT_TRUE(p.surfaces[2].qAsphere);
    EXPECT_EQ(p.surfaces[2].qAsphere->kind, QAsphere::Kind::Con);
    EXPECT_TRUE(p.surfaces[2].hasAsphere());
    auto message = [](const std::string& row) {
        return parseErrorOf("[system]\naperture = { f_number = 4 }\nsurfaces = [" + row + "]\n")
            .message();
    };
    EXPECT_NE(message("{ r = 40, t = 5, conic = -1, qbfs = { norm_radius_mm = 10.0, terms = [0.1] } }")
                  .find("conic must be 0"),
              std::string::npos);
    EXPECT_NE(message("{ r = 40, t = 5, qcon = { norm_radius_mm = 0.0, terms = [0.1] } }")
                  .find("must be > 0"),
              std::string::npos);
    EXPECT_NE(message("{ r = 40, t = 5, qcon = { norm_radius_mm = 5.0, terms = [] } }")
                  .find("1 to 9 coefficients"),
              std::string::npos);
    EXPECT_NE(message("{ r = 40, t = 5, asph = [1e-6], qcon = { norm_radius_mm = 5.0, terms = [1.0] } }")
                  .find("takes no 'asph'"),
              std::string::npos);
}

// Toroidal and biconic rows: the row's r and conic are the y-z section's, the table holds the
// x one; errors at the value.
TEST(TomlReader, AnamorphicRows) {
    const Prescription p = read(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, glass = "N-BK7", sd = 10, asph = [1e-6], toroidal = { x_r = inf } },
  { r = -60, conic = -1.2, t = 30, sd = 10, biconic = { x_c = -0.02, x_conic = 0.5 } },
  { r = inf, t = 2, glass = "N-BK7", sd = 10, toroidal = { x_r = 35 } },
  { t = 20, sd = 10 },
]
)");
    ASSERT_TRUE(p.surfaces[1].anamorphic);
    EXPECT_EQ(p.surfaces[1].anamorphic->kind, Anamorphic::Kind::Toroidal);
    EXPECT_EQ(p.surfaces[1].anamorphic->xCurvature, 0.0);
    EXPECT_EQ(p.surfaces[1].asphere[1], 1e-6);
    ASSERT_TRUE(p.surfaces[2].anamorphic);
    EXPECT_EQ(p.surfaces[2].anamorphic->kind, Anamorphic::Kind::Biconic);
    EXPECT_EQ(p.surfaces[2].anamorphic->xCurvature, -0.02);
    EXPECT_EQ(p.surfaces[2].anamorphic->xConic, 0.5);
    EXPECT_EQ(p.surfaces[2].conic, -1.2);
    EXPECT_DOUBLE_EQ(p.surfaces[3].anamorphic->xCurvature, 1.0 / 35.0);
    EXPECT_EQ(p.firstAnamorphic(), 1);
    auto error = [](const std::string& row) {
        return parseErrorOf("[system]\naperture = { f_number = 4 }\nsurfaces = [" + row + "]\n");
    };
    const ParseError k = error("{ r = 40, t = 5, toroidal = { x_r = 30, x_conic = -1 } }");
    expectAt(k, 3, 63);  // at the value
    EXPECT_THAT(k.message(), HasSubstr("no x conic"));
    EXPECT_THAT(error("{ r = 40, t = 5, toroidal = { x_r = 30 }, biconic = { x_r = 30 } }")
                    .message(),
                HasSubstr("toroidal or biconic, not both"));
    EXPECT_THAT(error("{ r = 40, t = 5, biconic = { x_conic = -1 } }").message(),
                HasSubstr("needs its x section"));
    EXPECT_THAT(error("{ r = 40, t = 5, asph = [1e-6], biconic = { x_r = 30 } }").message(),
                HasSubstr("biconic surface takes no 'asph'"));
    EXPECT_THAT(error("{ r = 40, t = 5, toroidal = { x_r = 30, x_c = 0.1 } }").message(),
                HasSubstr("not both"));
    EXPECT_THAT(error("{ break = { tilt_deg = [1, 0, 0] }, t = 5, toroidal = { x_r = 30 } }")
                    .message(),
                HasSubstr("takes no 'toroidal'"));
}

TEST(TomlReader, RadiusAndCurvatureTogether) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, c = 0.025, t = 5 }]
)");
    expectAt(e, 3, 27);
    EXPECT_EQ(e.message(), "give the radius r or the curvature c, not both");
}

TEST(TomlReader, NegativeSemiDiameter) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5, sd = -1 }]
)");
    expectAt(e, 3, 35);
    EXPECT_EQ(e.message(), "system.surfaces[1].sd must be >= 0 (got -1)");
}

TEST(TomlReader, MissingThickness) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, glass = "N-BK7" },
  { r = -40 },
]
)");
    expectAt(e, 5, 3);
    EXPECT_THAT(e.message(), HasSubstr("missing key 't' (thickness to the next surface"));
    EXPECT_THAT(e.message(), HasSubstr("in system.surfaces[2]"));
}

TEST(TomlReader, OnlyOneStop) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, stop = true },
  { r = -40, t = 30, stop = true },
]
)");
    expectAt(e, 5, 29);
    EXPECT_EQ(e.message(), "only one surface can be the stop; system.surfaces[1] already is");
}

TEST(TomlReader, NoSurfaces) {
    ParseError e = parseErrorOf("[system]\naperture = { f_number = 4 }\nsurfaces = []\n");
    expectAt(e, 3, 12);
    e = parseErrorOf("[system]\naperture = { f_number = 4 }\nsurfaces = [{ image = true }]\n");
    EXPECT_EQ(e.message(), "surfaces needs at least one surface row before the image");
    e = parseErrorOf("[system]\naperture = { f_number = 4 }\n");
    expectAt(e, 1, 1);
    EXPECT_THAT(e.message(), HasSubstr("missing key 'surfaces'"));
    e = parseErrorOf("name = \"x\"\n");
    EXPECT_THAT(e.message(), HasSubstr("missing key 'system'"));
}

TEST(TomlReader, ImageRow) {
    ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, image = true },
  { r = -40, t = 30 },
]
)");
    expectAt(e, 4, 28);
    EXPECT_THAT(e.message(), HasSubstr("only the last row can be the image row"));
    e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5 },
  { image = true, t = 1 },
]
)");
    expectAt(e, 5, 23);
    EXPECT_EQ(e.message(),
              "the image row takes no 't' (the previous row's t is the distance to the image)");
}

TEST(TomlReader, ApertureNeedsExactlyOneKey) {
    ParseError e = parseErrorOf("[system]\nsurfaces = [{ r = 40, t = 5 }]\n");
    expectAt(e, 1, 1);
    EXPECT_THAT(e.message(), HasSubstr("missing key 'aperture'"));
    e = parseErrorOf("[system]\naperture = {}\nsurfaces = [{ r = 40, t = 5 }]\n");
    expectAt(e, 2, 12);
    e = parseErrorOf(
        "[system]\naperture = { epd_mm = 10, f_number = 4 }\nsurfaces = [{ r = 40, t = 5 }]\n");
    expectAt(e, 2, 38);  // the second one in the file
    EXPECT_THAT(e.message(), HasSubstr("not 'f_number' and 'epd_mm'"));
    e = parseErrorOf("[system]\naperture = 2.0\nsurfaces = [{ r = 40, t = 5 }]\n");
    EXPECT_EQ(e.message(),
              "system.aperture must be a table such as { f_number = 2.0 }, not a "
              "floating-point number");
}

TEST(TomlReader, FloatByStopNeedsTheStopSize) {
    ParseError e = parseErrorOf(R"([system]
aperture = { float_by_stop = true }
surfaces = [{ r = 40, t = 5 }, { stop = true, t = 30 }]
)");
    expectAt(e, 2, 30);
    EXPECT_EQ(e.message(),
              "float_by_stop takes the aperture from the stop's sd, but the stop "
              "system.surfaces[2] has none");
    const Prescription p = read(R"([system]
aperture = { float_by_stop = true }
surfaces = [{ r = 40, t = 5 }, { stop = true, t = 30, sd = 4 }]
)");
    EXPECT_EQ(p.system.aperture.kind, SystemAperture::Kind::FloatByStop);
}

TEST(TomlReader, ObjectNaNeedsAFiniteObject) {
    const ParseError e = parseErrorOf(R"([system]
aperture = { object_na = 0.1 }
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 2, 26);
    EXPECT_THAT(e.message(), HasSubstr("finite object_distance_mm"));
}

TEST(TomlReader, FieldErrors) {
    ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
fields_deg = [0, 90]
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 3, 18);
    EXPECT_EQ(e.message(), "system.fields_deg[2] must be strictly between -90 and 90 (got 90)");

    e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
fields_mm = [0, 5]
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 3, 13);
    EXPECT_THAT(e.message(), HasSubstr("need a finite object_distance_mm"));

    e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
fields_deg = [0, 5]
field_weights = [1]
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 4, 17);
    EXPECT_EQ(e.message(), "field_weights has 1 entries for 2 fields");

    e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
fields_deg = [0, [1, 2, 3]]
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 3, 18);
    EXPECT_EQ(e.message(), "system.fields_deg[2] must be a pair [x, y] (got 3 numbers)");
}

TEST(TomlReader, WavelengthChecks) {
    ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
wavelengths_nm = [486.1, 587.6, 656.3]
primary_wavelength = 4
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 4, 22);
    EXPECT_EQ(e.message(), "system.primary_wavelength must be between 1 and 3 (got 4)");

    e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
wavelengths_nm = [-550]
surfaces = [{ r = 40, t = 5 }]
)");
    expectAt(e, 3, 19);

    // Micrometres by mistake: read, but reported.
    const Prescription p = read(R"([system]
aperture = { f_number = 4 }
wavelengths_nm = [0.5876]
surfaces = [{ r = 40, t = 5 }]
)");
    ASSERT_EQ(p.report.size(), 1u);
    EXPECT_EQ(p.report[0].severity, ImportNote::Severity::Warning);
    EXPECT_EQ(p.report[0].loc.line, 3);
    EXPECT_EQ(p.report[0].message,
              "wavelength 0.5876 nm is below 100 nm; wavelengths_nm is in nm, not um");
}

TEST(TomlReader, SurfaceNames) {
    ParseError e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [
  { r = 40, t = 5, glass = "N-BK7" },
  { r = -40, t = 30, name = "L1.front" },
]
)");
    expectAt(e, 5, 29);
    EXPECT_EQ(e.message(), "surface name 'L1.front' is also the name of system.surfaces[1]");

    e = parseErrorOf(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5, name = "front face" }]
)");
    expectAt(e, 3, 37);
    EXPECT_THAT(e.message(), HasSubstr("letters, digits"));

    const Prescription p = read(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5, glass = "N-BK7", name = "window" }, { t = 10 }]
)");
    EXPECT_EQ(p.surfaces[1].name, "window");
    EXPECT_EQ(p.surfaces[2].name, "L1.back");
}

TEST(TomlReader, ModelErrorsNameTheSurface) {
    try {
        read(R"([system]
aperture = { f_number = 4 }
surfaces = [{ r = 40, t = 5, glass = "N-BK7", sd = 15, mech_sd = 14 }, { t = 10 }]
)");
        FAIL() << "expected a ModelError";
    } catch (const ModelError& e) {
        EXPECT_EQ(e.object(), "L1.front");
        EXPECT_THAT(e.what(), HasSubstr("exceeds the mechanical semi-diameter"));
    }
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// Unphysical but parseable prescriptions: a warning naming the surface and its line, the
// lens still read. Plain lenses and a mirror system's negative gaps get none.
std::vector<std::string> warnings(std::string_view surfaces) {
    const std::string text = "[system]\nwavelengths_nm = [587.56]\naperture = { epd_mm = 10 }\n"
                             "fields_deg = [0]\nsurfaces = [\n" +
                             std::string(surfaces) + "]\n";
    std::vector<std::string> out;
    for (const ImportNote& n : read(text).report)
        if (n.severity == ImportNote::Severity::Warning)
            out.push_back(n.loc.str() + ": " + n.message);
    return out;
}

TEST(TomlReader, UnphysicalValuesGetWarningsNamingTheSurface) {
    EXPECT_THAT(warnings("{ r = 1e-12, t = 4, glass = \"N-BK7\", sd = 10.5 },\n"
                         "{ r = -50, t = 90, sd = 10.5 },\n"),
                ElementsAre(HasSubstr("lens.toml:6:"), HasSubstr("lens.toml:6:")));
    const auto tiny = warnings("{ r = 1e-12, t = 4, glass = \"N-BK7\", sd = 10.5 },\n"
                               "{ r = -50, t = 90, sd = 10.5 },\n");
    EXPECT_THAT(tiny[0], HasSubstr("L1.front: radius 1e-12 mm is below a micrometre"));
    EXPECT_THAT(tiny[1], HasSubstr("exceeds the height the surface reaches, 1e-12 mm"));
    // sd beyond |R| (a hemisphere of radius 8 cannot be 10.5 high); a conic reaches
    // |R| / sqrt(1 + k), a paraboloid any height.
    EXPECT_THAT(warnings("{ r = 8, t = 4, glass = \"N-BK7\", sd = 10.5 },\n"
                         "{ r = -50, t = 90, sd = 10.5 },\n"),
                ElementsAre(HasSubstr("clear semi-diameter 10.5 mm exceeds the height the "
                                      "surface reaches, 8 mm")));
    EXPECT_THAT(warnings("{ r = 8, conic = -1, t = 4, glass = \"N-BK7\", sd = 10.5 },\n"
                         "{ r = -50, t = 90, sd = 10.5 },\n"),
                ElementsAre());
    // Glass of zero or negative thickness; a negative air gap between two lenses.
    EXPECT_THAT(warnings("{ r = 50, t = 0, glass = \"N-BK7\", sd = 5 },\n"
                         "{ r = -50, t = 90, sd = 5 },\n"),
                ElementsAre(HasSubstr("L1.front: thickness 0 mm in N-BK7 (glass of no "
                                      "thickness)")));
    EXPECT_THAT(warnings("{ r = 50, t = -3, glass = \"N-BK7\", sd = 5 },\n"
                         "{ r = -50, t = 90, sd = 5 },\n"),
                ElementsAre(HasSubstr("runs against the light (no mirror turns it)")));
    EXPECT_THAT(warnings("{ r = 50, t = 3, glass = \"N-BK7\", sd = 5 },\n"
                         "{ r = -50, t = -1, sd = 5 },\n"
                         "{ r = 40, t = 3, glass = \"N-BK7\", sd = 5 },\n"
                         "{ r = -40, t = 90, sd = 5 },\n"),
                ElementsAre(HasSubstr("L1.back: air gap -1 mm runs against the light")));
    // Not warned: a stop placed back by a negative gap from a dummy plane, and a mirror
    // system, whose gaps after the mirror are negative.
    EXPECT_THAT(warnings("{ t = 5 },\n{ stop = true, t = -5, sd = 5 },\n"
                         "{ r = 50, t = 3, glass = \"N-BK7\", sd = 5 },\n"
                         "{ r = -50, t = 90, sd = 5 },\n"),
                ElementsAre());
    EXPECT_THAT(warnings("{ t = 100, sd = 20 },\n{ r = -400, t = -150, mirror = true, sd = 20 },\n"),
                ElementsAre());
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// A glass by its dispersion formula and coefficients, and by a table: read, written back and
// read again to the same material; a formula veil does not know is an error naming them.
TEST(TomlReader, GlassesByFormulaAndByTable) {
    const std::string text = R"([system]
aperture = { epd_mm = 10 }
surfaces = [
  { r = 40, t = 3, glass = { name = "NOA61", formula = "Schott", coefficients = [2.36390625, 0.0, 0.025493134, -0.000580235, -0.349933e-5, 0.445404e-7] }, sd = 6 },
  { r = -40, t = 1, sd = 6 },
  { r = 30, t = 2, glass = { name = "E48", nm = [486.1, 587.6, 656.3], n = [1.5378, 1.53116, 1.5286] }, sd = 6 },
  { r = -30, t = 30, sd = 6 },
]
)";
    const Prescription p = read(text);
    EXPECT_EQ(p.surfaces[1].material.kind, Material::Kind::Formula);
    EXPECT_NEAR(p.surfaces[1].material.ownGlass()->index(550.0), 1.5626000901577761, 1e-9);
    EXPECT_EQ(p.surfaces[3].material.kind, Material::Kind::Table);
    EXPECT_NEAR(p.surfaces[3].material.ownGlass()->index(587.6), 1.53116, 1e-14);
    const Prescription back = readTomlPrescriptionText(
        prescriptionToml(p, testCatalog(), "lens.toml"), "back.toml", testCatalog());
    EXPECT_EQ(back.surfaces[1].material, p.surfaces[1].material);
    EXPECT_EQ(back.surfaces[3].material, p.surfaces[3].material);
    const ParseError e = parseErrorOf(R"([system]
aperture = { epd_mm = 10 }
surfaces = [
  { r = 40, t = 3, glass = { name = "X", formula = "Cauchy", coefficients = [1.5] }, sd = 6 },
  { r = -40, t = 30, sd = 6 },
]
)");
    EXPECT_THAT(e.what(), HasSubstr("unknown dispersion formula; the formulas are 'Schott'"));
    EXPECT_EQ(e.loc().line, 4) << e.what();
}

}  // namespace
}  // namespace veil
