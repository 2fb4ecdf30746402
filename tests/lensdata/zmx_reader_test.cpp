// Tests of the Zemax .zmx reader against independent truth: the numbers written in the lens
// files, focal lengths derived by hand with a y-nu paraxial trace (working shown below) and
// checked with an independent ABCD matrix product, Zemax's own computed apertures, and files
// written in other encodings that must give the same prescription.

#include "lensdata/zmx_reader.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "lensdata/text_decoding.h"

namespace veil {
namespace {

const std::string kZmxDir = std::string(VEIL_SOURCE_DIR) + "/tests/data/zmx/";

std::string readBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    EXPECT_TRUE(in) << "cannot open " << path;
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

Prescription load(const std::string& name) {
    return readZmx(kZmxDir + name, GlassCatalog::builtIn());
}

// Notes of one severity; and the first note whose message contains `text`.
std::vector<ImportNote> notesOf(const Prescription& rx, ImportNote::Severity s) {
    std::vector<ImportNote> out;
    for (const ImportNote& n : rx.report)
        if (n.severity == s) out.push_back(n);
    return out;
}

const ImportNote* findNote(const Prescription& rx, const std::string& text) {
    for (const ImportNote& n : rx.report)
        if (n.message.find(text) != std::string::npos) return &n;
    return nullptr;
}

std::string reportText(const Prescription& rx) {
    std::string out;
    for (const ImportNote& n : rx.report) {
        std::ostringstream os;
        os << n << "\n";
        out += os.str();
    }
    return out;
}

// Paraxial Optics Oracle
//
// Independent of the tracer: a 2x2 matrix product in reduced angles. The state is (y, w) with
// w = n u, n the signed index of the gap: n changes sign at every mirror, which makes a mirror
// a refraction into n' = -n (Zemax keeps thicknesses negative after an odd number of mirrors,
// so t / n stays positive).
//   refraction at curvature c from n to n':  R = [[1, 0], [-(n' - n) c, 1]]
//   transfer over thickness t in index n:     T = [[1, t / n], [0, 1]]
// The product from the first to the last refracting surface is M = [[A, B], [C, D]] with
// C = -power, so EFL = -1 / C (image space in air, n' = +-1).

using Mat2 = std::array<double, 4>;  // A B C D

Mat2 mul(const Mat2& l, const Mat2& r) {
    return {l[0] * r[0] + l[1] * r[2], l[0] * r[1] + l[1] * r[3], l[2] * r[0] + l[3] * r[2],
            l[2] * r[1] + l[3] * r[3]};
}

// Index of a material: catalog glasses at `wavelengthNm`, model glasses at their nd.
double indexOf(const Material& m, const Prescription& rx, const GlassCatalog& catalog,
               double wavelengthNm) {
    switch (m.kind) {
        case Material::Kind::Air:
            return 1.0;
        case Material::Kind::Model:
            return m.nd;
        case Material::Kind::Table:
        case Material::Kind::Formula:
            return m.ownGlass()->index(wavelengthNm);
        case Material::Kind::Catalog: {
            const Glass* g = catalog.find(m.name, rx.system.glassCatalogs);
            EXPECT_NE(g, nullptr) << m.name;
            return g ? g->index(wavelengthNm) : 1.0;
        }
    }
    return 1.0;
}

Mat2 systemMatrix(const Prescription& rx, const GlassCatalog& catalog, double wavelengthNm) {
    Mat2 m{1, 0, 0, 1};
    double n = indexOf(rx.surfaces[0].material, rx, catalog, wavelengthNm);
    double sign = 1.0;
    const int last = rx.imageIndex() - 1;
    for (int i = 1; i <= last; ++i) {
        const Surface& s = rx.surfaces[i];
        if (s.mirror) sign = -sign;
        const double n2 = sign * indexOf(s.material, rx, catalog, wavelengthNm);
        m = mul({1, 0, -(n2 - n) * s.curvature, 1}, m);
        if (i < last) m = mul({1, s.thicknessMm / n2, 0, 1}, m);
        n = n2;
    }
    return m;
}

double effectiveFocalLength(const Prescription& rx, const GlassCatalog& catalog,
                            double wavelengthNm) {
    return -1.0 / systemMatrix(rx, catalog, wavelengthNm)[2];
}

// Same prescription, field by field (the report included).
void expectSamePrescription(const Prescription& a, const Prescription& b) {
    ASSERT_EQ(a.surfaces.size(), b.surfaces.size());
    for (size_t i = 0; i < a.surfaces.size(); ++i) {
        SCOPED_TRACE("surface " + std::to_string(i));
        const Surface& s = a.surfaces[i];
        const Surface& t = b.surfaces[i];
        EXPECT_EQ(s.name, t.name);
        EXPECT_EQ(s.comment, t.comment);
        EXPECT_EQ(s.curvature, t.curvature);
        EXPECT_EQ(s.conic, t.conic);
        EXPECT_EQ(s.asphere, t.asphere);
        EXPECT_EQ(s.thicknessMm, t.thicknessMm);
        EXPECT_EQ(s.material, t.material);
        EXPECT_EQ(s.clearSemiDiameterMm, t.clearSemiDiameterMm);
        EXPECT_EQ(s.mechSemiDiameterMm, t.mechSemiDiameterMm);
        EXPECT_EQ(s.stop, t.stop);
        EXPECT_EQ(s.mirror, t.mirror);
        EXPECT_EQ(s.coating, t.coating);
        EXPECT_EQ(s.origin.line, t.origin.line);
        EXPECT_EQ(s.origin.column, t.origin.column);
    }
    const SystemData& x = a.system;
    const SystemData& y = b.system;
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.notes, y.notes);
    EXPECT_EQ(x.aperture.kind, y.aperture.kind);
    EXPECT_EQ(x.aperture.value, y.aperture.value);
    EXPECT_EQ(x.fieldKind, y.fieldKind);
    ASSERT_EQ(x.fields.size(), y.fields.size());
    for (size_t i = 0; i < x.fields.size(); ++i) {
        EXPECT_EQ(x.fields[i].x, y.fields[i].x);
        EXPECT_EQ(x.fields[i].y, y.fields[i].y);
        EXPECT_EQ(x.fields[i].weight, y.fields[i].weight);
    }
    ASSERT_EQ(x.wavelengths.size(), y.wavelengths.size());
    for (size_t i = 0; i < x.wavelengths.size(); ++i) {
        EXPECT_EQ(x.wavelengths[i].nm, y.wavelengths[i].nm);
        EXPECT_EQ(x.wavelengths[i].weight, y.wavelengths[i].weight);
    }
    EXPECT_EQ(x.primaryWavelength, y.primaryWavelength);
    EXPECT_EQ(x.glassCatalogs, y.glassCatalogs);
    ASSERT_EQ(a.report.size(), b.report.size());
    for (size_t i = 0; i < a.report.size(); ++i) {
        EXPECT_EQ(a.report[i].severity, b.report[i].severity);
        EXPECT_EQ(a.report[i].loc.line, b.report[i].loc.line);
        EXPECT_EQ(a.report[i].loc.column, b.report[i].loc.column);
        EXPECT_EQ(a.report[i].message, b.report[i].message);
    }
}

std::string toUtf16(const std::string& ascii, bool bigEndian, bool bom) {
    std::string out;
    if (bom) out += bigEndian ? "\xFE\xFF" : "\xFF\xFE";
    for (char c : ascii) {
        if (bigEndian) out += '\0';
        out += c;
        if (!bigEndian) out += '\0';
    }
    return out;
}

// Double Gauss, US patent 583336 example 2 (tests/data/zmx/US00583336-2-scaled.zmx)

TEST(ZmxReader, DoubleGaussSurfacesAndSystem) {
    const Prescription rx = load("US00583336-2-scaled.zmx");
    ASSERT_EQ(rx.surfaces.size(), 14u);  // SURF 0..13
    EXPECT_EQ(rx.system.name, "Original Double Gauss");
    EXPECT_NE(rx.system.notes.find("U.S. Patent 583336"), std::string::npos);

    // Curvatures and thicknesses as written in the file (lens units MM).
    const std::array<double, 14> curv = {0.0,
                                         0.0,
                                         7.061398863114783100E-002,
                                         1.440756108805901400E-002,
                                         6.174554660245130200E-002,
                                         -5.085176709890669400E-002,
                                         1.137268281587626600E-001,
                                         0.0,
                                         -1.137268281587626600E-001,
                                         5.085176709890669400E-002,
                                         -6.174554660245130200E-002,
                                         -1.440756108805901400E-002,
                                         -7.061398863114783100E-002,
                                         0.0};
    const std::array<double, 13> thick = {kInfinity, 4.5,   1.386,         0.117, 2.313,
                                          1.386,     2.313, 2.313,         1.386, 2.313,
                                          0.117,     1.386, 42.35170011441};
    for (int i = 0; i < 14; ++i) EXPECT_EQ(rx.surfaces[i].curvature, curv[i]) << i;
    for (int i = 0; i < 13; ++i) EXPECT_EQ(rx.surfaces[i].thicknessMm, thick[i]) << i;

    // Glasses: N-BAK1 / N-BALF4 from the Schott catalog, the pickups read by name.
    const Material bak1 = Material::catalog("N-BAK1");
    const Material balf4 = Material::catalog("N-BALF4");
    const std::array<Material, 13> glass = {Material::air(),
                                            Material::air(),
                                            bak1,
                                            Material::air(),
                                            bak1,
                                            balf4,
                                            Material::air(),
                                            Material::air(),
                                            balf4,
                                            bak1,
                                            Material::air(),
                                            bak1,
                                            Material::air()};
    for (int i = 0; i < 13; ++i) EXPECT_EQ(rx.surfaces[i].material, glass[i]) << i;
    for (const Surface& s : rx.surfaces) EXPECT_FALSE(s.mirror);

    EXPECT_EQ(rx.stopIndex(), 7);
    EXPECT_EQ(rx.surfaces[7].name, "stop");
    EXPECT_DOUBLE_EQ(rx.surfaces[7].clearSemiDiameterMm, 4.215000499256);
    EXPECT_DOUBLE_EQ(rx.surfaces[2].clearSemiDiameterMm, 6.3);
    EXPECT_DOUBLE_EQ(rx.surfaces[13].clearSemiDiameterMm, 22.6142390559);
    EXPECT_EQ(rx.surfaces[2].name, "L1.front");
    EXPECT_EQ(rx.surfaces[13].name, "image");
    EXPECT_EQ(rx.surfaces[7].origin.line, 128);  // the SURF 7 line
    EXPECT_EQ(rx.elements().size(), 6u);

    EXPECT_EQ(rx.system.aperture.kind, SystemAperture::Kind::ImageSpaceFNumber);
    EXPECT_DOUBLE_EQ(rx.system.aperture.value, 4.5);
    EXPECT_EQ(rx.system.fieldKind, SystemData::FieldKind::AngleDeg);
    ASSERT_EQ(rx.system.fields.size(), 3u);  // FTYP 0 0 3 3: three fields
    EXPECT_EQ(rx.system.fields[0].y, 0.0);
    EXPECT_EQ(rx.system.fields[1].y, 17.0);
    EXPECT_EQ(rx.system.fields[2].y, 24.0);
    for (const Field& f : rx.system.fields) EXPECT_EQ(f.x, 0.0);
    ASSERT_EQ(rx.system.wavelengths.size(), 3u);  // three of the 24 WAVM slots
    EXPECT_DOUBLE_EQ(rx.system.wavelengths[0].nm, 486.1327);
    EXPECT_DOUBLE_EQ(rx.system.wavelengths[1].nm, 587.5618);
    EXPECT_DOUBLE_EQ(rx.system.wavelengths[2].nm, 656.2725);
    EXPECT_EQ(rx.system.primaryWavelength, 1);  // PWAV 2
    EXPECT_EQ(rx.system.glassCatalogs, std::vector<std::string>{"SCHOTT"});

    // Everything in this file is either imported or display/solve data: Info notes only.
    EXPECT_TRUE(notesOf(rx, ImportNote::Severity::Error).empty()) << reportText(rx);
    EXPECT_TRUE(notesOf(rx, ImportNote::Severity::Warning).empty()) << reportText(rx);
    // One summary note per skipped tag, with the count and the first line.
    const ImportNote* pops = findNote(rx, "POPS line(s) skipped");
    ASSERT_NE(pops, nullptr) << reportText(rx);
    EXPECT_EQ(pops->message.rfind("14 POPS", 0), 0u) << pops->message;
    EXPECT_EQ(pops->loc.line, 65);
    EXPECT_NE(findNote(rx, "CURV: 5 surface(s) carry a solve or pickup"), nullptr)
        << reportText(rx);
    EXPECT_NE(findNote(rx, "GLAS: 3 surface(s)"), nullptr) << reportText(rx);
}

// Effective focal length of the double Gauss, derived by hand.
//
// y-nu paraxial trace of a ray parallel to the axis, y = 1 at surface 2 (surface 1 is a flat
// dummy). phi = (n' - n) c, nu' = nu - y phi, y_next = y + t nu' / n'. Indices at the d line
// from the Schott catalog: N-BAK1 nd = 1.57250, N-BALF4 nd = 1.57956.
//   surf  c           n -> n'           phi          y           nu'
//    2    0.07061399  1      -> 1.57250  0.04042651  1.00000000  -0.04042651
//    3    0.01440756  1.5725 -> 1        -0.00824833  0.96436811  -0.03247208
//    4    0.06174555  1      -> 1.57250  0.03534933  0.96056888  -0.06642755
//    5   -0.05085177  1.5725 -> 1.57956  -0.00035901  0.86286019  -0.06611777
//    6    0.11372683  1.5796 -> 1        -0.06591152  0.80484453  -0.01306924
//    7    0 (stop)    1      -> 1         0           0.77461537  -0.01306924
//    8   -0.11372683  1      -> 1.57956  -0.06591152  0.74438622   0.03599439
//    9    0.05085177  1.5796 -> 1.57250  -0.00035901  0.77596984   0.03627297
//   10   -0.06174555  1.5725 -> 1         0.03534933  0.82932398   0.00695693
//   11   -0.01440756  1      -> 1.57250  -0.00824833  0.83013794   0.01380418
//   12   -0.07061399  1.5725 -> 1         0.04042651  0.84230493  -0.02024727
// EFL = -y_1 / nu'_last = 1 / 0.02024727 = 49.389 mm (back focal distance y / -nu' = 41.60 mm;
// the file's last thickness, 42.35 mm, is a marginal-ray-height solve at the 0.7 zone, not
// the paraxial focus). The file's own EFLY merit operand targets 49.4 mm.
constexpr double kDoubleGaussEflMm = 49.389;

TEST(ZmxReader, DoubleGaussEffectiveFocalLength) {
    const Prescription rx = load("US00583336-2-scaled.zmx");
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    // The catalog indices agree with the nd the file stores (1.572500121386, 1.579559355877).
    EXPECT_NEAR(catalog.find("N-BAK1")->index(kLineD), 1.572500121386, 2e-6);
    EXPECT_NEAR(catalog.find("N-BALF4")->index(kLineD), 1.579559355877, 2e-6);
    EXPECT_NEAR(effectiveFocalLength(rx, catalog, kLineD), kDoubleGaussEflMm, 0.01);
    // Both glasses are crowns of similar dispersion (Vd 57.5 and 53.9), so the negative
    // elements cannot cancel the colour of the positive ones: the lens is not an achromat and
    // keeps the longitudinal colour of a positive lens, EFL(F) < EFL(d) < EFL(C).
    const double eflF = effectiveFocalLength(rx, catalog, kLineF);
    const double eflC = effectiveFocalLength(rx, catalog, kLineC);
    EXPECT_LT(eflF, kDoubleGaussEflMm - 0.1);
    EXPECT_GT(eflC, kDoubleGaussEflMm + 0.1);
}

// Catadioptric objective, Handbook of Optics vol. II ch. 18 ex. 27
// (tests/data/zmx/HoO-V2C18Ex27.zmx)

TEST(ZmxReader, HandbookCatadioptricSurfacesAndSystem) {
    const Prescription rx = load("HoO-V2C18Ex27.zmx");
    ASSERT_EQ(rx.surfaces.size(), 11u);  // SURF 0..10
    EXPECT_EQ(rx.system.name, "");
    EXPECT_EQ(rx.stopIndex(), 1);

    // Model glasses (GLAS ___BLANK, solve 1) and their pickups on surfaces 6 and 8.
    const Material pmma = Material::model(1.4890000000000001, 57.399999999999999);
    const Material pc = Material::model(1.583, 30.300000000000001);
    EXPECT_EQ(rx.surfaces[1].material, pmma);
    EXPECT_EQ(rx.surfaces[2].material, pc);
    EXPECT_TRUE(rx.surfaces[3].material.isAir());
    EXPECT_EQ(rx.surfaces[6].material, pmma);
    EXPECT_TRUE(rx.surfaces[7].material.isAir());
    EXPECT_EQ(rx.surfaces[8].material, pc);
    EXPECT_TRUE(rx.surfaces[9].material.isAir());

    // Two mirrors (GLAS MIRROR; the MIRR 2 0 lines on every surface are drawing data). A
    // mirror keeps the incident medium, and thickness signs stay as written.
    for (int i = 0; i < 11; ++i) EXPECT_EQ(rx.surfaces[i].mirror, i == 4 || i == 5) << i;
    EXPECT_TRUE(rx.surfaces[4].material.isAir());
    EXPECT_TRUE(rx.surfaces[5].material.isAir());
    EXPECT_EQ(rx.surfaces[4].thicknessMm, -15.0);
    EXPECT_EQ(rx.surfaces[5].thicknessMm, 10.266999999999999);
    EXPECT_EQ(rx.surfaces[4].curvature, -1.788908765652951621E-02);
    EXPECT_EQ(rx.surfaces[4].conic, 1.077);
    EXPECT_EQ(rx.surfaces[4].name, "M1");
    EXPECT_EQ(rx.surfaces[5].name, "M2");

    // Even aspheres: PARM 2 and 3 are the r^4 and r^6 coefficients.
    EXPECT_EQ(rx.surfaces[1].asphere[0], 0.0);
    EXPECT_EQ(rx.surfaces[1].asphere[1], -1.9279999999999998e-05);
    EXPECT_EQ(rx.surfaces[1].asphere[2], 2.9799999999999999e-08);
    EXPECT_EQ(rx.surfaces[3].asphere[1], -1.0849999999999999e-05);
    EXPECT_EQ(rx.surfaces[3].asphere[2], 2.8060000000000001e-08);
    EXPECT_FALSE(rx.surfaces[2].hasAsphere());

    EXPECT_EQ(rx.surfaces[1].clearSemiDiameterMm, 9.8475244244558962);
    EXPECT_EQ(rx.surfaces[1].mechSemiDiameterMm, 9.9053590346029807);
    EXPECT_EQ(rx.surfaces[7].clearSemiDiameterMm, 1.387509761829758);
    EXPECT_EQ(rx.surfaces[7].mechSemiDiameterMm, 1.6691928437683086);

    EXPECT_EQ(rx.system.aperture.kind, SystemAperture::Kind::ImageSpaceFNumber);
    EXPECT_DOUBLE_EQ(rx.system.aperture.value, 1.25);
    ASSERT_EQ(rx.system.fields.size(), 2u);  // FTYP 0 0 2 1
    EXPECT_EQ(rx.system.fields[0].y, 0.0);
    EXPECT_EQ(rx.system.fields[1].y, 1.5);
    ASSERT_EQ(rx.system.wavelengths.size(), 1u);
    EXPECT_DOUBLE_EQ(rx.system.wavelengths[0].nm, 550.0);
    EXPECT_EQ(rx.system.primaryWavelength, 0);

    EXPECT_TRUE(notesOf(rx, ImportNote::Severity::Error).empty()) << reportText(rx);
    EXPECT_TRUE(notesOf(rx, ImportNote::Severity::Warning).empty()) << reportText(rx);
    const ImportNote* mirr = findNote(rx, "MIRR line(s) skipped");
    ASSERT_NE(mirr, nullptr) << reportText(rx);
    EXPECT_EQ(mirr->message.rfind("11 MIRR", 0), 0u) << mirr->message;
}

// Effective focal length of the catadioptric objective, derived by hand at the model glasses'
// nd (1.489, 1.583). Mirrors refract into n' = -n; thickness -15 after the primary in n = -1
// gives t / n = +15.
//   surf  c            n -> n'          phi          y           nu'
//    1    0            1     -> 1.489    0           1.00000000   0
//    2    0.00044070   1.489 -> 1.583    0.00004143  1.00000000  -0.00004143
//    3    0            1.583 -> 1        0           0.99997383  -0.00004143
//    4   -0.01788909   1     -> -1       0.03577818  0.99929071  -0.03579422  (primary)
//    5    0           -1     -> 1        0           0.46237735  -0.03579422  (flat mirror)
//    6    0.10989011   1     -> 1.489    0.05373626  0.09487804  -0.04089262
//    7   -0.11659088   1.489 -> 1        0.05701294  0.06192228  -0.04442299
//    8   -0.11641444   1     -> 1.583   -0.06786962  0.06112266  -0.04027462
//    9   -0.01143641   1.583 -> 1        0.00666743  0.05349008  -0.04063126
// EFL = 1 / 0.04063126 = 24.612 mm, back focal distance 0.05349 / 0.04063 = 1.3165 mm (the
// file's last thickness is 1.317).
constexpr double kHandbookEflMm = 24.612;

// Zemax's own focal length, recovered from the file. The stop is surface 1 and the object is
// at infinity, so the entrance pupil lies in the vertex plane of surface 1 and, at F/1.25,
// EPD = EFL / 1.25. The stored DIAM of surface 1 (solve 0, automatic) is the largest real ray
// height on it: the lower marginal ray of the 1.5 deg field, which meets the aspheric surface
// at z = sag(h) < 0, before the pupil plane, so h = EPD / 2 + |sag(h)| tan 1.5 deg.
//   h = 9.84752442, sag(h) = A4 h^4 + A6 h^6 = -0.15413173, EPD / 2 = 9.84348834,
//   EFL(550 nm) = 1.25 * 2 * 9.84348834 = 24.60872 mm.
// This is at the system wavelength, 550 nm, with Zemax's model-glass dispersion; the value at
// nd (24.612) differs by 1.2e-4 relative.
constexpr double kHandbookZemaxEfl550Mm = 24.60872;

TEST(ZmxReader, HandbookCatadioptricEffectiveFocalLength) {
    const Prescription rx = load("HoO-V2C18Ex27.zmx");
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    EXPECT_NEAR(effectiveFocalLength(rx, catalog, kLineD), kHandbookEflMm, 0.002);

    // The same recovery from the imported numbers, to tie the constant to the file.
    const Surface& stop = rx.surfaces[1];
    const double h = stop.clearSemiDiameterMm;
    const double sag = stop.asphere[1] * std::pow(h, 4) + stop.asphere[2] * std::pow(h, 6);
    const double tanField = std::tan(rx.system.fields[1].y * 3.14159265358979323846 / 180.0);
    const double zemaxEfl = rx.system.aperture.value * 2.0 * (h + sag * tanField);
    EXPECT_NEAR(zemaxEfl, kHandbookZemaxEfl550Mm, 1e-5);

    // The matrix product at 550 nm with the model glasses' dispersion (Glass::model) agrees
    // with Zemax to better than 5e-5 relative, well inside the 1.2e-4 that dispersion moves it.
    Prescription dispersive = rx;
    const double nm = rx.system.wavelengths[rx.system.primaryWavelength].nm;
    for (Surface& s : dispersive.surfaces)
        if (s.material.kind == Material::Kind::Model)
            s.material.nd = Glass::model(s.material.nd, s.material.vd, s.material.dPgF).index(nm);
    EXPECT_NEAR(effectiveFocalLength(dispersive, catalog, nm) / kHandbookZemaxEfl550Mm, 1.0, 5e-5);
}

// Encodings

TEST(ZmxReader, Utf16LittleEndianFileMatchesAsciiTwin) {
    const Prescription ascii = load("US00583336-2-scaled.zmx");
    const Prescription utf16 = load("US00583336-2-scaled-utf16le.zmx");  // BOM, CR LF
    expectSamePrescription(ascii, utf16);
    EXPECT_NE(utf16.sourceFile.find("utf16le"), std::string::npos);
}

TEST(ZmxReader, EveryEncodingGivesTheSamePrescription) {
    const std::string text = readBytes(kZmxDir + "HoO-V2C18Ex27.zmx");
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const Prescription ref = readZmxText(text, "HoO.zmx", catalog);
    std::string crlf;
    for (char c : text) crlf += c == '\n' ? std::string("\r\n") : std::string(1, c);
    std::string cr = text;
    std::replace(cr.begin(), cr.end(), '\n', '\r');
    const std::vector<std::pair<std::string, std::string>> variants = {
        {"UTF-8 BOM", "\xEF\xBB\xBF" + text},
        {"CR LF", crlf},
        {"CR", cr},
        {"UTF-16 LE BOM", toUtf16(text, false, true)},
        {"UTF-16 LE no BOM", toUtf16(text, false, false)},
        {"UTF-16 BE BOM", toUtf16(text, true, true)},
        {"UTF-16 BE no BOM", toUtf16(text, true, false)},
    };
    for (const auto& [what, bytes] : variants) {
        SCOPED_TRACE(what);
        expectSamePrescription(ref, readZmxText(bytes, "HoO.zmx", catalog));
    }
}

TEST(TextDecoding, DecodesNonAsciiText) {
    // "NAME Objectif f/2 µ" in UTF-16 LE with a surrogate pair, and Latin-1 bytes.
    std::string le = toUtf16("NAME x", false, true);
    le += std::string("\x3D\xD8\x00\xDE", 4);  // U+1F600 as a surrogate pair
    EXPECT_EQ(decodeText(le, "x"), "NAME x\xF0\x9F\x98\x80");
    EXPECT_EQ(decodeText("NAME \xB5m", "x"), "NAME \xC2\xB5m");      // Latin-1 micro sign
    EXPECT_EQ(decodeText("NAME \xC2\xB5m", "x"), "NAME \xC2\xB5m");  // already UTF-8
}

// Hand-written files exercising each command

TEST(ZmxReader, AllSupportedCommands) {
    const Prescription rx = load("all_commands.zmx");
    const SystemData& sys = rx.system;
    EXPECT_EQ(sys.name, "Every supported command");
    EXPECT_EQ(sys.notes, "First note line.\nSecond note line.");
    EXPECT_EQ(sys.aperture.kind, SystemAperture::Kind::EntrancePupilDiameter);
    EXPECT_EQ(sys.aperture.value, 20.0);
    EXPECT_EQ(sys.glassCatalogs, (std::vector<std::string>{"OHARA", "SCHOTT"}));
    ASSERT_EQ(sys.fields.size(), 3u);
    EXPECT_EQ(sys.fields[1].y, 5.0);
    EXPECT_EQ(sys.fields[2].x, 1.5);
    EXPECT_EQ(sys.fields[2].y, 7.0);
    EXPECT_EQ(sys.fields[0].weight, 2.0);
    EXPECT_EQ(sys.fields[2].weight, 0.5);
    ASSERT_EQ(sys.wavelengths.size(), 2u);  // FTYP says 2 of the 3 WAVM lines
    EXPECT_DOUBLE_EQ(sys.wavelengths[1].nm, 656.2725);
    EXPECT_EQ(sys.wavelengths[1].weight, 0.5);
    EXPECT_EQ(sys.primaryWavelength, 1);

    ASSERT_EQ(rx.surfaces.size(), 6u);
    const Surface& s1 = rx.surfaces[1];
    EXPECT_TRUE(s1.stop);
    EXPECT_EQ(s1.comment, "Front of the singlet");
    EXPECT_EQ(s1.curvature, 0.02);
    EXPECT_EQ(s1.thicknessMm, 5.0);
    EXPECT_EQ(s1.material, Material::catalog("N-BK7"));
    EXPECT_EQ(s1.coating, "MGF2");
    EXPECT_EQ(s1.clearSemiDiameterMm, 10.0);
    EXPECT_EQ(s1.mechSemiDiameterMm, 11.0);
    EXPECT_EQ(s1.origin.line, 23);
    EXPECT_EQ(s1.origin.column, 1);

    const Surface& s2 = rx.surfaces[2];
    EXPECT_EQ(s2.conic, -1.5);
    const std::array<double, 10> asph = {0, 1.0e-5, -2.5e-8, 0, 0, 0, 0, 3e-20, 0, 0};
    EXPECT_EQ(s2.asphere, asph);
    EXPECT_EQ(s2.material, Material::model(1.6, 40.0, 0.002));

    const Surface& m = rx.surfaces[4];
    EXPECT_TRUE(m.mirror);
    EXPECT_TRUE(m.material.isAir());
    EXPECT_EQ(m.thicknessMm, -40.0);
    EXPECT_EQ(m.comment, "Fold-back mirror");
    EXPECT_EQ(m.name, "M1");
    EXPECT_TRUE(std::isinf(rx.surfaces[0].thicknessMm));

    EXPECT_TRUE(notesOf(rx, ImportNote::Severity::Error).empty()) << reportText(rx);
    EXPECT_TRUE(notesOf(rx, ImportNote::Severity::Warning).empty()) << reportText(rx);
    const ImportNote* hide = findNote(rx, "HIDE line(s) skipped");
    ASSERT_NE(hide, nullptr) << reportText(rx);
    EXPECT_EQ(hide->loc.line, 14);
    EXPECT_EQ(hide->severity, ImportNote::Severity::Info);
}

TEST(ZmxReader, LensUnitsAreConvertedToMillimetres) {
    const Prescription rx = load("units_cm.zmx");
    // 1 cm = 10 mm: lengths x10, curvature /10, an r^(2k) coefficient x 10^(1 - 2k).
    EXPECT_DOUBLE_EQ(rx.system.aperture.value, 20.0);
    EXPECT_EQ(rx.system.fieldKind, SystemData::FieldKind::ObjectHeightMm);
    ASSERT_EQ(rx.system.fields.size(), 2u);
    EXPECT_DOUBLE_EQ(rx.system.fields[1].y, 15.0);
    const Surface& s = rx.surfaces[1];
    EXPECT_DOUBLE_EQ(s.curvature, 0.01);
    EXPECT_DOUBLE_EQ(s.thicknessMm, 5.0);
    EXPECT_DOUBLE_EQ(s.clearSemiDiameterMm, 12.0);
    EXPECT_DOUBLE_EQ(s.mechSemiDiameterMm, 15.0);
    EXPECT_DOUBLE_EQ(s.asphere[0], 0.01 / 10.0);  // r^2: 1/length
    EXPECT_DOUBLE_EQ(s.asphere[1], 1e-3 / 1e3);   // r^4: 1/length^3
    EXPECT_DOUBLE_EQ(s.asphere[2], 2e-5 / 1e5);   // r^6: 1/length^5
    EXPECT_DOUBLE_EQ(rx.surfaces[0].thicknessMm, 100.0);
    EXPECT_DOUBLE_EQ(rx.surfaces[2].thicknessMm, 95.0);
    // The sag at r = 1 cm = 10 mm is the same in both unit systems (oracle: the file's units).
    auto sagFile = [](double r) {  // cm
        const double c = 0.1;
        return c * r * r / (1 + std::sqrt(1 - c * c * r * r)) + 0.01 * r * r +
               1e-3 * std::pow(r, 4) + 2e-5 * std::pow(r, 6);
    };
    auto sagMm = [&](double r) {
        const double c = s.curvature;
        return c * r * r / (1 + std::sqrt(1 - c * c * r * r)) + s.asphere[0] * r * r +
               s.asphere[1] * std::pow(r, 4) + s.asphere[2] * std::pow(r, 6);
    };
    EXPECT_NEAR(sagMm(10.0), 10.0 * sagFile(1.0), 1e-12);
    const ImportNote* unit = findNote(rx, "lens units CM");
    ASSERT_NE(unit, nullptr);
    EXPECT_EQ(unit->loc.line, 4);
}

TEST(ZmxReader, OlderFieldAndWavelengthForms) {
    const Prescription rx = load("old_forms.zmx");
    EXPECT_EQ(rx.system.aperture.kind, SystemAperture::Kind::FloatByStop);
    ASSERT_EQ(rx.system.fields.size(), 3u);
    EXPECT_EQ(rx.system.fields[2].y, 14.0);  // angles are not lengths: no unit conversion
    EXPECT_EQ(rx.system.fields[2].weight, 3.0);
    ASSERT_EQ(rx.system.wavelengths.size(), 3u);
    EXPECT_DOUBLE_EQ(rx.system.wavelengths[0].nm, 486.1327);
    EXPECT_EQ(rx.system.wavelengths[1].weight, 2.0);
    EXPECT_EQ(rx.system.primaryWavelength, 1);
    // UNIT IN: 0.2 in = 5.08 mm; curvature 0.05 / in.
    EXPECT_DOUBLE_EQ(rx.surfaces[1].thicknessMm, 5.08);
    EXPECT_DOUBLE_EQ(rx.surfaces[1].curvature, 0.05 / 25.4);
    EXPECT_DOUBLE_EQ(rx.surfaces[1].clearSemiDiameterMm, 12.7);
}

TEST(ZmxReader, VignettingFactorsAreReadPerField) {
    const std::string text =
        "NAME v\nENPD 10\nFTYP 0 0 2 1\nXFLN 0 0\nYFLN 0 10\nVDXN 0 0.05\nVDYN 0 -0.1\n"
        "VCXN 0 0.2\nVCYN 0 0.3\nWAVM 1 0.55 1\nSURF 0\n DISZ INFINITY\nSURF 1\n STOP\n"
        " CURV 0.02\n DISZ 3\n GLAS N-BK7 0 0 1.5168 64.17\nSURF 2\n CURV -0.02\n DISZ 45\n"
        "SURF 3\n";
    const Prescription rx = readZmxText(text, "v.zmx", GlassCatalog::builtIn());
    ASSERT_EQ(rx.system.fields.size(), 2u);
    EXPECT_FALSE(rx.system.fields[0].vignetted());
    const Field& f = rx.system.fields[1];
    EXPECT_EQ(f.vdx, 0.05);
    EXPECT_EQ(f.vdy, -0.1);
    EXPECT_EQ(f.vcx, 0.2);
    EXPECT_EQ(f.vcy, 0.3);
    EXPECT_EQ(findNote(rx, "VCYN"), nullptr);  // read, not skipped
}

TEST(ZmxReader, ObjectNumericalApertureAndConeAngle) {
    const std::string head = "NAME na\nFTYP 1 0 1 1\nYFLN 0\nWAVM 1 0.55 1\n";
    const std::string body =
        "SURF 0\n DISZ 50\nSURF 1\n STOP\n CURV 0.02\n DISZ 3\n GLAS N-BK7 0 0 1.5168 64.17\n"
        "SURF 2\n CURV -0.02\n DISZ 45\nSURF 3\n";
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    const Prescription na = readZmxText(head + "OBNA 1.5E-1 0\n" + body, "na.zmx", catalog);
    EXPECT_EQ(na.system.aperture.kind, SystemAperture::Kind::ObjectSpaceNA);
    EXPECT_EQ(na.system.aperture.value, 0.15);
    const Prescription cone = readZmxText(head + "OBNA 30 1\n" + body, "cone.zmx", catalog);
    EXPECT_EQ(cone.system.aperture.kind, SystemAperture::Kind::ObjectSpaceNA);
    EXPECT_NEAR(cone.system.aperture.value, 0.5, 1e-15);  // sin 30 deg
    EXPECT_NE(findNote(cone, "object cone angle"), nullptr);
}

// Surface apertures: a centred circular obscuration from the axis (OBSC 0 R) or the inner edge
// of a circular aperture (CLAP R max) on a mirror or a surface in air becomes the central
// hole, in mm; anything else keeps the warning.
TEST(ZmxReader, CentredCircularHolesAreImported) {
    const std::string text =
        "UNIT CM X W X CM MR CPMM\n"                              // 1
        "ENPD 10\n"                                               // 2
        "SURF 0\n DISZ INFINITY\n"                                // 3-4
        "SURF 1\n CURV -0.025\n DISZ -15\n GLAS MIRROR 0 0\n"     // 5-8
        " DIAM 5 1 0 0 1 \"\"\n OBSC 0 1.5 0\n OBDC 0 0\n"        // 9-11: primary, hole 15 mm
        "SURF 2\n CURV -0.05\n DISZ 18\n GLAS MIRROR 0 0\n"       // 12-15
        " DIAM 1.5 0 0 0 1 \"\"\n CLAP 0.3 1.4 0\n"               // 16-17: secondary, hole 3 mm
        "SURF 3\n DISZ 1\n DIAM 2 0 0 0 1 \"\"\n"                 // 18-20
        " OBSC 0 0.5 0\n OBDC 0.2 0\n"                            // 21-22: decentered
        "SURF 4\n DISZ 0.5\n GLAS N-BK7 0 0 1.5168 64.17\n"       // 23-25
        " DIAM 2 0 0 0 1 \"\"\n OBSC 0 0.4 0\n"                   // 26-27: lens face
        "SURF 5\n DISZ 2\n DIAM 2 0 0 0 1 \"\"\n OBSC 0.5 1 0\n"  // 28-31: annular
        "SURF 6\n DISZ 1\n DIAM 2 0 0 0 1 \"\"\n OBSC 0 3 0\n"    // 32-35: beyond DIAM
        "SURF 7\n DISZ 1\n DIAM 2 0 0 0 1 \"\"\n CLAP 0 1.5 0\n"  // 36-39: no hole
        "SURF 8\n";
    const Prescription rx = readZmxText(text, "holes.zmx", GlassCatalog::builtIn());
    ASSERT_EQ(rx.surfaces.size(), 9u);
    EXPECT_DOUBLE_EQ(rx.surfaces[1].innerSemiDiameterMm, 15.0);  // cm -> mm
    EXPECT_DOUBLE_EQ(rx.surfaces[2].innerSemiDiameterMm, 3.0);
    for (int i : {3, 4, 5, 6, 7}) EXPECT_EQ(rx.surfaces[i].innerSemiDiameterMm, 0.0) << i;

    auto expectNote = [&](const std::string& noteText, ImportNote::Severity severity, int line) {
        const ImportNote* n = findNote(rx, noteText);
        ASSERT_NE(n, nullptr) << noteText << "\n" << reportText(rx);
        EXPECT_EQ(n->severity, severity) << n->message;
        EXPECT_EQ(n->loc.line, line) << n->message;
    };
    using Severity = ImportNote::Severity;
    expectNote("OBSC imported as a central hole of radius 1.5 (hole_sd): OBSC 0 1.5 0; OBDC 0 0",
               Severity::Info, 10);
    expectNote(
        "CLAP imported as a central hole of radius 0.3 (hole_sd): CLAP 0.3 1.4 0; its "
        "outer radius 1.4 is not imported",
        Severity::Warning, 17);
    expectNote("OBSC not imported: OBSC 0 0.5 0; OBDC 0.2 0 (decentered", Severity::Warning, 21);
    expectNote("OBSC not imported: OBSC 0 0.4 0 (a hole in a surface of a lens element",
               Severity::Warning, 27);
    expectNote("OBSC not imported: OBSC 0.5 1 0 (an annular obscuration", Severity::Warning, 31);
    expectNote(
        "OBSC not imported: OBSC 0 3 0 (the hole radius 3 is not inside the clear "
        "semi-diameter DIAM 2",
        Severity::Warning, 35);
    expectNote("CLAP not imported: CLAP 0 1.5 0 (no central hole", Severity::Warning, 39);
}

// Reported problems, with their line numbers

TEST(ZmxReader, UnknownGlassIsReportedWithItsLine) {
    const Prescription rx = load("unknown_glass.zmx");
    // N-BK77: not in the catalog, the file stores nd/vd -> model glass, Warning.
    const ImportNote* typo = findNote(rx, "unknown glass 'N-BK77'");
    ASSERT_NE(typo, nullptr) << reportText(rx);
    EXPECT_EQ(typo->severity, ImportNote::Severity::Warning);
    EXPECT_EQ(typo->loc.line, 20);
    EXPECT_EQ(typo->loc.column, 8);
    EXPECT_NE(typo->message.find("did you mean"), std::string::npos) << typo->message;
    EXPECT_NE(typo->message.find("N-BK7"), std::string::npos) << typo->message;
    EXPECT_EQ(rx.surfaces[1].material, Material::model(1.5168, 64.17));
    // UNOBTAINIUM: nothing to fall back on -> Error, name kept.
    const ImportNote* none = findNote(rx, "unknown glass 'UNOBTAINIUM'");
    ASSERT_NE(none, nullptr) << reportText(rx);
    EXPECT_EQ(none->severity, ImportNote::Severity::Error);
    EXPECT_EQ(none->loc.line, 26);
    EXPECT_EQ(rx.surfaces[2].material, Material::catalog("UNOBTAINIUM"));
}

// A legacy name the catalogs hold under its maker's new name (BK7, now Schott's N-BK7; K9,
// CDGM's H-K9L) is that glass, with a note naming it, not the file's stored model glass.
TEST(ZmxReader, LegacyGlassNamesAreTheirSuccessors) {
    const std::string text =
        "ENPD 10\nSURF 0\n DISZ INFINITY\nSURF 1\n STOP\n CURV 0.02\n DISZ 2\n"
        " GLAS BK7 0 0 1.5168 64.17 0 0 0 0 0 0\nSURF 2\n DISZ 1\nSURF 3\n CURV -0.01\n"
        " DISZ 2\n GLAS K9 0 0 1.5163 64.06 0 0 0 0 0 0\nSURF 4\n DISZ 40\nSURF 5\n";
    const Prescription rx = readZmxText(text, "legacy.zmx", GlassCatalog::builtIn());
    EXPECT_EQ(rx.surfaces[1].material, Material::catalog("N-BK7"));
    EXPECT_EQ(rx.surfaces[3].material, Material::catalog("H-K9L"));
    const ImportNote* bk7 = findNote(rx,
                                     "glass BK7 is in no loaded catalog under that name; "
                                     "taken as N-BK7 (SCHOTT)");
    ASSERT_NE(bk7, nullptr) << reportText(rx);
    EXPECT_EQ(bk7->severity, ImportNote::Severity::Info);
    EXPECT_EQ(bk7->loc.line, 8);
    EXPECT_NE(findNote(rx, "taken as H-K9L (CDGM)"), nullptr) << reportText(rx);
    EXPECT_EQ(findNote(rx, "unknown glass"), nullptr) << reportText(rx);
}

// GCAT naming a catalog veil has not loaded explains every glass that falls back: a warning,
// with the way to load it, not an info line among the others.
TEST(ZmxReader, UnloadedGcatCatalogIsAWarningWithTheFix) {
    // LightPath's moldable D-ZK3M (nd 1.58913, Vd 61.15 in the file's model glass).
    const std::string text =
        "GCAT LIGHTPATH\nENPD 10\nSURF 0\n DISZ INFINITY\nSURF 1\n STOP\n CURV 0.02\n DISZ 2\n"
        " GLAS D-ZK3M 0 0 1.58913 61.15 0 0 0 0 0 0\nSURF 2\n DISZ 40\nSURF 3\n";
    const Prescription rx = readZmxText(text, "lightpath.zmx", GlassCatalog::builtIn());
    const ImportNote* gcat = findNote(rx, "glass catalog LIGHTPATH named by GCAT is not loaded");
    ASSERT_NE(gcat, nullptr) << reportText(rx);
    EXPECT_EQ(gcat->severity, ImportNote::Severity::Warning);
    EXPECT_EQ(gcat->loc.line, 1);
    EXPECT_NE(gcat->message.find("--glass-catalog"), std::string::npos) << gcat->message;
    const ImportNote* glass = findNote(rx, "unknown glass 'D-ZK3M'");
    ASSERT_NE(glass, nullptr) << reportText(rx);
    EXPECT_EQ(glass->severity, ImportNote::Severity::Warning);
    EXPECT_EQ(rx.surfaces[1].material, Material::model(1.58913, 61.15));

    // When every glass is found anyway, the catalog is an Info of the import report (which
    // commands do not print), not a warning.
    const std::string found =
        "GCAT LIGHTPATH SCHOTT\nENPD 10\nSURF 0\n DISZ INFINITY\nSURF 1\n STOP\n CURV 0.02\n"
        " DISZ 2\n GLAS N-BK7 0 0 1.5168 64.17 0 0 0 0 0 0\nSURF 2\n DISZ 40\nSURF 3\n";
    const Prescription ok = readZmxText(found, "found.zmx", GlassCatalog::builtIn());
    const ImportNote* quiet = findNote(ok, "glass catalog LIGHTPATH named by GCAT is not loaded");
    ASSERT_NE(quiet, nullptr) << reportText(ok);
    EXPECT_EQ(quiet->severity, ImportNote::Severity::Info);
    EXPECT_NE(quiet->message.find("every glass of the file was found"), std::string::npos);
}

// An unknown command repeated on many lines (a merit function's operands, surface ids) is one
// warning per command, with its count and first line.
TEST(ZmxReader, RepeatedUnknownCommandsAreOneWarningEach) {
    std::string text =
        "ENPD 10\nSURF 0\n DISZ INFINITY\n SSID 0\nSURF 1\n STOP\n SSID 1\n CURV 0.02\n"
        " DISZ 2\n GLAS N-BK7\nSURF 2\n SSID 2\n DISZ 40\nSURF 3\n";
    text += "FROB 1\n";
    const Prescription rx = readZmxText(text, "ssid.zmx", GlassCatalog::builtIn());
    int ssid = 0;
    for (const ImportNote& n : rx.report)
        if (n.message.find("'SSID'") != std::string::npos) {
            ++ssid;
            EXPECT_EQ(n.message, "unknown command 'SSID' ignored (3 lines; the first: SSID 0)");
            EXPECT_EQ(n.loc.line, 4);
            EXPECT_EQ(n.severity, ImportNote::Severity::Warning);
        }
    EXPECT_EQ(ssid, 1) << reportText(rx);
    const ImportNote* frob = findNote(rx, "unknown command 'FROB'");
    ASSERT_NE(frob, nullptr);
    EXPECT_EQ(frob->message, "unknown command 'FROB' ignored: FROB 1");
}

// The built-in Hoya, Nikon and Sumita catalogs answer GCAT lines naming them: each glass
// below comes from the catalog GCAT names, with the nd and Vd the file's GLAS line carries
// (what the designer's program read from the same vendor catalog), and no note about it.
TEST(ZmxReader, GcatVendorGlassesAreBuiltIn) {
    struct Case {
        const char* catalog;
        const char* glass;
        double nd, vd;
    };
    for (const Case& c :
         {Case{"HOYA", "BACD5", 1.58913, 61.25}, Case{"HOYA", "FCD1", 1.497, 81.61},
          Case{"NIKON", "E-BK7", 1.5168, 64.11}, Case{"SUMITA", "K-BK7", 1.51633, 64.1},
          Case{"SCHOTT", "ZERODUR", 1.54236, 56.12}}) {
        const std::string text = std::string("GCAT ") + c.catalog +
                                 "\nENPD 10\nSURF 0\n DISZ INFINITY\nSURF 1\n STOP\n"
                                 " CURV 0.02\n DISZ 2\n GLAS " +
                                 c.glass + " 0 0 " + std::to_string(c.nd) + " " +
                                 std::to_string(c.vd) + " 0 0 0 0 0 0\nSURF 2\n DISZ 40\nSURF 3\n";
        const Prescription rx = readZmxText(text, "vendor.zmx", GlassCatalog::builtIn());
        EXPECT_EQ(findNote(rx, "GCAT"), nullptr) << reportText(rx);
        EXPECT_EQ(findNote(rx, c.glass), nullptr) << reportText(rx);
        EXPECT_EQ(rx.surfaces[1].material, Material::catalog(c.glass)) << c.glass;
        const Glass* g = GlassCatalog::builtIn().find(c.glass, std::vector<std::string>{c.catalog});
        ASSERT_NE(g, nullptr) << c.glass;
        EXPECT_EQ(g->catalog(), c.catalog);
        EXPECT_NEAR(g->index(kLineD), c.nd, 1e-5) << c.glass;
        EXPECT_NEAR(g->abbeNumber(), c.vd, 0.05) << c.glass;
    }
}

TEST(ZmxReader, ConstantIndexModelGlassHasNoDispersion) {
    // Vd = 0 is Zemax's constant index; nd 1 / Vd 0 is air; nd < 1 is reported.
    const std::string text =
        "ENPD 10\nSURF 0\n DISZ INFINITY\nSURF 1\n STOP\n CURV 0.02\n DISZ 2\n"
        " GLAS ___BLANK 1 0 1.7 0 0 0 0 0 0 0\nSURF 2\n DISZ 1\n"
        " GLAS ___BLANK 1 0 1 0 0 0 0 0 0 0\nSURF 3\n DISZ 1\n"
        " GLAS ___BLANK 1 0 0.9 0 0 0 0 0 0 0\nSURF 4\n DISZ 40\nSURF 5\n";
    const Prescription rx = readZmxText(text, "const.zmx", GlassCatalog::builtIn());
    EXPECT_EQ(rx.surfaces[1].material, Material::model(1.7, 0.0));
    const Glass g = Glass::model(1.7, 0.0);
    EXPECT_EQ(g.index(400.0), 1.7);
    EXPECT_EQ(g.index(1000.0), 1.7);
    EXPECT_TRUE(rx.surfaces[2].material.isAir());
    const ImportNote* n = findNote(rx, "model glass nd = 0.9, Vd = 0 is not physical");
    ASSERT_NE(n, nullptr) << reportText(rx);
    EXPECT_EQ(n->severity, ImportNote::Severity::Error);
    EXPECT_EQ(n->loc.line, 14);
}

// An index a little below 1 with Vd = 0 is a gas or vacuum relative to air (US 2003/0048547's
// object space is 0.999982): air, with a warning saying by how much; below 0.999, an error.
TEST(ZmxReader, GasIndexJustBelowAirIsAirWithAWarning) {
    auto read = [](const std::string& nd) {
        return readZmxText("ENPD 10\nSURF 0\n DISZ INFINITY\n GLAS ___BLANK 1 0 " + nd +
                               " 0 0 0 0 0 0 0\nSURF 1\n STOP\n CURV 0.02\n DISZ 2\n"
                               " GLAS ___BLANK 1 0 1.7 0 0 0 0 0 0 0\nSURF 2\n DISZ 40\nSURF 3\n",
                           "gas.zmx", GlassCatalog::builtIn());
    };
    const Prescription gas = read("0.999982");
    EXPECT_TRUE(gas.surfaces[0].material.isAir());
    const ImportNote* n = findNote(gas, "model glass nd = 0.999982, Vd = 0 (a gas or vacuum");
    ASSERT_NE(n, nullptr) << reportText(gas);
    EXPECT_EQ(n->severity, ImportNote::Severity::Warning);
    EXPECT_NE(n->message.find("differs by 1.8e-05"), std::string::npos) << n->message;
    const Prescription below = read("0.998");
    const ImportNote* e = findNote(below, "model glass nd = 0.998, Vd = 0 is not physical");
    ASSERT_NE(e, nullptr) << reportText(below);
    EXPECT_EQ(e->severity, ImportNote::Severity::Error);
}

// nd 1.5, Vd 40 on a GLAS line is what programs write for a glass they did not have
// (Liang's eye model's COC, US 5,831,776's SILICA): an unknown glass with it is an error,
// not a model glass; a glass found anyway gets no "different catalog version" note.
TEST(ZmxReader, ThePlaceholderNdVdIsNotAGlass) {
    auto read = [](const std::string& glass) {
        return readZmxText(
            "ENPD 10\nSURF 0\n DISZ INFINITY\nSURF 1\n STOP\n CURV 0.02\n DISZ 2\n"
            " GLAS " +
                glass + " 0 0 1.5 4.0E+1 0 0 0 0 0 0\nSURF 2\n DISZ 40\nSURF 3\n",
            "placeholder.zmx", GlassCatalog::builtIn());
    };
    const Prescription unknown = read("COC");
    const ImportNote* e = findNote(unknown, "unknown glass 'COC'");
    ASSERT_NE(e, nullptr) << reportText(unknown);
    EXPECT_EQ(e->severity, ImportNote::Severity::Error);
    EXPECT_NE(e->message.find("the placeholder lens design programs write"), std::string::npos)
        << e->message;
    EXPECT_EQ(e->loc.line, 8);
    const Prescription found = read("SILICA");
    EXPECT_EQ(found.surfaces[1].material, Material::catalog("SILICA"));
    EXPECT_EQ(findNote(found, "different catalog version"), nullptr) << reportText(found);
    // Other stored values still make a model glass, with a warning.
    const Prescription model = readZmxText(
        "ENPD 10\nSURF 0\n DISZ INFINITY\nSURF 1\n STOP\n CURV 0.02\n DISZ 2\n"
        " GLAS NOSUCH 0 0 1.6 4.0E+1 0 0 0 0 0 0\nSURF 2\n DISZ 40\nSURF 3\n",
        "model.zmx", GlassCatalog::builtIn());
    EXPECT_EQ(model.surfaces[1].material, Material::model(1.6, 40.0));
}

// A Q-type surface (TYPE QED_TYPE) is an Error that says how to bring it in: veil models the
// surface (TOML qbfs / qcon) but does not read its .zmx encoding.
TEST(ZmxReader, QTypeSurfaceSaysHowToBringItIn) {
    const std::string text =
        "VERS 190513 80 123\nMODE SEQ\nUNIT MM X W X CM MR CPMM\nENPD 10\nSURF 0\n DISZ "
        "INFINITY\nSURF 1\n STOP\n TYPE QED_TYPE\n CURV 0.02\n XDAT 3 5\n XDAT 4 0.01\n DISZ "
        "4\n GLAS N-BK7 0 0 1.5168 64.17\n DIAM 5 1\nSURF 2\n DISZ 40\nSURF 3\n";
    const Prescription rx = readZmxText(text, "q.zmx", GlassCatalog::builtIn());
    const ImportNote* n = findNote(rx, "surface type QED_TYPE");
    ASSERT_NE(n, nullptr) << reportText(rx);
    EXPECT_EQ(n->severity, ImportNote::Severity::Error);
    EXPECT_EQ(n->loc.line, 9);
    EXPECT_NE(n->message.find("XDAT 4 = 0.01"), std::string::npos) << n->message;
    EXPECT_NE(n->message.find("qbfs or qcon"), std::string::npos) << n->message;
}

// TOROIDAL: PARM 1 the radius of rotation (0: infinite), PARM 2..8 the y^2..y^14 terms;
// BICONICX: PARM 1 the x radius, PARM 2 the x conic; lengths in lens units (cm here).
TEST(ZmxReader, ToroidalAndBiconicSurfaces) {
    const std::string text =
        "UNIT CM\nENPD 1\nWAVM 1 0.55 1\nSURF 0\n DISZ INFINITY\nSURF 1\n TYPE TOROIDAL\n"
        " CURV 0.5\n CONI -0.3\n PARM 1 4\n PARM 2 0.01\n PARM 3 -0.002\n PARM 13 0\n"
        " XDAT 1 0 0 0 0\n DISZ 0.4\n GLAS N-BK7 0 0 1.5168 64.17\n DIAM 1 1\nSURF 2\n"
        " TYPE TOROIDAL\n PARM 1 0\n DISZ 1\n DIAM 1 1\nSURF 3\n TYPE BICONICX\n CURV -0.2\n"
        " PARM 1 -2.5\n PARM 2 -1\n DISZ 0.3\n GLAS N-BK7 0 0 1.5168 64.17\n DIAM 1 1\n"
        "SURF 4\n DISZ 5\nSURF 5\n";
    const Prescription rx = readZmxText(text, "t.zmx", GlassCatalog::builtIn());
    for (const ImportNote& n : rx.report)
        EXPECT_NE(n.severity, ImportNote::Severity::Error) << n;
    const Surface& t = rx.surfaces[1];
    ASSERT_TRUE(t.anamorphic);
    EXPECT_EQ(t.anamorphic->kind, Anamorphic::Kind::Toroidal);
    EXPECT_DOUBLE_EQ(t.anamorphic->xCurvature, 1.0 / 40.0);
    EXPECT_DOUBLE_EQ(t.curvature, 0.05);
    EXPECT_DOUBLE_EQ(t.conic, -0.3);
    EXPECT_DOUBLE_EQ(t.asphere[0], 0.01 / 10.0);     // y^2: 1/length
    EXPECT_DOUBLE_EQ(t.asphere[1], -0.002 / 1000.0);  // y^4: 1/length^3
    EXPECT_EQ(rx.surfaces[2].anamorphic->xCurvature, 0.0);  // PARM 1 0: a cylinder
    const Surface& b = rx.surfaces[3];
    ASSERT_TRUE(b.anamorphic);
    EXPECT_EQ(b.anamorphic->kind, Anamorphic::Kind::Biconic);
    EXPECT_DOUBLE_EQ(b.anamorphic->xCurvature, -1.0 / 25.0);
    EXPECT_DOUBLE_EQ(b.anamorphic->xConic, -1.0);
    EXPECT_DOUBLE_EQ(b.curvature, -0.02);
    EXPECT_NO_THROW(rx.validate());
}

// The toroid's Zernike sag terms are not modelled: an Error at the count and at each value
// that is not zero; XDAT 1 and 2 (the count and the normalization radius) are no terms.
TEST(ZmxReader, ToroidalZernikeTermsAreErrors) {
    const std::string text =
        "ENPD 1\nWAVM 1 0.55 1\nSURF 0\n DISZ INFINITY\nSURF 1\n TYPE TOROIDAL\n CURV 0.05\n"
        " PARM 1 40\n PARM 13 2\n XDAT 1 2 0 0 0\n XDAT 2 10 0 0 0\n XDAT 3 0.001 0 0 0\n"
        " DISZ 4\n GLAS N-BK7 0 0 1.5168 64.17\n DIAM 5 1\nSURF 2\n DISZ 40\nSURF 3\n";
    const Prescription rx = readZmxText(text, "z.zmx", GlassCatalog::builtIn());
    const ImportNote* count = findNote(rx, "TOROIDAL PARM 13 = 2");
    ASSERT_NE(count, nullptr) << reportText(rx);
    EXPECT_EQ(count->severity, ImportNote::Severity::Error);
    EXPECT_EQ(count->loc.line, 9);
    const ImportNote* term = findNote(rx, "XDAT 3 = 0.001");
    ASSERT_NE(term, nullptr) << reportText(rx);
    EXPECT_EQ(term->severity, ImportNote::Severity::Error);
    EXPECT_EQ(term->loc.line, 12);
    EXPECT_EQ(findNote(rx, "XDAT 2 = 10"), nullptr) << reportText(rx);  // the radius is no term

    // As Zemax writes a toroid without Zernike terms: the count 0 and the normalization
    // radius 100 (XDAT 1, XDAT 2) are no terms, and the lens loads.
    const std::string plain =
        "ENPD 1\nWAVM 1 0.55 1\nSURF 0\n DISZ INFINITY\nSURF 1\n TYPE TOROIDAL\n CURV 0.05\n"
        " PARM 1 40\n XDAT 1 0 0 0 1 0 0 \"\"\n XDAT 2 1.0E+02 0 0 1 0 0 \"\"\n"
        " DISZ 4\n GLAS N-BK7 0 0 1.5168 64.17\n DIAM 5 1\nSURF 2\n DISZ 40\nSURF 3\n";
    const Prescription ok = readZmxText(plain, "t.zmx", GlassCatalog::builtIn());
    for (const ImportNote& n : ok.report) EXPECT_NE(n.severity, ImportNote::Severity::Error) << n;
    ASSERT_TRUE(ok.surfaces[1].anamorphic);
}

TEST(ZmxReader, UnsupportedSurfacesAndCommandsAreReported) {
    const Prescription rx = load("unsupported.zmx");
    ASSERT_EQ(rx.surfaces.size(), 6u);  // nothing dropped

    const ImportNote* cb = findNote(rx, "surface type IRREGULA");  // an irregular surface
    ASSERT_NE(cb, nullptr) << reportText(rx);
    EXPECT_EQ(cb->severity, ImportNote::Severity::Error);
    EXPECT_EQ(cb->loc.line, 28);
    EXPECT_NE(cb->message.find("would lose its shape"), std::string::npos) << cb->message;
    EXPECT_NE(cb->message.find("PARM 3 = 45"), std::string::npos) << cb->message;
    EXPECT_EQ(rx.surfaces[3].thicknessMm, 5.0);  // its thickness still counts

    const ImportNote* zernike = findNote(rx, "surface type SZERNSAG");
    ASSERT_NE(zernike, nullptr) << reportText(rx);
    EXPECT_EQ(zernike->severity, ImportNote::Severity::Error);
    EXPECT_EQ(zernike->loc.line, 38);
    EXPECT_NE(zernike->message.find("PARM 1 = -40"), std::string::npos) << zernike->message;
    EXPECT_EQ(rx.surfaces[4].curvature, -0.02);  // its base curvature
    EXPECT_TRUE(rx.surfaces[4].mirror);
    EXPECT_EQ(rx.surfaces[4].thicknessMm, -40.0);

    const ImportNote* frob = findNote(rx, "unknown command 'FROB'");
    ASSERT_NE(frob, nullptr) << reportText(rx);
    EXPECT_EQ(frob->severity, ImportNote::Severity::Warning);
    EXPECT_EQ(frob->loc.line, 11);
    const ImportNote* wibl = findNote(rx, "unknown command 'WIBL'");
    ASSERT_NE(wibl, nullptr) << reportText(rx);
    EXPECT_EQ(wibl->loc.line, 45);

    // FTYP 2: paraxial image heights, kept as given (in mm) for the scene to resolve
    // (tracer/sequential/image_fields.h); nothing to report.
    EXPECT_EQ(findNote(rx, "field type"), nullptr) << reportText(rx);
    EXPECT_EQ(rx.system.fieldKind, SystemData::FieldKind::ParaxialImageHeightMm);
    ASSERT_EQ(rx.system.fields.size(), 3u);
    EXPECT_EQ(rx.system.fields[1].y, 3.0);
    EXPECT_EQ(rx.system.fields[2].y, 4.0);

    // The report is in file order.
    EXPECT_TRUE(std::is_sorted(
        rx.report.begin(), rx.report.end(),
        [](const ImportNote& a, const ImportNote& b) { return a.loc.line < b.loc.line; }));
}

TEST(ZmxReader, MalformedNumberThrowsWithPosition) {
    try {
        load("malformed_number.zmx");
        FAIL() << "expected ParseError";
    } catch (const ParseError& e) {
        EXPECT_EQ(e.loc().line, 9);
        EXPECT_EQ(e.loc().column, 8);  // "  CURV abc": the bad token
        EXPECT_NE(e.loc().file.find("malformed_number.zmx"), std::string::npos);
        EXPECT_NE(e.message().find("'abc'"), std::string::npos) << e.message();
    }
    // Trailing junk and non-finite values are malformed too.
    const std::string base = "SURF 0\n DISZ INFINITY\nSURF 1\n DISZ 1\nSURF 2\n";
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    EXPECT_THROW(readZmxText(base + " CURV 0.1x\n", "a.zmx", catalog), ParseError);
    EXPECT_THROW(readZmxText(base + " CONI nan\n", "a.zmx", catalog), ParseError);
    EXPECT_THROW(readZmxText("FTYP 0 0 two 1\n" + base, "a.zmx", catalog), ParseError);
    EXPECT_THROW(readZmxText("UNIT FURLONG\n" + base, "a.zmx", catalog), ParseError);
}

TEST(ZmxReader, FileWithoutSurfacesIsNotALensFile) {
    EXPECT_THROW(load("not_a_lens.zmx"), ParseError);
    EXPECT_THROW(readZmxText("", "empty.zmx", GlassCatalog::builtIn()), ParseError);
    EXPECT_THROW(load("no_such_file.zmx"), ParseError);
}

TEST(ZmxReader, SurfaceCommandBeforeFirstSurfaceIsAnError) {
    EXPECT_THROW(
        readZmxText("CURV 0.1\nSURF 0\nSURF 1\nSURF 2\n", "a.zmx", GlassCatalog::builtIn()),
        ParseError);
}

}  // namespace
// ODDASPH: PARM n multiplies r^n; the even powers join the even asphere, the odd ones (r^3,
// r^5, r^7) the odd terms, both in the lens units converted to mm; an r^1 term is an Error.
TEST(ZmxReader, OddAsphereTermsByPower) {
    const std::string head =
        "UNIT CM X W X CM MR CPMM\nENPD 1\nSURF 0\n DISZ INFINITY\nSURF 1\n STOP\n"
        " TYPE ODDASPH\n CURV 0.02\n";
    const std::string tail = " DISZ 0.5\n GLAS N-BK7\nSURF 2\n DISZ 10\nSURF 3\n";
    const Prescription rx =
        readZmxText(head + " PARM 2 1e-3\n PARM 3 2e-4\n PARM 4 -3e-5\n PARM 5 4e-6\n" + tail,
                    "odd.zmx", GlassCatalog::builtIn());
    const Surface& s = rx.surfaces[1];
    // cm to mm: a coefficient of r^n scales by 10^(1 - n).
    EXPECT_NEAR(s.asphere[0], 1e-3 * std::pow(10.0, -1.0), 1e-18);     // r^2
    EXPECT_NEAR(s.oddAsphere[0], 2e-4 * std::pow(10.0, -2.0), 1e-18);  // r^3
    EXPECT_NEAR(s.asphere[1], -3e-5 * std::pow(10.0, -3.0), 1e-18);    // r^4
    EXPECT_NEAR(s.oddAsphere[1], 4e-6 * std::pow(10.0, -4.0), 1e-18);  // r^5
    EXPECT_TRUE(s.hasAsphere());
    for (const ImportNote& n : rx.report) EXPECT_NE(n.severity, ImportNote::Severity::Error) << n;
    const Prescription cone =
        readZmxText(head + " PARM 1 0.01\n" + tail, "cone.zmx", GlassCatalog::builtIn());
    const ImportNote* note = findNote(cone, "a term in r^1");
    ASSERT_NE(note, nullptr) << reportText(cone);
    EXPECT_EQ(note->severity, ImportNote::Severity::Error);
}

}  // namespace veil
