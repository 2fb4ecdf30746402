// The [properties.*] and [[assign]] reader: every key, the errors at their file positions,
// globs, and how resolve() chooses each object's property.

#include "tracer/surfaces/property_table.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "geometry/scene.h"
#include "lensdata/toml_document.h"

namespace veil {
namespace {

using ::testing::HasSubstr;

template <class E, class F>
E errorOf(F&& body) {
    try {
        body();
    } catch (const E& e) {
        return e;
    }
    ADD_FAILURE() << "expected an exception";
    return E({}, "none");
}

// 1-based line and column of the first occurrence of `marker` in `text`.
std::pair<int, int> positionOf(const std::string& text, const std::string& marker) {
    const size_t at = text.find(marker);
    EXPECT_NE(at, std::string::npos) << marker;
    int line = 1, col = 1;
    for (size_t i = 0; i < at; ++i) {
        if (text[i] == '\n') {
            ++line;
            col = 1;
        } else {
            ++col;
        }
    }
    return {line, col};
}

// Reads `text` and expects a ParseError at `marker` whose message contains `message`.
void expectErrorAt(const std::string& text, const std::string& marker, const std::string& message,
                   bool checkUnused = false) {
    const ParseError e = errorOf<ParseError>([&] {
        const TomlDocument doc = TomlDocument::fromString(text, "scene.toml");
        PropertyTable::read(doc);
        if (checkUnused) doc.checkAllUsed();
    });
    const auto [line, col] = positionOf(text, marker);
    EXPECT_EQ(e.loc().file, "scene.toml");
    EXPECT_EQ(e.loc().line, line) << e.what();
    EXPECT_EQ(e.loc().column, col) << e.what();
    EXPECT_THAT(e.message(), HasSubstr(message)) << text;
}

// Globs

TEST(GlobMatch, StarAndQuestionMarkOverTheWholeName) {
    EXPECT_TRUE(globMatch("L3.*", "L3.front"));
    EXPECT_TRUE(globMatch("L3.*", "L3.flat1"));
    EXPECT_FALSE(globMatch("L3.*", "L31.front"));
    EXPECT_FALSE(globMatch("L3.*", "L3"));
    EXPECT_TRUE(globMatch("L?.edge", "L4.edge"));
    EXPECT_FALSE(globMatch("L?.edge", "L10.edge"));
    EXPECT_TRUE(globMatch("*.edge", "stop.edge"));
    EXPECT_TRUE(globMatch("spacer*", "spacer3a"));
    EXPECT_FALSE(globMatch("stop", "stop.edge"));
    EXPECT_TRUE(globMatch("*", ""));
    EXPECT_TRUE(globMatch("a*b*c", "aXbYbZc"));
    EXPECT_FALSE(globMatch("a*b*c", "aXbY"));
    EXPECT_TRUE(globMatch("**x", "x"));
    EXPECT_FALSE(globMatch("", "x"));
}

// Built-Ins

TEST(PropertyTable, BuiltInsAndKindDefaults) {
    const PropertyTable t;
    for (const char* name :
         {"uncoated", "ideal_ar", "absorber", "mirror", "ground_glass", "lens_edge", "lens_flat"}) {
        EXPECT_GE(t.find(name), 0) << name;
        EXPECT_TRUE(PropertyTable::isBuiltInName(name));
    }
    EXPECT_EQ(t.find("black_anodized"), -1);
    EXPECT_TRUE(std::holds_alternative<FresnelSpecular>(t.property(t.find("uncoated")).specular()));
    EXPECT_EQ(std::get<MirrorSpecular>(t.property(t.find("mirror")).specular()).reflectance, 1.0);
    const auto& edge = std::get<LambertianScatter>(t.property(t.find("lens_edge")).scatter());
    EXPECT_EQ(edge.reflectance, 0.5);
    EXPECT_EQ(edge.transmittance, 0.5);

    EXPECT_EQ(PropertyTable::defaultName(ObjectKind::LensFace), "uncoated");
    EXPECT_EQ(PropertyTable::defaultName(ObjectKind::MirrorFace), "mirror");
    EXPECT_EQ(PropertyTable::defaultName(ObjectKind::LensEdge), "lens_edge");
    EXPECT_EQ(PropertyTable::defaultName(ObjectKind::LensFlat), "lens_flat");
    for (ObjectKind k :
         {ObjectKind::Stop, ObjectKind::Mechanics, ObjectKind::ImportedMesh, ObjectKind::Detector})
        EXPECT_EQ(PropertyTable::defaultName(k), "absorber") << k;
    EXPECT_EQ(PropertyTable::defaultName(ObjectKind::Dummy), "ideal_ar");
}

// Reading

const char* kEveryKey = R"(
[properties.black_anodized]
scatter = { model = "lambertian", reflectance = 0.05 }

[properties.ground]
scatter = { model = "lambertian", reflectance = 0.5, transmittance = 0.5 }

[properties.lens_1pct]
specular = { model = "fixed", reflectance = 0.01 }

[properties.lossy]
specular = { model = "fixed", reflectance = 0.02, transmittance = 0.9 }

[properties.bare]
specular = "fresnel"

[properties.bare2]
specular = { model = "uncoated" }

[properties.ar]
specular = "ideal_ar"

[properties.mgf2]
specular = { model = "quarter_wave", index = 1.38, design_nm = 587.6 }

[properties.mgf2_default]
specular = { model = "quarter_wave" }

[properties.alu]
specular = { model = "mirror", reflectance = 0.95 }
scatter = { model = "abg", brdf = { a = 0.001, b = 0.001, g = 2 } }

[properties.black]
specular = "absorber"

[properties.rough_lens]
specular = "fresnel"
scatter = { model = "abg", brdf = { a = 1e-4, b = 1e-3, g = 2 }, btdf = { a = 2e-4, b = 1e-3, g = 1.5 } }

[properties.polished]
scatter = { model = "harvey_shack", brdf = { b0 = 50, l = 0.01, s = -2.5 } }

[properties.roughness]
specular = "fresnel"
scatter = { model = "k_correlation", sigma_nm = 2, b_um = 10, c = 3, reflectance = 0.04, transmission = true }

[properties.psd]
specular = "mirror"
scatter = { model = "k_correlation", a = 5.5, b_um = 2, c = 1.5, reflectance = 0.9 }

[properties.dusty]
specular = "mirror"
scatter = { model = "harvey_shack", brdf = [{ b0 = 3.93, l = 0.00411, s = -2.35 }, { b0 = 0.00429, l = 0.0431513, s = -1.11 }] }

[properties.gauss]
scatter = { model = "gaussian", reflectance = 0.05, half_width_deg = 5 }

[properties.dust]
specular = "fresnel"
scatter = { model = "particulate", level = 300, min_um = 2, index = 1.53, k = 0.008 }

[properties.gauss_t]
specular = "none"
scatter = { model = "gaussian", reflectance = 0.1, transmittance = 0.2, half_width_deg = 12.5 }

[properties.plain_mirror]
specular = "mirror"
scatter = "none"

[properties.lens_edge]
scatter = { model = "lambertian", reflectance = 0.1 }

[[assign]]
objects = "L1.*"
property = "ar"

[[assign]]
objects = ["spacer*", "barrel"]
property = "black_anodized"
)";

TEST(PropertyTable, ReadsEveryKey) {
    const TomlDocument doc = TomlDocument::fromString(kEveryKey, "scene.toml");
    const PropertyTable t = PropertyTable::read(doc);
    EXPECT_NO_THROW(doc.checkAllUsed());
    auto get = [&](const char* name) -> const OpticalProperty& {
        const int i = t.find(name);
        EXPECT_GE(i, 0) << name;
        return t.property(std::max(i, 0));
    };

    const auto& dust = std::get<ParticulateScatter>(get("dust").scatter()).params();
    EXPECT_EQ(dust.level, 300.0);
    EXPECT_EQ(dust.minUm, 2.0);
    EXPECT_EQ(dust.index, 1.53);
    EXPECT_EQ(dust.k, 0.008);

    const auto& black = get("black_anodized");
    EXPECT_TRUE(std::holds_alternative<AbsorberSpecular>(black.specular()));  // default
    EXPECT_EQ(std::get<LambertianScatter>(black.scatter()).reflectance, 0.05);
    EXPECT_EQ(std::get<LambertianScatter>(black.scatter()).transmittance, 0.0);
    EXPECT_EQ(std::get<LambertianScatter>(get("ground").scatter()).transmittance, 0.5);

    const auto& fixed = std::get<FixedSpecular>(get("lens_1pct").specular());
    EXPECT_EQ(fixed.reflectance, 0.01);
    EXPECT_EQ(fixed.transmittance, 0.99);  // default 1 - reflectance
    EXPECT_EQ(std::get<FixedSpecular>(get("lossy").specular()).transmittance, 0.9);

    EXPECT_TRUE(std::holds_alternative<FresnelSpecular>(get("bare").specular()));
    EXPECT_TRUE(std::holds_alternative<FresnelSpecular>(get("bare2").specular()));
    EXPECT_FALSE(get("bare").hasScatter());
    EXPECT_TRUE(std::holds_alternative<IdealArSpecular>(get("ar").specular()));

    const auto& qw = std::get<QuarterWaveSpecular>(get("mgf2").specular());
    EXPECT_EQ(qw.index, 1.38);
    EXPECT_EQ(qw.designNm, 587.6);
    const auto& qwd = std::get<QuarterWaveSpecular>(get("mgf2_default").specular());
    EXPECT_EQ(qwd.index, 1.38);
    EXPECT_EQ(qwd.designNm, 550.0);

    EXPECT_EQ(std::get<MirrorSpecular>(get("alu").specular()).reflectance, 0.95);
    const auto& alu = std::get<AbgScatter>(get("alu").scatter());
    ASSERT_NE(alu.reflectLobe(), nullptr);
    EXPECT_EQ(alu.transmitLobe(), nullptr);
    EXPECT_EQ(alu.reflectLobe()->params().a, 0.001);
    EXPECT_EQ(alu.reflectLobe()->params().b, 0.001);
    EXPECT_EQ(alu.reflectLobe()->params().g, 2.0);
    const auto& rough = std::get<AbgScatter>(get("rough_lens").scatter());
    ASSERT_NE(rough.transmitLobe(), nullptr);
    EXPECT_EQ(rough.transmitLobe()->params().g, 1.5);

    // Harvey-Shack keys give the lobe b0 (1 + (r / l)^2)^(s / 2).
    const auto& polished = std::get<AbgScatter>(get("polished").scatter());
    ASSERT_NE(polished.reflectLobe(), nullptr);
    EXPECT_NEAR(polished.reflectLobe()->bsdf(0.0), 50.0, 1e-12);
    EXPECT_NEAR(polished.reflectLobe()->bsdf(0.01), 50.0 * std::pow(2.0, -1.25), 1e-10);
    // K-correlation from the roughness: A = sigma^2 B^2 (C - 2) / (2 pi); or A itself.
    const auto& dusty = std::get<AbgScatter>(get("dusty").scatter());
    ASSERT_EQ(dusty.lobes(false).size(), 2u);
    EXPECT_NEAR(dusty.lobes(false)[1]->bsdf(0.0), 0.00429, 1e-12);
    const auto& kc = std::get<KCorrelationScatter>(get("roughness").scatter());
    EXPECT_NEAR(kc.params().aNm2Um2, 4.0 * 100.0 * 1.0 / (2.0 * std::numbers::pi), 1e-12);
    EXPECT_EQ(kc.params().reflectance, 0.04);
    EXPECT_TRUE(kc.transmits());
    const auto& psd = std::get<KCorrelationScatter>(get("psd").scatter());
    EXPECT_EQ(psd.params().aNm2Um2, 5.5);
    EXPECT_EQ(psd.params().c, 1.5);
    EXPECT_FALSE(psd.transmits());
    EXPECT_TRUE(std::holds_alternative<AbsorberSpecular>(get("black").specular()));
    const auto& g = std::get<GaussianScatter>(get("gauss").scatter());
    EXPECT_EQ(g.reflectance(), 0.05);
    EXPECT_EQ(g.halfWidthDeg(), 5.0);
    const auto& gt = std::get<GaussianScatter>(get("gauss_t").scatter());
    EXPECT_EQ(gt.transmittance(), 0.2);
    EXPECT_EQ(gt.halfWidthDeg(), 12.5);
    EXPECT_TRUE(std::holds_alternative<AbsorberSpecular>(get("gauss_t").specular()));
    EXPECT_EQ(std::get<MirrorSpecular>(get("plain_mirror").specular()).reflectance, 1.0);
    EXPECT_FALSE(get("plain_mirror").hasScatter());

    // A table replaces the built-in of its name, in place.
    EXPECT_EQ(std::get<LambertianScatter>(get("lens_edge").scatter()).reflectance, 0.1);
    EXPECT_EQ(t.properties().size(), PropertyTable().properties().size() + 20);

    ASSERT_EQ(t.rules().size(), 2u);
    EXPECT_EQ(t.rules()[0].patterns, std::vector<std::string>{"L1.*"});
    EXPECT_EQ(t.rules()[0].property, "ar");
    EXPECT_EQ(t.rules()[1].patterns, (std::vector<std::string>{"spacer*", "barrel"}));
    EXPECT_EQ(t.rules()[1].patternLocs[1].line, positionOf(kEveryKey, "\"barrel\"").first);
    EXPECT_EQ(t.rules()[1].patternLocs[1].column, positionOf(kEveryKey, "\"barrel\"").second);
}

TEST(PropertyTable, NoSectionsGiveTheBuiltIns) {
    const TomlDocument doc = TomlDocument::fromString("[system]\n", "lens.toml");
    const PropertyTable t = PropertyTable::read(doc);
    EXPECT_EQ(t.properties().size(), PropertyTable().properties().size());
    EXPECT_TRUE(t.rules().empty());
}

// Reading Errors

TEST(PropertyTable, SpecularErrorsAreAtTheValue) {
    std::string text = "[properties.x]\nspecular = \"fresnal\"\n";
    expectErrorAt(text, "\"fresnal\"", "did you mean 'fresnel'");
    text = "[properties.x]\nspecular = \"fixed\"\n";
    expectErrorAt(text, "\"fixed\"", "takes parameters");
    text = "[properties.x]\nspecular = { model = \"fixed\" }\n";
    expectErrorAt(text, "{", "missing key 'reflectance'");
    text = "[properties.x]\nspecular = { model = \"fixed\", reflectance = 1.5 }\n";
    expectErrorAt(text, "1.5", "between 0 and 1");
    text =
        "[properties.x]\nspecular = { model = \"fixed\", reflectance = 0.5, transmittance = 0.6 "
        "}\n";
    expectErrorAt(text, "0.6", "exceeds 1");
    text = "[properties.x]\nspecular = { model = \"quarter_wave\", index = 0 }\n";
    expectErrorAt(text, "0 }", "> 0");
    text = "[properties.x]\nspecular = { model = \"mirror\", reflectance = -0.1 }\n";
    expectErrorAt(text, "-0.1", "between 0 and 1");
    text = "[properties.x]\nspecular = { model = \"shiny\" }\n";
    expectErrorAt(text, "\"shiny\"", "unknown specular model 'shiny'");
    text = "[properties.x]\nspecular = 3\n";
    expectErrorAt(text, "3", "a model name or a table");
}

TEST(PropertyTable, ScatterErrorsAreAtTheValue) {
    std::string text = "[properties.x]\nscatter = { model = \"lambert\", reflectance = 0.1 }\n";
    expectErrorAt(text, "\"lambert\"", "did you mean 'lambertian'");
    text =
        "[properties.x]\nscatter = { model = \"lambertian\", reflectance = 0.7, transmittance = "
        "0.4 }\n";
    expectErrorAt(text, "{", "exceeds 1");
    text = "[properties.x]\nscatter = { model = \"gaussian\", reflectance = 0.05 }\n";
    expectErrorAt(text, "{", "missing key 'half_width_deg'");
    text =
        "[properties.x]\nscatter = { model = \"gaussian\", reflectance = 0.05, half_width_deg = 0 "
        "}\n";
    expectErrorAt(text, "0 }", "half_width_deg");
    text = "[properties.x]\nscatter = { model = \"abg\" }\n";
    expectErrorAt(text, "{", "needs `brdf` or `btdf`");
    text = "[properties.x]\nscatter = { model = \"abg\", brdf = { a = 0.01, g = 2 } }\n";
    expectErrorAt(text, "{ a", "missing key 'b'");
    text = "[properties.x]\nscatter = { model = \"abg\", brdf = { a = 0.01, b = 0, g = 2 } }\n";
    expectErrorAt(text, "0, g", "> 0");
    text = "[properties.x]\nscatter = { model = \"abg\", brdf = { a = 1.0, b = 1e-3, g = 2 } }\n";
    expectErrorAt(text, "{ model", "total integrated scatter");
    text =
        "[properties.x]\nscatter = { model = \"k_correlation\", a = 1, sigma_nm = 1, b_um = 1, c = "
        "3, reflectance = 1 }\n";
    expectErrorAt(text, "1, b_um", "not both");
    text =
        "[properties.x]\nscatter = { model = \"k_correlation\", sigma_nm = 1, b_um = 1, c = 2, "
        "reflectance = 1 }\n";
    expectErrorAt(text, "2, refl", "c > 2");
    text = "[properties.x]\nscatter = { model = \"k_correlation\", a = 1, b_um = 1, c = 3 }\n";
    expectErrorAt(text, "{ model", "missing key 'reflectance'");
    text =
        "[properties.x]\nscatter = { model = \"k_correlation\", a = 1, b_um = 1, c = 3, "
        "reflectance = 0 }\n";
    expectErrorAt(text, "0 }", "scatter nothing");
    text =
        "[properties.x]\nscatter = { model = \"k_correlation\", b_um = 1, c = 3, reflectance = 1 "
        "}\n";
    expectErrorAt(text, "{ model", "needs `a`");
    text = "[properties.x]\nscatter = { model = \"particulate\", index = 1.5 }\n";
    expectErrorAt(text, "{ model", "missing key 'level'");
    text = "[properties.x]\nscatter = { model = \"particulate\", level = 5000, index = 1.5 }\n";
    expectErrorAt(text, "5000", "past 1000");
    text =
        "[properties.x]\nscatter = { model = \"particulate\", level = 100, min_um = 100, index = "
        "1.5 }\n";
    expectErrorAt(text, "100, index", "below the level 100");
    text = "[properties.x]\nscatter = { model = \"particulate\", level = 100, index = 0 }\n";
    expectErrorAt(text, "0 }", "index");
    text =
        "[properties.x]\nscatter = { model = \"particulate\", level = 100, index = 1.5, k = -1 }\n";
    expectErrorAt(text, "-1 }", "k");
    text = "[properties.x]\nscatter = { model = \"harvey_shack\", brdf = [] }\n";
    expectErrorAt(text, "[] }", "at least one lobe");
    text = "[properties.x]\nscatter = \"lambertian\"\n";
    expectErrorAt(text, "\"lambertian\"", "must be a table");
    text = "[properties.x]\nscatter = { model = \"harvey_shack\", brdf = { b0 = 1, l = 0.01 } }\n";
    expectErrorAt(text, "{ b0", "missing key 's'");
    text =
        "[properties.x]\nscatter = { model = \"harvey_shack\", brdf = { b0 = 1, l = 0.01, s = 1 } "
        "}\n";
    expectErrorAt(text, "1 } }", "s");
}

TEST(PropertyTable, TableErrors) {
    std::string text = "[system]\nname = \"x\"\n\n[properties.empty]\n";
    const ParseError e = errorOf<ParseError>(
        [&] { PropertyTable::read(TomlDocument::fromString(text, "scene.toml")); });
    EXPECT_EQ(e.loc().line, 4) << e.what();
    EXPECT_THAT(e.message(), HasSubstr("needs `specular`, `scatter` or both"));
    text = "[properties]\nblack = 5\n";
    expectErrorAt(text, "5", "a table [properties.black]");
    // The first error in file order is reported, whatever the names' order.
    text = "[properties.b]\nspecular = \"bad1\"\n[properties.a]\nspecular = \"bad2\"\n";
    expectErrorAt(text, "\"bad1\"", "bad1");
    // Keys nobody reads are left for checkAllUsed, which suggests the right spelling.
    text = "[properties.x]\nscatter = { model = \"lambertian\", reflectence = 0.05 }\n";
    expectErrorAt(text, "reflectence", "did you mean 'reflectance'", true);
    text = "[properties.x]\nspecular = \"fresnel\"\nscater = { model = \"lambertian\" }\n";
    expectErrorAt(text, "scater", "did you mean 'scatter'", true);
}

TEST(PropertyTable, AssignErrors) {
    std::string text =
        "[properties.black]\nspecular = \"absorber\"\n\n[[assign]]\nobjects = \"L1.*\"\n"
        "property = \"blak\"\n";
    expectErrorAt(text, "\"blak\"", "did you mean 'black'");
    text = "[[assign]]\nobjects = 5\nproperty = \"absorber\"\n";
    expectErrorAt(text, "5", "a name glob or an array of globs");
    text = "[[assign]]\nobjects = []\nproperty = \"absorber\"\n";
    expectErrorAt(text, "[]", "at least one glob");
    text = "[[assign]]\nobjects = [\"L1.*\", \"\"]\nproperty = \"absorber\"\n";
    expectErrorAt(text, "\"\"", "must not be empty");
    text = "[[assign]]\nobjects = \"L1.*\"\n";
    const ParseError e = errorOf<ParseError>(
        [&] { PropertyTable::read(TomlDocument::fromString(text, "scene.toml")); });
    EXPECT_THAT(e.message(), HasSubstr("missing key 'property'"));
    EXPECT_EQ(e.loc().line, 1);
    text = "assign = { objects = \"x\", property = \"absorber\" }\n";
    expectErrorAt(text, "{", "array of tables [[assign]]");
}

// Resolving

Scene testScene() {
    Scene s;
    auto add = [&](const char* name, ObjectKind kind, const char* property,
                   std::vector<std::string> aliases = {}) {
        SceneObject o;
        o.name = name;
        o.kind = kind;
        o.property = property;
        o.aliases = std::move(aliases);
        s.addObject(std::move(o));
    };
    add("L1.front", ObjectKind::LensFace, "");
    add("L1.flat1", ObjectKind::LensFlat, "lens_flat");
    add("L1.edge", ObjectKind::LensEdge, "lens_edge");
    add("L1.back", ObjectKind::LensFace, "", {"L2.front"});
    add("L2.edge", ObjectKind::LensEdge, "lens_edge");
    add("L2.back", ObjectKind::LensFace, "mgf2");
    add("M1", ObjectKind::MirrorFace, "");
    add("stop", ObjectKind::Stop, "");
    add("stop.edge", ObjectKind::Stop, "");
    add("spacer1", ObjectKind::Mechanics, "");
    add("spacer2", ObjectKind::Mechanics, "black");
    add("barrel", ObjectKind::Mechanics, "");
    add("housing", ObjectKind::ImportedMesh, "");
    add("sensor", ObjectKind::Detector, "", {"image"});
    add("dummy", ObjectKind::Dummy, "");
    return s;
}

std::string nameOf(const PropertyTable& t, const std::vector<int>& of, const Scene& s,
                   const char* object) {
    return t.property(of[s.find(object)->id]).name();
}

const char* kProperties = R"([properties.mgf2]
specular = { model = "quarter_wave" }
[properties.black]
specular = "absorber"
[properties.ar]
specular = "ideal_ar"
)";

TEST(PropertyTable, ResolveUsesKindDefaultsWithoutRules) {
    const Scene s = testScene();
    const PropertyTable t = PropertyTable::read(TomlDocument::fromString(kProperties, "s.toml"));
    const std::vector<int> of = t.resolve(s);
    ASSERT_EQ(of.size(), s.objects().size());
    EXPECT_EQ(nameOf(t, of, s, "L1.front"), "uncoated");
    EXPECT_EQ(nameOf(t, of, s, "L1.flat1"), "lens_flat");
    EXPECT_EQ(nameOf(t, of, s, "L1.edge"), "lens_edge");
    EXPECT_EQ(nameOf(t, of, s, "L2.back"), "mgf2");
    EXPECT_EQ(nameOf(t, of, s, "M1"), "mirror");
    EXPECT_EQ(nameOf(t, of, s, "stop"), "absorber");
    EXPECT_EQ(nameOf(t, of, s, "spacer1"), "absorber");
    EXPECT_EQ(nameOf(t, of, s, "spacer2"), "black");
    EXPECT_EQ(nameOf(t, of, s, "housing"), "absorber");
    EXPECT_EQ(nameOf(t, of, s, "sensor"), "absorber");
    EXPECT_EQ(nameOf(t, of, s, "dummy"), "ideal_ar");
}

TEST(PropertyTable, RulesLaterWinsOwnPropertiesFirst) {
    const Scene s = testScene();
    const std::string text = std::string(kProperties) + R"(
[[assign]]
objects = "L?.*"
property = "ar"

[[assign]]
objects = ["L1.edge", "spacer?"]
property = "black"

[[assign]]
objects = "L2.front"
property = "mgf2"

[[assign]]
objects = "*.edge"
property = "ground_glass"
)";
    const PropertyTable t = PropertyTable::read(TomlDocument::fromString(text, "s.toml"));
    const std::vector<int> of = t.resolve(s);
    EXPECT_EQ(nameOf(t, of, s, "L1.front"), "ar");
    // A wildcard that does not spell "flat" leaves the flats to their default (and the butt
    // ends, unless it spells "edge": the last rule, *.edge, reaches them).
    EXPECT_EQ(nameOf(t, of, s, "L1.flat1"), "lens_flat");
    EXPECT_EQ(nameOf(t, of, s, "L1.edge"), "ground_glass");  // the last matching rule
    EXPECT_EQ(nameOf(t, of, s, "L2.edge"), "ground_glass");
    EXPECT_EQ(nameOf(t, of, s, "stop.edge"), "ground_glass");
    EXPECT_EQ(nameOf(t, of, s, "L1.back"), "mgf2");  // by its alias L2.front
    EXPECT_EQ(nameOf(t, of, s, "L2.back"), "mgf2");  // its own property beats the rules
    EXPECT_EQ(nameOf(t, of, s, "spacer1"), "black");
    EXPECT_EQ(nameOf(t, of, s, "spacer2"), "black");
    EXPECT_EQ(nameOf(t, of, s, "barrel"), "absorber");
    EXPECT_EQ(nameOf(t, of, s, "M1"), "mirror");
}

TEST(PropertyTable, RuleMatchingNothingIsAnErrorAtItsPattern) {
    const Scene s = testScene();
    const std::string text = std::string(kProperties) +
                             "[[assign]]\nobjects = [\"L1.*\", \"L9.*\"]\nproperty = \"ar\"\n";
    const PropertyTable t = PropertyTable::read(TomlDocument::fromString(text, "s.toml"));
    const ParseError e = errorOf<ParseError>([&] { t.resolve(s); });
    const auto [line, col] = positionOf(text, "\"L9.*\"");
    EXPECT_EQ(e.loc().file, "s.toml");
    EXPECT_EQ(e.loc().line, line);
    EXPECT_EQ(e.loc().column, col);
    EXPECT_THAT(e.message(), HasSubstr("'L9.*' matches no object"));
}

TEST(PropertyTable, UnknownPropertyNameIsAModelErrorNamingTheObject) {
    Scene s = testScene();
    SceneObject o;
    o.name = "spacer9";
    o.kind = ObjectKind::Mechanics;
    o.property = "black_anodised";
    s.addObject(o);
    PropertyTable t = PropertyTable::read(TomlDocument::fromString(kProperties, "s.toml"));
    t.define(OpticalProperty("black_anodized", AbsorberSpecular{}, LambertianScatter{0.05, 0.0}));
    const ModelError e = errorOf<ModelError>([&] { t.resolve(s); });
    EXPECT_EQ(e.object(), "spacer9");
    EXPECT_THAT(std::string(e.what()), HasSubstr("'black_anodised'"));
    EXPECT_THAT(std::string(e.what()), HasSubstr("did you mean 'black_anodized'"));
    // Rules added in code must name a defined property.
    EXPECT_THROW(t.addRule(AssignRule{{"*"}, {}, "nope", {}}), ModelError);
    t.addRule(AssignRule{{"spacer9"}, {}, "black_anodized", {}});
    EXPECT_EQ(t.rules().size(), 1u);
}

TEST(PropertyTable, PrintsItself) {
    std::ostringstream os;
    os << PropertyTable() << " " << AssignRule{{"L1.*", "L2.*"}, {}, "ar", {}};
    EXPECT_THAT(os.str(), HasSubstr("7 properties"));
    EXPECT_THAT(os.str(), HasSubstr("L1.* L2.* -> ar"));
}

}  // namespace
}  // namespace veil
