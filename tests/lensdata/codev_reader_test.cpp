// CODE V .seq import (lensdata/codev_reader.h): the double Gauss written as CODE V writes it
// reads into the same prescription as the TOML example; the syntax (curvature mode,
// continuation lines, comments, glass codes and names, aspheres, mirrors, units) reads as
// CODE V defines it; what veil cannot represent is an Error note at its line.

#include "lensdata/codev_reader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "lensdata/glass_catalog.h"
#include "lensdata/lens_file.h"
#include "lensdata/prescription.h"

namespace veil {
namespace {

const ImportNote* findNote(const Prescription& rx, const std::string& text) {
    for (const ImportNote& n : rx.report)
        if (n.message.find(text) != std::string::npos) return &n;
    return nullptr;
}

std::string reportText(const Prescription& rx) {
    std::string s;
    for (const ImportNote& n : rx.report) s += n.message + "\n";
    return s;
}

TEST(CodeVReader, DoubleGaussReadsAsTheTomlExample) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const Prescription seq =
        readLensFile(VEIL_SOURCE_DIR "/tests/data/codev/double_gauss_50mm.seq", catalog);
    const Prescription toml =
        readLensFile(VEIL_SOURCE_DIR "/examples/lenses/double_gauss_50mm.toml", catalog);
    ASSERT_EQ(seq.surfaces.size(), toml.surfaces.size());
    EXPECT_TRUE(std::isinf(seq.surfaces[0].thicknessMm));
    for (size_t i = 1; i < seq.surfaces.size(); ++i) {
        SCOPED_TRACE(i);
        const Surface& a = seq.surfaces[i];
        const Surface& b = toml.surfaces[i];
        EXPECT_NEAR(a.curvature, b.curvature, 1e-15);
        EXPECT_DOUBLE_EQ(a.thicknessMm, b.thicknessMm);
        EXPECT_EQ(a.material.kind, b.material.kind);
        EXPECT_NEAR(a.material.nd, b.material.nd, 1e-12);
        EXPECT_NEAR(a.material.vd, b.material.vd, 1e-9);
        EXPECT_EQ(a.clearSemiDiameterMm, b.clearSemiDiameterMm);
        EXPECT_EQ(a.mechSemiDiameterMm, b.mechSemiDiameterMm);
        EXPECT_EQ(a.stop, b.stop);
    }
    EXPECT_EQ(seq.system.name, "Double Gauss 50 mm f/2 (Tronnier)");
    EXPECT_EQ(seq.system.aperture.kind, SystemAperture::Kind::EntrancePupilDiameter);
    EXPECT_EQ(seq.system.aperture.value, 25.0);
    ASSERT_EQ(seq.system.fields.size(), 4u);
    EXPECT_EQ(seq.system.fields[3].y, 22.0);
    ASSERT_EQ(seq.system.wavelengths.size(), 3u);
    EXPECT_EQ(seq.system.wavelengths[seq.system.primaryWavelength].nm, 587.5618);
    // What was read but not imported is said once per command, as Info; nothing worse.
    for (const ImportNote& n : seq.report) EXPECT_EQ(n.severity, ImportNote::Severity::Info) << n;
    EXPECT_EQ(findNote(seq, "VUY"), nullptr) << reportText(seq);  // imported (all zero)
    for (const Field& f : seq.system.fields) EXPECT_FALSE(f.vignetted());
    EXPECT_NE(findNote(seq, "PIM"), nullptr) << reportText(seq);
}

// CODE V's upper and lower vignetting factors cut the pupil to [-(1 - VLY), 1 - VUY]: they
// become Zemax's decenter and compression, (VLY - VUY) / 2 and (VLY + VUY) / 2. The file is
// a CODE V export kept under tests/data (tests/data/README.md).
TEST(CodeVReader, VignettingFactorsBecomeDecenterAndCompression) {
    const Prescription rx =
        readLensFile(VEIL_SOURCE_DIR "/tests/data/codev/ag_dblgauss.seq", GlassCatalog::builtIn());
    ASSERT_EQ(rx.system.fields.size(), 3u);  // VUY 0 0.2 0.4, VLY 0 0.25 0.4
    EXPECT_FALSE(rx.system.fields[0].vignetted());
    EXPECT_NEAR(rx.system.fields[1].vdy, 0.025, 1e-15);
    EXPECT_NEAR(rx.system.fields[1].vcy, 0.225, 1e-15);
    EXPECT_EQ(rx.system.fields[2].vdy, 0.0);
    EXPECT_NEAR(rx.system.fields[2].vcy, 0.4, 1e-15);
    EXPECT_EQ(rx.system.fields[2].vdx, 0.0);
    EXPECT_EQ(rx.system.fields[2].vcx, 0.0);
    EXPECT_EQ(findNote(rx, "VUY"), nullptr) << reportText(rx);
}

// Curvature mode, lower case, a continuation line, comments and ';', inch units, an asphere,
// glass codes, nd:vd, a catalog name without its hyphen and a mirror in glass.
TEST(CodeVReader, SyntaxAsCodeVWritesIt) {
    const std::string text =
        "rdm n;len \"test\"\r\n"
        "tit 'Mixed: a \"quoted\" title'\r\n"
        "! a whole-line comment; with a semicolon\r\n"
        "epd 1.0; dim i ! inch units\r\n"
        "wl 656.3 587.6 486.1; ref 2\r\n"
        "yan 0 5 &\r\n"
        "  7\r\n"
        "so 0 1e11\r\n"
        "s 0.05 0.2 nbk7_schott\r\n"
        "  stop\r\n"
        "  asp; k -0.5\r\n"
        "  A 1.0e-3; B -2.0e-5; C 0.0; D&\r\n"
        "   3.0e-9\r\n"
        "s -0.01 0.1 517000.520000\r\n"
        "s 0 0.1 569.631\r\n"
        "s 0 0.1 1.5168:64.17\r\n"
        "s -0.02 -0.1 REFL\r\n"
        "s 0 -1.0 517642\r\n"
        "si 0 0.01\r\n"
        "go\r\n";
    const Prescription rx = readCodeVText(text, "syntax.seq", GlassCatalog::builtIn());
    EXPECT_EQ(rx.system.name, "Mixed: a \"quoted\" title");
    ASSERT_EQ(rx.system.fields.size(), 3u);
    EXPECT_EQ(rx.system.fields[2].y, 7.0);
    EXPECT_EQ(rx.system.aperture.value, 25.4);  // 1 inch
    ASSERT_EQ(rx.surfaces.size(), 8u);
    const double in = 25.4;
    const Surface& s1 = rx.surfaces[1];
    EXPECT_NEAR(s1.curvature, 0.05 / in, 1e-15);  // curvature mode
    EXPECT_NEAR(s1.thicknessMm, 0.2 * in, 1e-12);
    EXPECT_TRUE(s1.stop);
    EXPECT_EQ(s1.material, Material::catalog("N-BK7"));
    EXPECT_EQ(s1.conic, -0.5);
    // A multiplies r^4, B r^6, D r^10; coefficients scale as length^(1 - power).
    EXPECT_NEAR(s1.asphere[1], 1.0e-3 * std::pow(in, -3.0), 1e-18);
    EXPECT_NEAR(s1.asphere[2], -2.0e-5 * std::pow(in, -5.0), 1e-22);
    EXPECT_NEAR(s1.asphere[4], 3.0e-9 * std::pow(in, -9.0), 1e-28);
    // Glass codes: 517000.520000 is nd 1.517, vd 52; 569.631 is nd 1.569, vd 63.1; the
    // six-digit 517642 is nd 1.517, vd 64.2.
    EXPECT_NEAR(rx.surfaces[2].material.nd, 1.517, 1e-12);
    EXPECT_NEAR(rx.surfaces[2].material.vd, 52.0, 1e-9);
    EXPECT_NEAR(rx.surfaces[3].material.nd, 1.569, 1e-12);
    EXPECT_NEAR(rx.surfaces[3].material.vd, 63.1, 1e-9);
    EXPECT_EQ(rx.surfaces[4].material, Material::model(1.5168, 64.17));
    // The mirror keeps the medium the light came from.
    EXPECT_TRUE(rx.surfaces[5].mirror);
    EXPECT_EQ(rx.surfaces[5].material, rx.surfaces[4].material);
    EXPECT_NEAR(rx.surfaces[6].material.nd, 1.517, 1e-12);
    EXPECT_NEAR(rx.surfaces[6].material.vd, 64.2, 1e-9);
    // The SI thickness is a defocus added to the last gap.
    EXPECT_NEAR(rx.surfaces[6].thicknessMm, (-1.0 + 0.01) * in, 1e-12);
}

// Image-height fields keep their kind (resolved when a scene is built) and the lens units.
TEST(CodeVReader, ImageHeightFieldsInLensUnits) {
    const std::string head = "RDM;LEN\nDIM C\nEPD 1\nWL 550\n";
    const std::string lens = "SO 0 1e11\nS 5 0.5 1.5168:64.17\n  STO\nS -5 9.5\nSI 0 0\n";
    const Prescription paraxial =
        readCodeVText(head + "XIM 0 0.3\nYIM 0 0.4\n" + lens, "yim.seq", GlassCatalog::builtIn());
    EXPECT_EQ(paraxial.system.fieldKind, SystemData::FieldKind::ParaxialImageHeightMm);
    ASSERT_EQ(paraxial.system.fields.size(), 2u);
    EXPECT_DOUBLE_EQ(paraxial.system.fields[1].x, 3.0);  // cm to mm
    EXPECT_DOUBLE_EQ(paraxial.system.fields[1].y, 4.0);
    const Prescription real =
        readCodeVText(head + "YRI 0 0.4\n" + lens, "yri.seq", GlassCatalog::builtIn());
    EXPECT_EQ(real.system.fieldKind, SystemData::FieldKind::RealImageHeightMm);
    EXPECT_DOUBLE_EQ(real.system.fields[1].x, 0.0);
    EXPECT_THROW(
        readCodeVText(head + "YAN 0 5\nYRI 0 0.4\n" + lens, "mixed.seq", GlassCatalog::builtIn()),
        ParseError);
}

TEST(CodeVReader, WhatVeilCannotRepresentIsAnErrorAtItsLine) {
    const std::string text =
        "RDM;LEN\nEPD 10\nWL 550\nYAN 0\nSO 0 1e11\nS 50 5 NBK7_SCHOTT\n  STO\n"
        "S -50 40\n  RET S1\n  XTO\nS 0 1 UNOBTAINIUM_SCHOTT\nFROB 1\nSI 0 0\nGO\n";
    const Prescription rx = readCodeVText(text, "bad.seq", GlassCatalog::builtIn());
    const ImportNote* decenter =
        findNote(rx, "RET (return to a surface's coordinates) is not supported");
    ASSERT_NE(decenter, nullptr) << reportText(rx);
    EXPECT_EQ(decenter->severity, ImportNote::Severity::Error);
    EXPECT_EQ(decenter->loc.line, 9);
    const ImportNote* toroid = findNote(rx, "surface profile XTO");
    ASSERT_NE(toroid, nullptr) << reportText(rx);
    EXPECT_EQ(toroid->severity, ImportNote::Severity::Error);
    const ImportNote* glass = findNote(rx, "unknown glass 'UNOBTAINIUM_SCHOTT'");
    ASSERT_NE(glass, nullptr) << reportText(rx);
    EXPECT_EQ(glass->severity, ImportNote::Severity::Error);
    EXPECT_EQ(glass->loc.line, 11);
    const ImportNote* frob = findNote(rx, "unknown command 'FROB'");
    ASSERT_NE(frob, nullptr) << reportText(rx);
    EXPECT_EQ(frob->severity, ImportNote::Severity::Warning);
}

// Decenters become coordinate breaks around their surface: basic (this surface and all after
// it), DAR (this surface only: the inverse break after it carries its thickness) and BEN
// (tilted once more after it, a fold). ZDE lengthens the gap before; lengths in lens units.
TEST(CodeVReader, DecentersBecomeCoordinateBreaks) {
    const std::string text =
        "RDM;LEN\nDIM C\nEPD 1\nWL 587.56\nYAN 0\nSO 0 1e11\n"
        "S 0 1.5\n"                                  // 1: a dummy
        "S 5 0.5 NBK7_SCHOTT\n  STO\n  YDE 0.035; ADE 1.5; DAR\n"  // 2: decentered, returned
        "S -5 3\n  XDE -0.02\n"                       // 3: basic: everything after moves
        "S 0 -2 REFL\n  ADE 45; BEN\n"                 // 4: a fold mirror
        "SI 0 0\n  ZDE 0.1\nGO\n";                  // the image moved 1 mm along its z
    const Prescription rx = readCodeVText(text, "decenters.seq", GlassCatalog::builtIn());
    for (const ImportNote& n : rx.report) EXPECT_NE(n.severity, ImportNote::Severity::Error) << n;
    // object, dummy, CB, S2, CB (return), CB, S3, CB, mirror, CB (bend), CB, image
    ASSERT_EQ(rx.surfaces.size(), 12u);
    const double cm = 10.0;
    ASSERT_TRUE(rx.surfaces[2].coordinateBreak);
    EXPECT_NEAR(rx.surfaces[2].coordinateBreak->decenterYMm, 0.035 * cm, 1e-15);
    EXPECT_EQ(rx.surfaces[2].coordinateBreak->tiltXDeg, 1.5);
    EXPECT_FALSE(rx.surfaces[2].coordinateBreak->tiltFirst);
    EXPECT_TRUE(rx.surfaces[3].stop);
    EXPECT_EQ(rx.surfaces[3].thicknessMm, 0.0);
    ASSERT_TRUE(rx.surfaces[4].coordinateBreak);
    EXPECT_NEAR(rx.surfaces[4].coordinateBreak->decenterYMm, -0.035 * cm, 1e-15);
    EXPECT_EQ(rx.surfaces[4].coordinateBreak->tiltXDeg, -1.5);
    EXPECT_TRUE(rx.surfaces[4].coordinateBreak->tiltFirst);
    EXPECT_NEAR(rx.surfaces[4].thicknessMm, 0.5 * cm, 1e-12);  // S2's thickness, returned
    EXPECT_EQ(rx.surfaces[4].material, Material::catalog("N-BK7"));
    ASSERT_TRUE(rx.surfaces[5].coordinateBreak);
    EXPECT_NEAR(rx.surfaces[5].coordinateBreak->decenterXMm, -0.02 * cm, 1e-15);
    EXPECT_NEAR(rx.surfaces[6].thicknessMm, 3.0 * cm, 1e-12);  // basic: its own thickness
    ASSERT_TRUE(rx.surfaces[7].coordinateBreak);
    EXPECT_EQ(rx.surfaces[7].coordinateBreak->tiltXDeg, 45.0);
    EXPECT_TRUE(rx.surfaces[8].mirror);
    EXPECT_EQ(rx.surfaces[8].thicknessMm, 0.0);
    ASSERT_TRUE(rx.surfaces[9].coordinateBreak);
    EXPECT_EQ(rx.surfaces[9].coordinateBreak->tiltXDeg, 45.0);  // the bend
    EXPECT_EQ(rx.surfaces[9].coordinateBreak->decenterYMm, 0.0);
    EXPECT_NEAR(rx.surfaces[9].thicknessMm, -2.0 * cm + 0.1 * cm, 1e-12);  // + ZDE of SI
    ASSERT_TRUE(rx.surfaces[10].coordinateBreak);
    EXPECT_TRUE(rx.surfaces[10].coordinateBreak->identity());  // ZDE alone: no shift or tilt
}

// An object distance written INF (as some exporters write it) is infinity, as 1e10 lens units
// and more are; INF elsewhere is no number.
TEST(CodeVReader, ObjectDistanceInfIsInfinity) {
    const std::string lens = "S 50 5 1.5168:64.17\n  STO\nS -50 45\nSI 0 0\n";
    for (const char* so : {"SO 0 INF\n", "SO 0 inf\n", "SO 0 1e10\n"}) {
        const Prescription rx =
            readCodeVText(std::string("RDM\nEPD 10\nWL 550\nYAN 0\n") + so + lens, "inf.seq",
                          GlassCatalog::builtIn());
        EXPECT_TRUE(std::isinf(rx.surfaces[0].thicknessMm)) << so;
    }
    EXPECT_THROW(readCodeVText("RDM\nEPD 10\nWL 550\nYAN 0\nSO 0 1e11\nS 50 INF\nSI 0 0\n",
                               "inf.seq", GlassCatalog::builtIn()),
                 ParseError);
}

TEST(CodeVReader, MalformedInputNamesFileLineAndColumn) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    try {
        readCodeVText("RDM\nEPD 10\nSO 0 1e11\nS 50 five\nSI 0 0\n", "num.seq", catalog);
        FAIL() << "no error";
    } catch (const ParseError& e) {
        EXPECT_EQ(e.loc().line, 4);
        EXPECT_EQ(e.loc().column, 6);
        EXPECT_NE(e.message().find("'five' is not a number"), std::string::npos) << e.what();
    }
    EXPECT_THROW(readCodeVText("RDM\nEPD 10\nSO 0 1e11\nS 50 5\n", "noimage.seq", catalog),
                 ParseError);
    EXPECT_THROW(readCodeVText("RDM\nEPD 10\nS 50 5\nSI 0 0\n", "noobject.seq", catalog),
                 ParseError);
    EXPECT_THROW(readCodeVText("RDM\nEPD 10\nWL 550\nREF 3\nSO 0 1e11\nS 50 5\nSI 0 0\n", "ref.seq",
                               catalog),
                 ParseError);
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// A private glass catalog (PRV ... END: PWL wavelengths, then each glass's indices) gives
// the lens its own glass, as in tests/data/codev/CODV_65988_noDOE.seq (whose first-order
// data tests/analysis/lens/codev_first_order_test.cpp checks). n_d: SciPy's natural spline
// through the table over 1 / lambda^2 gives 1.5311617964888755.
TEST(CodeVReader, PrivateGlassCatalogGivesTheLensItsOwnGlass) {
    const std::string text =
        "EPD 12.0\nDIM M\nWL 656.2725 587.5618 486.1327\nREF 2\nYAN 0.0\n"
        "PRV\n"
        "  PWL 1600.0 1500.0 1400.0 1300.0 1200.0 1100.0 1000.0 900.0 800.0 700.0 650.0&\n"
        "   600.0 587.6 546.1 486.1 480.0 460.0 440.0 404.7 400.0\n"
        "  'E48' 1.5184 1.5188 1.5192 1.5197 1.5201 1.5219 1.5231 1.5247 1.5257 1.527&\n"
        "   1.5286 1.5306 1.53116 1.5334 1.5378 1.5384 1.5404 1.5427 1.5476 1.5484\n"
        "END\n"
        "SO 0.0 0.1e14\nS 9.93 3.7 'E48'\n  STO\n  CIR 6.0\nS -48.3 12.94603127272\n  CIR 6.0\n"
        "SI 0.0 0.0\nGO\n";
    const Prescription rx = readCodeVText(text, "prv.seq", GlassCatalog::builtIn());
    EXPECT_EQ(reportText(rx).find("Error"), std::string::npos) << reportText(rx);
    const Material& m = rx.surfaces[1].material;
    ASSERT_EQ(m.kind, Material::Kind::Table);
    EXPECT_EQ(m.name, "E48");
    ASSERT_EQ(m.tableNm.size(), 20u);
    EXPECT_NEAR(m.ownGlass()->index(587.5618), 1.5311617964888755, 1e-13);
    EXPECT_TRUE(rx.surfaces[2].material.isAir());

    // A private glass by its Laurent coefficients (LAU: the Schott formula), as
    // ray-optics' CODV_35571.seq gives Norland's NOA61 adhesive. Truth: Norland's published
    // Cauchy fit n = 1.5375 + 8290.45 / l^2 - 2.11046e8 / l^4 (l in nm), whose square the
    // coefficients expand.
    const std::string lau =
        "EPD 10\nWL 550\nPRV\n  PWL 550.0\n  'NOA61' LAU 2.36390625 0.0 0.025493134 "
        "-0.000580235 -0.349933e-5 0.445404e-7\nEND\n"
        "SO 0 1e14\nS 40 3 'NOA61'\nSTO\nS -40 30\nSI 0 0\n";
    const Prescription adhesive = readCodeVText(lau, "lau.seq", GlassCatalog::builtIn());
    const Material& noa = adhesive.surfaces[1].material;
    ASSERT_EQ(noa.kind, Material::Kind::Formula);
    EXPECT_EQ(noa.formula, DispersionFormula::Schott);
    for (double l : {400.0, 550.0, 700.0})
        EXPECT_NEAR(noa.ownGlass()->index(l),
                    1.5375 + 8290.45 / (l * l) - 2.11046e8 / (l * l * l * l), 1e-9)
            << l;
    EXPECT_THROW(readCodeVText("EPD 10\nWL 550\nPRV\n 'X' SEL 1 2 3\nEND\nSO 0 1e14\nS 40 3 "
                               "'X'\nSTO\nS -40 30\nSI 0 0\n",
                               "sel.seq", GlassCatalog::builtIn()),
                 ParseError);

    // A glass whose indices do not match PWL, or that comes before it: an error at its line.
    const std::string bad =
        "EPD 12.0\nWL 587.5618\nPRV\n PWL 500 600\n 'X1' 1.5 1.49 1.48\nEND\n"
        "SO 0 1e14\nS 10 3 'X1'\nSTO\nS -50 10\nSI 0 0\n";
    try {
        readCodeVText(bad, "bad.seq", GlassCatalog::builtIn());
        ADD_FAILURE() << "a table of 3 indices for 2 wavelengths was read";
    } catch (const ParseError& e) {
        EXPECT_NE(std::string(e.what()).find("bad.seq:5:2"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("gives 3 indices for the 2 wavelengths"),
                  std::string::npos)
            << e.what();
    }
}

}  // namespace
}  // namespace veil
