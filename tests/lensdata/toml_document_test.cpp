#include "lensdata/toml_document.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

namespace veil {
namespace {

using ::testing::HasSubstr;

// Runs `body` and returns the ParseError it throws (a test failure if it throws none).
template <class F>
ParseError parseErrorOf(F&& body) {
    try {
        body();
    } catch (const ParseError& e) {
        return e;
    }
    ADD_FAILURE() << "expected a ParseError";
    return ParseError({}, "none");
}

void expectAt(const ParseError& e, int line, int column) {
    EXPECT_EQ(e.loc().line, line) << e.what();
    EXPECT_EQ(e.loc().column, column) << e.what();
}

// TomlDocument Parsing

TEST(TomlDocument, SyntaxErrorHasLineAndColumn) {
    const ParseError e = parseErrorOf(
        [] { TomlDocument::fromString("[system]\nname = \"x\"\nt = 1.0 2.0\n", "bad.toml"); });
    EXPECT_EQ(e.loc().file, "bad.toml");
    expectAt(e, 3, 9);  // the stray "2.0"
}

TEST(TomlDocument, MultiLineInlineTableGetsAHint) {
    const ParseError e = parseErrorOf([] {
        TomlDocument::fromString("rows = [\n  { r = 1.0,\n    t = 2.0 },\n]\n", "rows.toml");
    });
    expectAt(e, 2, 13);  // the newline right after "r = 1.0,"
    EXPECT_THAT(e.message(), HasSubstr("must be written on one line"));
}

TEST(TomlDocument, DuplicateKeyIsASyntaxError) {
    const ParseError e =
        parseErrorOf([] { TomlDocument::fromString("a = 1\na = 2\n", "dup.toml"); });
    expectAt(e, 2, 5);
}

// A dotted key of 30000 parts (an 80 KB file) once overflowed the stack inside the TOML
// library; keys are bounded before parsing, strings and comments not counted.
std::string dottedKey(int parts) {
    std::string key = "k";
    for (int i = 1; i < parts; ++i) key += ".k";
    return key;
}

TEST(TomlDocument, DottedKeysAreBounded) {
    const ParseError e = parseErrorOf([] {
        TomlDocument::fromString("# a comment.\n" + dottedKey(30000) + " = 1\n", "deep.toml");
    });
    EXPECT_EQ(e.loc().file, "deep.toml");
    expectAt(e, 2, 2 * kMaxDottedKeyParts);  // the dot that starts part 129
    EXPECT_THAT(e.message(), HasSubstr("more than 128 parts"));
    EXPECT_NO_THROW(TomlDocument::fromString(dottedKey(kMaxDottedKeyParts) + " = 1\n", "ok.toml"));
    EXPECT_THAT(parseErrorOf([] {
                    std::string table = "[";  // appended: GCC 12 warns falsely on "[" + ...
                    table += dottedKey(kMaxDottedKeyParts + 1);
                    table += "]\n";
                    TomlDocument::fromString(table, "t.toml");
                }).message(),
                HasSubstr("more than 128 parts"));
    // Dots in strings, multi-line strings and comments are not key parts; values' dots reset.
    const std::string dots(400, '.');
    EXPECT_NO_THROW(
        TomlDocument::fromString("a = \"" + dots + "\"\nb = '" + dots + "'\nc = \"\"\"\n" + dots +
                                     "\n" + dots + "\"\"\"\nd = \'\'\'" + dots + "\'\'\'\n# " +
                                     dots + "\ne = [" + std::string(100, '1') + ".5, 1.5, 2.5]\n",
                                 "strings.toml"));
}

TEST(TomlDocument, MissingFileNamesTheFile) {
    const ParseError e = parseErrorOf([] { TomlDocument::fromFile("/nonexistent/dir/lens.toml"); });
    EXPECT_EQ(e.loc().file, "/nonexistent/dir/lens.toml");
    EXPECT_EQ(e.loc().line, 0);
    EXPECT_THAT(e.message(), HasSubstr("cannot open"));
}

TEST(TomlDocument, ReadsAFile) {
    const std::filesystem::path path =
        std::filesystem::path(VEIL_SOURCE_DIR) / "tests/data/toml/cooke_triplet.toml";
    TomlDocument doc = TomlDocument::fromFile(path);
    EXPECT_EQ(doc.fileName(), path.string());
    const TomlTable system = doc.root().require("system").asTable();
    EXPECT_EQ(system.string("name"), "Cooke triplet f/5");
    EXPECT_EQ(system.loc().file, path.string());
}

// Typed Getters

TEST(TomlDocument, NumbersAcceptIntegersAndFloats) {
    TomlDocument doc = TomlDocument::fromString("a = 3\nb = 2.5\nc = inf\nd = -0.0\n");
    const TomlTable root = doc.root();
    EXPECT_EQ(root.number("a", 0.0), 3.0);
    EXPECT_EQ(root.number("b", 0.0), 2.5);
    EXPECT_EQ(root.number("c", 0.0, NumberRange::any().orInfinite()), INFINITY);
    EXPECT_TRUE(std::signbit(root.number("d", 1.0)));
    EXPECT_EQ(root.number("absent", 7.0), 7.0);
}

TEST(TomlDocument, WrongTypeIsReportedAtTheValue) {
    TomlDocument doc = TomlDocument::fromString("[lens]\nsd = \"12\"\n", "lens.toml");
    const TomlTable lens = doc.root().require("lens").asTable();
    const ParseError e = parseErrorOf([&] { lens.number("sd", 0.0); });
    expectAt(e, 2, 6);
    EXPECT_EQ(e.message(), "lens.sd must be a number, not a string");
    EXPECT_EQ(std::string(e.what()), "lens.toml:2:6: lens.sd must be a number, not a string");
}

TEST(TomlDocument, IntegerRejectsFloat) {
    TomlDocument doc = TomlDocument::fromString("n = 2.0\n");
    const ParseError e = parseErrorOf([&] { doc.root().require("n").asInteger(); });
    expectAt(e, 1, 5);
    EXPECT_EQ(e.message(), "n must be an integer, not a floating-point number");
}

TEST(TomlDocument, OutOfRangeIsReportedAtTheValue) {
    TomlDocument doc = TomlDocument::fromString("[s]\nsd = -1.5\nf = 0\nang = 90\nk = 4\n");
    const TomlTable s = doc.root().require("s").asTable();
    ParseError e = parseErrorOf([&] { s.number("sd", 0.0, NumberRange::atLeast(0.0)); });
    expectAt(e, 2, 6);
    EXPECT_EQ(e.message(), "s.sd must be >= 0 (got -1.5)");
    e = parseErrorOf([&] { s.number("f", 1.0, NumberRange::above(0.0)); });
    EXPECT_EQ(e.message(), "s.f must be > 0 (got 0)");
    e = parseErrorOf([&] { s.number("ang", 0.0, NumberRange::strictlyBetween(-90, 90)); });
    EXPECT_EQ(e.message(), "s.ang must be strictly between -90 and 90 (got 90)");
    e = parseErrorOf([&] { s.require("k").asInteger(NumberRange::between(1, 3)); });
    EXPECT_EQ(e.message(), "s.k must be between 1 and 3 (got 4)");
    expectAt(e, 5, 5);
}

TEST(TomlDocument, InfinityAndNanNeedPermission) {
    TomlDocument doc = TomlDocument::fromString("a = inf\nb = nan\nc = -inf\n");
    const TomlTable root = doc.root();
    EXPECT_EQ(parseErrorOf([&] { root.number("a", 0.0); }).message(), "a must be finite (got inf)");
    EXPECT_THAT(
        parseErrorOf([&] { root.number("b", 0.0, NumberRange::any().orInfinite()); }).message(),
        HasSubstr("is nan"));
    // -inf lies outside [0, inf] even when infinity is allowed.
    EXPECT_EQ(parseErrorOf([&] {
                  root.number("c", 0.0, NumberRange::atLeast(0.0).orInfinite());
              }).message(),
              "c must be >= 0 (got -inf)");
}

TEST(TomlDocument, StringsBoolsTablesArrays) {
    TomlDocument doc = TomlDocument::fromString(
        "name = \"L1\"\nflag = true\nt = { x = 1 }\nlist = [1, [2, 3], { y = 4 }]\n");
    const TomlTable root = doc.root();
    EXPECT_EQ(root.string("name"), "L1");
    EXPECT_EQ(root.string("absent", "dflt"), "dflt");
    EXPECT_TRUE(root.boolean("flag", false));
    EXPECT_EQ(root.require("t").asTable().number("x", 0.0), 1.0);
    const std::vector<TomlValue> list = root.require("list").asArray();
    ASSERT_EQ(list.size(), 3u);
    EXPECT_EQ(list[0].path(), "list[1]");
    EXPECT_EQ(list[1].asArray()[1].path(), "list[2][2]");
    EXPECT_EQ(list[1].asArray()[1].asNumber(), 3.0);
    EXPECT_EQ(list[2].asTable().path(), "list[3]");
    EXPECT_EQ(list[2].asTable().number("y", 0.0), 4.0);
    const ParseError e = parseErrorOf([&] { root.boolean("name", false); });
    EXPECT_EQ(e.message(), "name must be true or false, not a string");
}

TEST(TomlDocument, RequireNamesTheTableAndTheHint) {
    TomlDocument doc = TomlDocument::fromString("a = 1\n\n[system]\nname = \"x\"\n", "f.toml");
    const TomlTable system = doc.root().require("system").asTable();
    const ParseError e = parseErrorOf([&] { system.require("aperture", "f_number or epd_mm"); });
    expectAt(e, 3, 1);
    EXPECT_EQ(e.message(), "missing key 'aperture' (f_number or epd_mm) in [system]");
}

TEST(TomlDocument, ViewsSurviveMovingTheDocument) {
    TomlDocument doc = TomlDocument::fromString("[s]\nx = 1\ny = 2\n");
    const TomlTable s = doc.root().require("s").asTable();
    EXPECT_EQ(s.number("x", 0.0), 1.0);
    TomlDocument moved = std::move(doc);
    EXPECT_EQ(s.number("y", 0.0), 2.0);
    EXPECT_NO_THROW(moved.checkAllUsed());
}

// Unused Keys

TEST(TomlDocument, AllKeysUsedPasses) {
    TomlDocument doc =
        TomlDocument::fromString("top = 1\n[sys]\nrows = [{ a = 1 }, { a = 2, b = { c = 3 } }]\n");
    const TomlTable root = doc.root();
    root.number("top", 0.0);
    const TomlTable sys = root.require("sys").asTable();
    for (const TomlValue& row : sys.require("rows").asArray()) {
        const TomlTable t = row.asTable();
        t.number("a", 0.0);
        if (auto b = t.get("b")) b->asTable().number("c", 0.0);
    }
    EXPECT_NO_THROW(doc.checkAllUsed());
}

TEST(TomlDocument, UnknownKeyInTableWithSuggestion) {
    TomlDocument doc =
        TomlDocument::fromString("[system]\nname = \"x\"\nwavelength_nm = [550.0]\n", "lens.toml");
    const TomlTable system = doc.root().require("system").asTable();
    system.string("name");
    system.get("wavelengths_nm");  // asked for but absent: a known key
    const ParseError e = parseErrorOf([&] { doc.checkAllUsed(); });
    expectAt(e, 3, 1);
    EXPECT_EQ(e.message(),
              "unknown key 'wavelength_nm' in [system] (did you mean 'wavelengths_nm'?)");
}

TEST(TomlDocument, UnknownKeyAtTopLevel) {
    TomlDocument doc = TomlDocument::fromString("title = \"x\"\n  colour = 3\n[system]\n");
    doc.root().string("title");
    doc.root().get("system");
    const ParseError e = parseErrorOf([&] { doc.checkAllUsed(); });
    expectAt(e, 2, 3);
    EXPECT_EQ(e.message(), "unknown key 'colour' at the top level");
}

TEST(TomlDocument, UnknownTablesAndArraysOfTables) {
    TomlDocument doc = TomlDocument::fromString("[system]\n[mechanics]\nx = 1\n");
    doc.root().get("system");
    ParseError e = parseErrorOf([&] { doc.checkAllUsed(); });
    expectAt(e, 2, 2);
    EXPECT_EQ(e.message(), "unknown table [mechanics]");

    TomlDocument doc2 = TomlDocument::fromString("[system]\n\n[[source]]\nname = \"sun\"\n");
    doc2.root().get("system");
    e = parseErrorOf([&] { doc2.checkAllUsed(); });
    expectAt(e, 3, 3);
    EXPECT_EQ(e.message(), "unknown table [[source]]");
}

TEST(TomlDocument, UnknownKeyInsideAnArrayEntry) {
    TomlDocument doc = TomlDocument::fromString(
        "[system]\nsurfaces = [\n  { r = 1, t = 2 },\n  { r = 3, t = 4,  sdd = 5 },\n]\n",
        "lens.toml");
    const TomlTable system = doc.root().require("system").asTable();
    for (const TomlValue& row : system.require("surfaces").asArray()) {
        const TomlTable t = row.asTable();
        t.number("r", 0.0);
        t.number("t", 0.0);
        t.number("sd", 0.0);
    }
    const ParseError e = parseErrorOf([&] { doc.checkAllUsed(); });
    expectAt(e, 4, 20);
    EXPECT_EQ(e.message(), "unknown key 'sdd' in system.surfaces[2] (did you mean 'sd'?)");
}

TEST(TomlDocument, HasDoesNotMarkUsed) {
    TomlDocument doc = TomlDocument::fromString("x = 1\n");
    EXPECT_TRUE(doc.root().has("x"));
    EXPECT_FALSE(doc.root().has("width"));
    EXPECT_EQ(parseErrorOf([&] { doc.checkAllUsed(); }).message(),
              "unknown key 'x' at the top level");
}

TEST(TomlDocument, KeysOfAnUnopenedTableAreUnknown) {
    // The reader took the value of 'glass' but never read inside it.
    TomlDocument doc = TomlDocument::fromString("glass = { nd = 1.5, vd = 60 }\n");
    doc.root().get("glass");
    const ParseError e = parseErrorOf([&] { doc.checkAllUsed(); });
    expectAt(e, 1, 11);
    EXPECT_EQ(e.message(), "unknown key 'nd' in [glass]");
}

TEST(TomlDocument, FirstUnusedKeyInFileOrderIsReported) {
    // toml++ keeps keys sorted by name; the report must follow the file, not the map.
    TomlDocument doc = TomlDocument::fromString("zeta = 1\nalpha = 2\n[b]\naa = 1\n");
    const ParseError e = parseErrorOf([&] { doc.checkAllUsed(); });
    expectAt(e, 1, 1);
    EXPECT_THAT(e.message(), HasSubstr("'zeta'"));
}

TEST(TomlDocument, NoSuggestionForDistantSpelling) {
    TomlDocument doc = TomlDocument::fromString("radius = 1\n");
    doc.root().get("r");
    doc.root().get("t");
    EXPECT_EQ(parseErrorOf([&] { doc.checkAllUsed(); }).message(),
              "unknown key 'radius' at the top level");
}

// Spelling Suggestions

TEST(ClosestSpelling, PicksTheNearestPlausibleKey) {
    const std::vector<std::string> keys = {"sd", "mech_sd", "conic", "fields_deg", "t"};
    EXPECT_EQ(closestSpelling("sdd", keys), "sd");
    EXPECT_EQ(closestSpelling("cnoic", keys), "conic");  // a transposition is one edit
    EXPECT_EQ(closestSpelling("CONIC", keys), "conic");
    EXPECT_EQ(closestSpelling("mech_sdd", keys), "mech_sd");
    EXPECT_EQ(closestSpelling("fields", keys), "fields_deg");  // prefix of 3 or more
    EXPECT_EQ(closestSpelling("x", keys), "t");                // 1 edit is close for short words
    EXPECT_EQ(closestSpelling("abc", keys), "");
    EXPECT_EQ(closestSpelling("radius", keys), "");
    EXPECT_EQ(closestSpelling("sd", keys), "");  // not a suggestion for itself
}

TEST(NumberRange, DescribesItself) {
    EXPECT_EQ(NumberRange::atLeast(0).describe(), ">= 0");
    EXPECT_EQ(NumberRange::above(0.5).describe(), "> 0.5");
    EXPECT_EQ(NumberRange::between(1, 3).describe(), "between 1 and 3");
    EXPECT_EQ(NumberRange::strictlyBetween(-90, 90).describe(), "strictly between -90 and 90");
    EXPECT_EQ((NumberRange{0, 1, false, true}).describe(), "in [0, 1)");
    EXPECT_EQ(NumberRange::any().describe(), "a finite number");
    EXPECT_TRUE(NumberRange::atLeast(0).orInfinite().contains(INFINITY));
    EXPECT_FALSE(NumberRange::atLeast(0).contains(INFINITY));
    EXPECT_FALSE(NumberRange::any().orInfinite().contains(NAN));
}

// What-if Edits (TomlDocument::set)

constexpr const char* kEditable = R"(
[system]
surfaces = [
  { r = 50.0, t = 5, glass = "N-BK7", coating = "ar" },
  { r = -50.0, t = 40.0 },
]

[[source]]
name = "sun"
field_deg = [0.0, 7.0]

[[source]]
name = "lamp"
flux_w = 2

[properties.black]
reflectance = 0.05
on = true
)";

TEST(TomlDocument, SetReplacesValuesByPathKeepingTheirType) {
    TomlDocument doc = TomlDocument::fromString(kEditable, "scene.toml");
    doc.set("properties.black.reflectance", "0.3", "--vary a");
    doc.set("system.surfaces[1].coating", "none", "--vary b");
    doc.set("system.surfaces.2.t", "38", "--vary c");      // a number stays a number
    doc.set("system.surfaces.1.t", "4.5", "--vary d");     // an integer given a fraction
    doc.set("source.sun.field_deg[2]", "15", "--vary e");  // an entry by its name
    doc.set("source.lamp.flux_w", "3", "--vary f");        // an integer stays one
    doc.set("properties.black.on", "false", "--vary g");
    doc.set("properties.black.transmittance", "0.1", "--vary h");  // a new key
    const TomlTable root = doc.root();
    const TomlTable black = root.require("properties").asTable().require("black").asTable();
    EXPECT_EQ(black.number("reflectance", 0.0), 0.3);
    EXPECT_FALSE(black.boolean("on", true));
    EXPECT_EQ(black.number("transmittance", 0.0), 0.1);
    const auto surfaces = root.require("system").asTable().require("surfaces").asArray();
    EXPECT_EQ(surfaces[0].asTable().string("coating"), "none");
    EXPECT_FALSE(surfaces[0].asTable().require("t").isInteger());
    EXPECT_EQ(surfaces[0].asTable().number("t", 0.0), 4.5);
    EXPECT_EQ(surfaces[1].asTable().number("t", 0.0), 38.0);
    const auto sources = root.require("source").asArray();
    EXPECT_EQ(sources[0].asTable().require("field_deg").asArray()[1].asNumber(), 15.0);
    EXPECT_TRUE(sources[1].asTable().require("flux_w").isInteger());
    // A message about an edited value names the edit, not a line of the file.
    const ParseError e = parseErrorOf(
        [&] { black.require("reflectance").asNumber(NumberRange::between(0.0, 0.2)); });
    EXPECT_EQ(e.loc().file, "--vary a");
    EXPECT_EQ(e.loc().line, 0);
    EXPECT_THAT(e.what(), HasSubstr("--vary a: properties.black.reflectance must be"));
}

// A string given in TOML quotes, as a TOML user writes it, is the text inside them.
TEST(TomlDocument, SetTakesQuotedStringsAsTheirText) {
    TomlDocument doc = TomlDocument::fromString(kEditable, "scene.toml");
    doc.set("system.surfaces[1].coating", "\"ideal_ar\"", "--set a");
    doc.set("system.surfaces[2].coating", "'mgf2'", "--set b");
    doc.set("properties.black.note", "\"say \\\"hi\\\"\"", "--set c");  // a new key
    doc.set("properties.black.label", "\"", "--set d");                 // one quote is no quoting
    const TomlTable root = doc.root();
    const auto surfaces = root.require("system").asTable().require("surfaces").asArray();
    EXPECT_EQ(surfaces[0].asTable().string("coating"), "ideal_ar");
    EXPECT_EQ(surfaces[1].asTable().string("coating"), "mgf2");
    const TomlTable black = root.require("properties").asTable().require("black").asTable();
    EXPECT_EQ(black.string("note"), "say \"hi\"");
    EXPECT_EQ(black.string("label"), "\"");
}

TEST(TomlDocument, SetRejectsPathsThatNameNothingAndValuesThatDoNotFit) {
    TomlDocument doc = TomlDocument::fromString(kEditable, "scene.toml");
    auto error = [&](const char* key, const char* value) {
        return std::string(parseErrorOf([&] { doc.set(key, value, "--vary X"); }).what());
    };
    EXPECT_THAT(error("propertes.black.reflectance", "0.1"),
                HasSubstr("--vary X: no 'propertes' in the top level of scene.toml (did you "
                          "mean 'properties'?)"));
    EXPECT_THAT(error("system.surfaces[3].t", "1"),
                HasSubstr("system.surfaces has 2 entries, counted from 1; there is no entry 3"));
    EXPECT_THAT(error("system.surfaces.0.t", "1"), HasSubstr("there is no entry 0"));
    EXPECT_THAT(error("source.moon.flux_w", "1"),
                HasSubstr("no entry named 'moon' in source (named: sun, lamp)"));
    EXPECT_THAT(error("system.surfaces[1].t", "thick"),
                HasSubstr("system.surfaces[1].t is a number in the file; 'thick' is not one"));
    EXPECT_THAT(error("properties.black.on", "1"), HasSubstr("is true or false in the file"));
    EXPECT_THAT(error("source.sun.field_deg", "3"),
                HasSubstr("source[1].field_deg is an array; name one of its values"));
    EXPECT_THAT(error("properties.black.reflectance.x", "3"),
                HasSubstr("is a floating-point number, not a table"));
    EXPECT_THAT(error("", "3"), HasSubstr("an empty key"));
}

TEST(TomlDocument, AnEditedKeyNobodyReadsIsReportedAtTheEdit) {
    TomlDocument doc = TomlDocument::fromString("[a]\nx = 1\n", "f.toml");
    doc.set("a.y", "2", "--vary a.y=2");
    doc.root().require("a").asTable().number("x", 0.0);
    const ParseError e = parseErrorOf([&] { doc.checkAllUsed(); });
    EXPECT_EQ(e.loc().file, "--vary a.y=2");
    EXPECT_THAT(e.what(), HasSubstr("unknown key 'y' in [a]"));
}

}  // namespace
}  // namespace veil
