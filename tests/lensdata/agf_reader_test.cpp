// Tests for lensdata/agf_reader.h: the fields of every AGF line, the text encodings,
// veil-catalog markers, errors with file:line:column, and writing back.

#include "lensdata/agf_reader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <sstream>
#include <string>

#include "lensdata/errors.h"
#include "lensdata/text_decoding.h"

namespace veil {
namespace {

const std::string kData = std::string(VEIL_SOURCE_DIR) + "/tests/data/glass/";

// Parses `text` and returns the ParseError it must throw.
ParseError parseErrorOf(const std::string& text, const std::string& file = "t.agf") {
    try {
        parseAgf(text, file, "T");
    } catch (const ParseError& e) {
        return e;
    }
    ADD_FAILURE() << "no ParseError for:\n" << text;
    return ParseError(FileLoc{}, "none");
}

// Reading

TEST(AgfReader, ReadsEveryFieldOfTheSample) {
    const std::vector<AgfCatalog> cats = readAgfFile(kData + "sample.agf");
    ASSERT_EQ(cats.size(), 1u);
    const AgfCatalog& cat = cats[0];
    EXPECT_EQ(cat.name, "SAMPLE");  // the file stem in upper case
    ASSERT_EQ(cat.comments.size(), 1u);
    EXPECT_EQ(cat.comments[0],
              "Test catalog for the veil AGF reader (tests/lensdata/agf_reader_test.cpp)");
    ASSERT_EQ(cat.glasses.size(), 2u);

    const Glass& a = cat.glasses[0];
    EXPECT_EQ(a.name(), "TESTSCHOTT");
    EXPECT_EQ(a.catalog(), "SAMPLE");
    EXPECT_EQ(a.formula(), DispersionFormula::Schott);
    EXPECT_EQ(a.milCode, "517642");
    EXPECT_EQ(a.ndCatalog, 1.5168);
    EXPECT_EQ(a.vdCatalog, 64.17);
    EXPECT_FALSE(a.excludeSubstitution);
    EXPECT_EQ(a.status, GlassStatus::Preferred);
    EXPECT_EQ(a.meltFrequency, 3);
    EXPECT_EQ(a.comment, "BK7 with the Schott formula coefficients of the pre-1992 Schott catalog");
    EXPECT_EQ(a.extraData, (std::vector<double>{7.1, 8.3, 2.51, -0.0009, 0.0}));
    EXPECT_EQ(a.dPgF(), -0.0009);
    EXPECT_EQ(a.coefficients(),
              (std::vector<double>{2.2718929, -0.010108077, 0.010592509, 0.00020816965,
                                   -7.6472538e-06, 4.9240991e-07, 0.0, 0.0}));
    EXPECT_EQ(a.thermalData,
              (std::vector<double>{1.86e-06, 1.31e-08, -1.37e-11, 4.34e-07, 6.27e-10, 0.17, 20}));
    EXPECT_DOUBLE_EQ(a.minWavelengthNm, 310.0);
    EXPECT_DOUBLE_EQ(a.maxWavelengthNm, 2500.0);
    // IT rows sorted by wavelength; the blank transmittance at 0.31 um reads as 0.
    ASSERT_EQ(a.transmittance.size(), 3u);
    EXPECT_DOUBLE_EQ(a.transmittance[0].wavelengthNm, 310.0);
    EXPECT_EQ(a.transmittance[0].internalTransmittance, 0.0);
    EXPECT_EQ(a.transmittance[0].thicknessMm, 25.0);
    EXPECT_DOUBLE_EQ(a.transmittance[1].wavelengthNm, 400.0);
    EXPECT_EQ(a.transmittance[1].internalTransmittance, 0.992);
    EXPECT_EQ(a.transmittance[1].thicknessMm, 10.0);
    EXPECT_DOUBLE_EQ(a.transmittance[2].wavelengthNm, 500.0);
    // The coefficients are those of BK7: nd = 1.51680 (pre-1992 Schott catalog).
    EXPECT_NEAR(a.index(kLineD), 1.51680, 1e-5);

    const Glass& b = cat.glasses[1];
    EXPECT_EQ(b.name(), "TESTSELL");
    EXPECT_EQ(b.formula(), DispersionFormula::Sellmeier1);
    EXPECT_EQ(b.milCode, "620364.360");
    EXPECT_TRUE(b.excludeSubstitution);
    EXPECT_EQ(b.status, GlassStatus::Obsolete);
    EXPECT_EQ(b.meltFrequency, 0);  // "-": not given
    ASSERT_EQ(b.extraData.size(), 5u);
    EXPECT_TRUE(std::isnan(b.extraData[1]));  // "-": not given
    EXPECT_EQ(b.coefficients().size(), 6u);
    EXPECT_EQ(b.coefficients()[5], 111.886764);
    EXPECT_TRUE(b.thermalData.empty());  // an empty TD line
    EXPECT_TRUE(b.comment.empty());
    ASSERT_EQ(b.transmittance.size(), 2u);
    EXPECT_NEAR(b.index(kLineD), 1.62004, 1e-5);  // the data of Schott F2
}

// The same catalog as UTF-16 LE and BE with BOM and CR LF line ends (what OpticStudio
// writes), and as UTF-8 with BOM, reads exactly like the ASCII file.
TEST(AgfReader, ReadsUtf16AndUtf8WithBom) {
    const std::vector<AgfCatalog> ascii = readAgfFile(kData + "sample.agf");
    for (const char* file : {"sample_utf16le.agf", "sample_utf16be.agf", "sample_utf8bom.agf"}) {
        const std::vector<AgfCatalog> other = readAgfFile(kData + file);
        ASSERT_EQ(other.size(), 1u) << file;
        EXPECT_EQ(other[0].comments, ascii[0].comments) << file;
        ASSERT_EQ(other[0].glasses.size(), ascii[0].glasses.size()) << file;
        for (size_t i = 0; i < ascii[0].glasses.size(); ++i) {
            const Glass &g = other[0].glasses[i], &h = ascii[0].glasses[i];
            EXPECT_EQ(g.name(), h.name()) << file;
            EXPECT_EQ(g.coefficients(), h.coefficients()) << file;
            EXPECT_EQ(g.comment, h.comment) << file;
            EXPECT_EQ(g.transmittance.size(), h.transmittance.size()) << file;
            EXPECT_EQ(g.index(kLineF), h.index(kLineF)) << file;
        }
    }
}

// `units` as UTF-16 bytes, little or big endian, after an optional BOM.
std::string utf16(std::u16string_view units, bool bigEndian, bool bom = true) {
    std::string bytes;
    if (bom) bytes = bigEndian ? "\xFE\xFF" : "\xFF\xFE";
    for (char16_t u : units) {
        const char hi = static_cast<char>(u >> 8), lo = static_cast<char>(u & 0xFF);
        bytes += bigEndian ? hi : lo;
        bytes += bigEndian ? lo : hi;
    }
    return bytes;
}

TEST(TextDecoding, DecodesUtf16ToUtf8) {
    // A BMP character (degree sign) and a surrogate pair (U+1F600), in UTF-8 after decoding.
    const std::u16string text = u"CC 25\u00B0C \U0001F600";
    const std::string expected = "CC 25\u00B0C \U0001F600";  // UTF-8 execution charset
    EXPECT_EQ(decodeText(utf16(text, false), "x"), expected);
    EXPECT_EQ(decodeText(utf16(text, true), "x"), expected);
    // Without BOM, the zero bytes give UTF-16 away.
    EXPECT_EQ(decodeText(utf16(u"NM", false, false), "x"), "NM");
    EXPECT_EQ(decodeText(utf16(u"NM", true, false), "x"), "NM");
    // An unpaired surrogate becomes U+FFFD.
    const std::u16string lone = {char16_t(0xD800), u'A'};
    EXPECT_EQ(decodeText(utf16(lone, false), "x"), "\uFFFDA");
    // ASCII and UTF-8 pass through; a UTF-8 BOM is dropped.
    EXPECT_EQ(decodeText("NM X", "x"), "NM X");
    EXPECT_EQ(decodeText("\xEF\xBB\xBFNM X", "x"), "NM X");
    // Half a UTF-16 code unit at the end.
    EXPECT_THROW(decodeText(utf16(u"CC", false) + "C", "x"), ParseError);
}

TEST(AgfReader, SkipsUnknownTagsAndAcceptsAnyLineEnd) {
    const std::string text =
        "OD 1 2 3\nBD whatever\r\nNM G 2 0 1.5 60\rCD 1 0.01\r\nMC 1\n! note\nIT 0.5 0.9 10";
    const std::vector<AgfCatalog> cats = parseAgf(text, "t.agf", "T");
    ASSERT_EQ(cats[0].glasses.size(), 1u);
    const Glass& g = cats[0].glasses[0];
    EXPECT_EQ(g.coefficients(), (std::vector<double>{1.0, 0.01}));
    EXPECT_EQ(g.status, GlassStatus::Standard);  // optional NM fields left out
    ASSERT_EQ(g.transmittance.size(), 1u);
    EXPECT_EQ(g.transmittance[0].internalTransmittance, 0.9);
}

TEST(AgfReader, VeilCatalogMarkersSplitOneFileIntoCatalogs) {
    const std::vector<AgfCatalog> cats = readAgfFile(kData + "multi.agf");
    // No glass before the first marker: the default catalog MULTI is left out. "alpha"
    // continues ALPHA.
    ASSERT_EQ(cats.size(), 2u);
    EXPECT_EQ(cats[0].name, "ALPHA");
    EXPECT_EQ(cats[0].comments, (std::vector<std::string>{"First catalog"}));
    ASSERT_EQ(cats[0].glasses.size(), 2u);
    EXPECT_EQ(cats[0].glasses[0].name(), "A1");
    EXPECT_EQ(cats[0].glasses[1].name(), "A2");
    EXPECT_EQ(cats[0].glasses[1].catalog(), "ALPHA");
    EXPECT_EQ(cats[1].name, "BETA");
    ASSERT_EQ(cats[1].glasses.size(), 1u);
    EXPECT_EQ(cats[1].glasses[0].catalog(), "BETA");

    // Glasses before a marker stay in the default catalog.
    const auto mixed =
        parseAgf("NM D 2 0 1.5 60\nCD 1 0.01\nCC veil-catalog X\nNM E 2 0 1.5 60\nCD 1 0.01\n",
                 "m.agf", "DEFAULT");
    ASSERT_EQ(mixed.size(), 2u);
    EXPECT_EQ(mixed[0].name, "DEFAULT");
    EXPECT_EQ(mixed[1].name, "X");
    // Only the exact marker word counts; anything else is a comment.
    const auto comment = parseAgf("CC veil-catalogue X\n", "c.agf", "C");
    ASSERT_EQ(comment.size(), 1u);
    EXPECT_EQ(comment[0].comments, (std::vector<std::string>{"veil-catalogue X"}));
}

// Errors

TEST(AgfReader, NonNumericFieldNamesFileLineAndColumn) {
    try {
        readAgfFile(kData + "bad_number.agf");
        FAIL() << "no ParseError";
    } catch (const ParseError& e) {
        EXPECT_EQ(e.loc().file, kData + "bad_number.agf");
        EXPECT_EQ(e.loc().line, 4);
        EXPECT_EQ(e.loc().column, 17);  // "NM BAD 2 517642 " is 16 characters
        EXPECT_NE(e.message().find("expected a number for nd, got '1.51x80'"), std::string::npos)
            << e.what();
        EXPECT_NE(std::string(e.what()).find("bad_number.agf:4:17"), std::string::npos);
    }
}

TEST(AgfReader, CoefficientsBeforeAnyGlassAreAnError) {
    try {
        readAgfFile(kData + "cd_before_nm.agf");
        FAIL() << "no ParseError";
    } catch (const ParseError& e) {
        EXPECT_EQ(e.loc().line, 2);
        EXPECT_EQ(e.loc().column, 3);
        EXPECT_NE(e.message().find("CD line before any NM line"), std::string::npos) << e.what();
    }
}

TEST(AgfReader, UnknownFormulaNumberIsAnError) {
    try {
        readAgfFile(kData + "unknown_formula.agf");
        FAIL() << "no ParseError";
    } catch (const ParseError& e) {
        EXPECT_EQ(e.loc().line, 2);
        EXPECT_EQ(e.loc().column, 8);
        EXPECT_NE(e.message().find("unknown dispersion formula 14"), std::string::npos) << e.what();
    }
}

TEST(AgfReader, OtherMalformedLines) {
    struct Case {
        std::string text;
        int line, column;
        std::string message;
    };
    const Case cases[] = {
        {"NM G 2 0 1.5\n", 1, 13, "NM line is missing vd"},
        {"NM G 2.5 0 1.5 60\n", 1, 6, "expected an integer for the dispersion formula"},
        {"NM G 2 0 1.5 60 0 7\n", 1, 19, "unknown glass status 7"},
        {"NM G 2 0 1.5 60\nCD 1 x\n", 2, 6, "expected a number for a dispersion coefficient"},
        {"NM G 2 0 1.5 60\nCD 1\nCD 2\n", 3, 1, "second CD line for glass 'G'"},
        {"NM G 2 0 1.5 60\nIT 0.5 1.5 10\n", 2, 8, "internal transmittance must lie in [0, 1]"},
        {"NM G 2 0 1.5 60\nIT 0.5 0.9 0\n", 2, 12, "thickness must be > 0"},
        {"NM G 2 0 1.5 60\nIT 0.5\n", 2, 7, "IT line is missing the internal transmittance"},
        {"NM G 2 0 1.5 60\nLD 0.3\n", 2, 7, "LD line is missing the maximum wavelength"},
        {"NM G 2 0 1.5 60\nED 1 inf\n", 2, 6, "expected a number for ED data, got 'inf'"},
        {"NM G 2 0 1.5 60\nCD 1 0.01\nNM g 2 0 1.5 60\n", 3, 4,
         "glass 'g' is defined twice in catalog T (first at line 1)"},
        // A glass without its coefficients was read as index 1 (vacuum), silently.
        {"NM G 2 0 1.5 60\nLD 0.3 2.5\nNM H 2 0 1.5 60\nCD 1 0.01\n", 1, 1,
         "glass 'G' has no CD line (its dispersion coefficients)"},
        {"NM G 2 0 1.5 60\nCD 1 0.01\nNM H 2 0 1.6 40\n", 3, 1, "glass 'H' has no CD line"},
        {"CC veil-catalog\n", 1, 1, "veil-catalog marker needs one catalog name"},
        {"GC a comment with no glass\n", 1, 1, "GC line before any NM line"},
        // Columns count characters: the two-byte "ß" is one column.
        {"NM Glaß 2 0 x 60\n", 1, 13, "expected a number for nd, got 'x'"},
    };
    for (const Case& c : cases) {
        const ParseError e = parseErrorOf(c.text);
        EXPECT_EQ(e.loc().file, "t.agf");
        EXPECT_EQ(e.loc().line, c.line) << c.text;
        EXPECT_EQ(e.loc().column, c.column) << c.text;
        EXPECT_NE(e.message().find(c.message), std::string::npos)
            << "got '" << e.message() << "' for:\n"
            << c.text;
    }
}

TEST(AgfReader, MissingFileIsAParseErrorNamingIt) {
    try {
        readAgfFile(kData + "no_such_file.agf");
        FAIL() << "no ParseError";
    } catch (const ParseError& e) {
        EXPECT_EQ(e.loc().file, kData + "no_such_file.agf");
        EXPECT_NE(std::string(e.what()).find("no_such_file.agf"), std::string::npos);
    }
}

// Writing

void expectSameGlass(const Glass& a, const Glass& b) {
    EXPECT_EQ(a.name(), b.name());
    EXPECT_EQ(a.catalog(), b.catalog()) << a.name();
    EXPECT_EQ(a.formula(), b.formula()) << a.name();
    // Trailing zero coefficients are not written; they are zero either way.
    std::vector<double> ca = a.coefficients(), cb = b.coefficients();
    while (!ca.empty() && ca.back() == 0.0) ca.pop_back();
    while (!cb.empty() && cb.back() == 0.0) cb.pop_back();
    EXPECT_EQ(ca, cb) << a.name();
    EXPECT_EQ(a.milCode, b.milCode) << a.name();
    EXPECT_EQ(a.ndCatalog, b.ndCatalog) << a.name();
    EXPECT_EQ(a.vdCatalog, b.vdCatalog) << a.name();
    EXPECT_EQ(a.excludeSubstitution, b.excludeSubstitution) << a.name();
    EXPECT_EQ(a.status, b.status) << a.name();
    EXPECT_EQ(a.meltFrequency, b.meltFrequency) << a.name();
    EXPECT_EQ(a.comment, b.comment) << a.name();
    ASSERT_EQ(a.extraData.size(), b.extraData.size()) << a.name();
    for (size_t i = 0; i < a.extraData.size(); ++i)
        EXPECT_TRUE(a.extraData[i] == b.extraData[i] ||
                    (std::isnan(a.extraData[i]) && std::isnan(b.extraData[i])))
            << a.name();
    EXPECT_EQ(a.thermalData, b.thermalData) << a.name();
    EXPECT_EQ(a.minWavelengthNm, b.minWavelengthNm) << a.name();
    EXPECT_EQ(a.maxWavelengthNm, b.maxWavelengthNm) << a.name();
    ASSERT_EQ(a.transmittance.size(), b.transmittance.size()) << a.name();
    for (size_t i = 0; i < a.transmittance.size(); ++i) {
        EXPECT_EQ(a.transmittance[i].wavelengthNm, b.transmittance[i].wavelengthNm) << a.name();
        EXPECT_EQ(a.transmittance[i].internalTransmittance,
                  b.transmittance[i].internalTransmittance)
            << a.name();
        EXPECT_EQ(a.transmittance[i].thicknessMm, b.transmittance[i].thicknessMm) << a.name();
    }
}

TEST(AgfReader, WritesWhatItReads) {
    const AgfCatalog original = readAgfFile(kData + "sample.agf")[0];
    std::ostringstream out;
    writeAgf(out, original);
    const std::string text = out.str();
    EXPECT_EQ(text.rfind("CC veil-catalog SAMPLE\n", 0), 0u) << text;
    EXPECT_NE(text.find("\nIT 0.31 0 25\n"), std::string::npos) << text;  // blank tau: 0
    EXPECT_NE(text.find("\nED 8.2 - 3.599 0.0002 0\n"), std::string::npos) << text;
    const std::vector<AgfCatalog> again = parseAgf(text, "again.agf", "X");
    ASSERT_EQ(again.size(), 1u);
    EXPECT_EQ(again[0].name, "SAMPLE");
    EXPECT_EQ(again[0].comments, original.comments);
    ASSERT_EQ(again[0].glasses.size(), original.glasses.size());
    for (size_t i = 0; i < original.glasses.size(); ++i)
        expectSameGlass(again[0].glasses[i], original.glasses[i]);
}

TEST(AgfReader, ModelGlassesCannotBeWritten) {
    AgfCatalog c{"M", {}, {Glass::model(1.5, 60.0)}};
    std::ostringstream out;
    EXPECT_THROW(writeAgf(out, c), std::invalid_argument);
}

TEST(AgfReader, Prints) {
    std::ostringstream os;
    os << AgfCatalog{"X", {"c"}, {Glass(), Glass()}};
    EXPECT_EQ(os.str(), "AgfCatalog{X, 2 glasses, 1 comments}");
}

}  // namespace
}  // namespace veil
