// A prescription written as a veil lens file reads back to the same prescription, value for
// value (lensdata/toml_writer.h): on real Zemax and CODE V files and on lens files that hold
// every surface kind (aspheres even and odd, Q-type, toroidal and crossed cylinders, breaks).

#include "lensdata/toml_writer.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "lensdata/lens_file.h"
#include "lensdata/toml_reader.h"

namespace veil {
namespace {

void expectSame(const Prescription& a, const Prescription& b, const std::string& file) {
    SCOPED_TRACE(file);
    EXPECT_EQ(a.system.name, b.system.name);
    EXPECT_EQ(a.system.notes, b.system.notes);
    EXPECT_EQ(a.system.aperture.kind, b.system.aperture.kind);
    EXPECT_EQ(a.system.aperture.value, b.system.aperture.value);
    EXPECT_EQ(a.system.fieldKind, b.system.fieldKind);
    EXPECT_EQ(a.system.rectangularField, b.system.rectangularField);
    ASSERT_EQ(a.system.fields.size(), b.system.fields.size());
    for (size_t i = 0; i < a.system.fields.size(); ++i) {
        const Field &f = a.system.fields[i], &g = b.system.fields[i];
        EXPECT_EQ(f.x, g.x) << i;
        EXPECT_EQ(f.y, g.y) << i;
        EXPECT_EQ(f.weight, g.weight) << i;
        EXPECT_EQ(f.vdx, g.vdx) << i;
        EXPECT_EQ(f.vdy, g.vdy) << i;
        EXPECT_EQ(f.vcx, g.vcx) << i;
        EXPECT_EQ(f.vcy, g.vcy) << i;
    }
    ASSERT_EQ(a.system.wavelengths.size(), b.system.wavelengths.size());
    for (size_t i = 0; i < a.system.wavelengths.size(); ++i) {
        EXPECT_EQ(a.system.wavelengths[i].nm, b.system.wavelengths[i].nm);
        EXPECT_EQ(a.system.wavelengths[i].weight, b.system.wavelengths[i].weight);
    }
    EXPECT_EQ(a.system.primaryWavelength, b.system.primaryWavelength);
    ASSERT_EQ(a.surfaces.size(), b.surfaces.size());
    for (size_t i = 0; i < a.surfaces.size(); ++i) {
        const Surface &s = a.surfaces[i], &t = b.surfaces[i];
        SCOPED_TRACE("surface " + std::to_string(i) + " " + s.name);
        EXPECT_EQ(s.name, t.name);
        EXPECT_EQ(s.comment, t.comment);
        EXPECT_EQ(s.curvature, t.curvature);
        EXPECT_EQ(s.conic, t.conic);
        EXPECT_EQ(s.asphere, t.asphere);
        EXPECT_EQ(s.oddAsphere, t.oddAsphere);
        EXPECT_EQ(s.qAsphere, t.qAsphere);
        EXPECT_EQ(s.anamorphic, t.anamorphic);
        EXPECT_EQ(s.thicknessMm, t.thicknessMm);
        EXPECT_EQ(s.material, t.material);
        EXPECT_EQ(s.clearSemiDiameterMm, t.clearSemiDiameterMm);
        EXPECT_EQ(s.mechSemiDiameterMm, t.mechSemiDiameterMm);
        EXPECT_EQ(s.semiDiameterAutomatic && s.clearSemiDiameterMm > 0.0, t.semiDiameterAutomatic);
        EXPECT_EQ(s.innerSemiDiameterMm, t.innerSemiDiameterMm);
        EXPECT_EQ(s.stop, t.stop);
        EXPECT_EQ(s.mirror, t.mirror);
        EXPECT_EQ(s.coordinateBreak, t.coordinateBreak);
        EXPECT_EQ(s.coating, t.coating);
    }
}

TEST(TomlWriter, RealAndEveryKindOfLensReadsBackTheSame) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const std::string data = VEIL_SOURCE_DIR "/tests/data/";
    for (const std::string file :
         {"zmx/US00583336-2-scaled.zmx", "zmx/US00583336-2-scaled-utf16le.zmx",
          "zmx/HoO-V2C18Ex03.zmx", "zmx/HoO-V2C18Ex27.zmx", "codev/ag_dblgauss.seq",
          "codev/double_gauss_50mm.seq", "codev/lens_reflection_test.seq",
          "codev/CODV_65988_noDOE.seq", "toml/cooke_triplet.toml", "toml/odd_asphere_singlet.toml",
          "toml/qtype_singlet.toml", "../../examples/lenses/anamorphic_cylinders.toml",
          "../../examples/lenses/catadioptric_2000mm.toml",
          "../../examples/lenses/newtonian_500mm.toml",
          "../../examples/lenses/longfocus_360mm.toml"}) {
        const Prescription lens = readLensFile(data + file, catalog);
        const std::string text = prescriptionToml(lens, catalog, file);
        const Prescription back = readTomlPrescriptionText(text, file + " as TOML", catalog);
        expectSame(lens, back, file);
        // Written twice, the same text.
        EXPECT_EQ(prescriptionToml(back, catalog, file), text) << file;
    }
}

// Names veil gives are left to it; others, comments and odd characters travel as written.
TEST(TomlWriter, NamesAndTextAreKeptAndEscaped) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const Prescription lens = readTomlPrescriptionText(
        "[system]\nname = \"a \\\"quoted\\\" lens\\twith a tab\"\naperture = { epd_mm = 10 }\n"
        "surfaces = [\n"
        "  { r = 50, t = 5, glass = { nd = 1.6, vd = 40, dpgf = 0.001 }, sd = 6, "
        "name = \"front-lens\", comment = \"back\\\\slash\" },\n"
        "  { r = -50, t = 40, sd = 6, coating = \"MgF2\" },\n"
        "  { image = true, sd = 3, name = \"ccd\" },\n]\n",
        "names.toml", catalog);
    const std::string text = prescriptionToml(lens, catalog, "names.toml");
    EXPECT_NE(text.find("name = \"front-lens\""), std::string::npos) << text;
    EXPECT_EQ(text.find("name = \"L1.back\""), std::string::npos) << text;
    EXPECT_NE(text.find("name = \"ccd\""), std::string::npos) << text;
    expectSame(lens, readTomlPrescriptionText(text, "back.toml", catalog), "names.toml");
}

}  // namespace
}  // namespace veil
