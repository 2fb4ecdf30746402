#include "tracer/surfaces/property_table.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "geometry/scene.h"
#include "lensdata/input_file.h"
#include "lensdata/toml_document.h"
#include "lensdata/zemax_bsdf.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

namespace {

constexpr std::array<std::string_view, 7> kBuiltInNames = {
    "uncoated", "ideal_ar", "absorber", "mirror", "ground_glass", "lens_edge", "lens_flat"};

OpticalProperty groundGlass(std::string name) {
    return OpticalProperty(std::move(name), AbsorberSpecular{}, LambertianScatter{0.5, 0.5});
}

std::string quoted(std::string_view s) { return "'" + std::string(s) + "'"; }

}  // namespace

bool isCementedFace(const SceneObject& o) {
    return o.kind == ObjectKind::LensFace && o.mediumFront != 0 && o.mediumBack != 0;
}

std::vector<std::string> namesAndAliases(const std::vector<SceneObject>& objects) {
    std::vector<std::string> names;
    for (const SceneObject& o : objects) {
        names.push_back(o.name);
        names.insert(names.end(), o.aliases.begin(), o.aliases.end());
    }
    return names;
}

bool coatingPatternReaches(std::string_view pattern, const SceneObject& o) {
    bool match = globMatch(pattern, o.name);
    for (const std::string& a : o.aliases) match = match || globMatch(pattern, a);
    if (!match) return false;
    if (pattern.find_first_of("*?") == std::string_view::npos) return true;
    if (o.kind == ObjectKind::LensEdge) return pattern.find("edge") != std::string_view::npos;
    if (o.kind == ObjectKind::LensFlat) return pattern.find("flat") != std::string_view::npos;
    return !isCementedFace(o);
}

namespace {

std::string didYouMean(std::string_view word, const std::vector<std::string>& candidates) {
    const std::string close = closestSpelling(word, candidates);
    return close.empty() ? std::string() : " (did you mean '" + close + "'?)";
}

std::string number(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

std::string joinNames(const std::vector<std::string>& names) {
    std::string s;
    for (size_t i = 0; i < names.size(); ++i) s += (i ? ", " : "") + names[i];
    return s;
}

// Specular Part

const std::vector<std::string> kSpecularModels = {"fresnel",      "uncoated", "ideal_ar", "fixed",
                                                  "quarter_wave", "mirror",   "absorber", "none"};
const std::vector<std::string> kScatterModels = {"lambertian",   "gaussian",      "abg",
                                                 "harvey_shack", "k_correlation", "tabulated",
                                                 "particulate",  "none"};

SpecularModel specularByName(const TomlValue& at, const std::string& model, bool inTable) {
    if (model == "fresnel" || model == "uncoated") return FresnelSpecular{};
    if (model == "ideal_ar") return IdealArSpecular{};
    if (model == "absorber" || model == "none") return AbsorberSpecular{};
    if (model == "mirror") return MirrorSpecular{1.0};
    if (!inTable && (model == "fixed" || model == "quarter_wave"))
        at.fail("specular model '" + model + "' takes parameters: write specular = { model = \"" +
                model + "\", ... }");
    const std::string hint = didYouMean(model, kSpecularModels);
    at.fail("unknown specular model '" + model + "'" +
            (hint.empty() ? " (expected one of " + joinNames(kSpecularModels) + ")" : hint));
}

SpecularModel readSpecular(const TomlValue& v) {
    if (v.isString()) return specularByName(v, v.asString(), false);
    if (!v.isTable()) v.failExpected("a model name or a table { model = \"...\", ... }");
    const TomlTable t = v.asTable();
    const TomlValue modelValue = t.require("model", "the specular model");
    const std::string model = modelValue.asString();
    const NumberRange unit = NumberRange::between(0.0, 1.0);
    if (model == "fixed") {
        const double r = t.require("reflectance", "specular reflectance, 0 to 1").asNumber(unit);
        const std::optional<TomlValue> tv = t.get("transmittance");
        const double tr = tv ? tv->asNumber(unit) : 1.0 - r;
        if (r + tr > 1.0)
            (tv ? *tv : modelValue)
                .fail(t.path() + ": reflectance + transmittance = " + number(r + tr) +
                      " exceeds 1");
        return FixedSpecular{r, tr};
    }
    if (model == "quarter_wave") {
        QuarterWaveSpecular q;
        q.index = t.number("index", q.index, NumberRange::above(0.0));
        q.designNm = t.number("design_nm", q.designNm, NumberRange::above(0.0));
        return q;
    }
    if (model == "mirror") return MirrorSpecular{t.number("reflectance", 1.0, unit)};
    return specularByName(modelValue, model, true);
}

// Scatter Part

AbgParams readAbgParams(const TomlValue& v) {
    if (!v.isTable()) v.failExpected("a table { a = ..., b = ..., g = ... } (or an array of them)");
    const TomlTable t = v.asTable();
    AbgParams p;
    p.a = t.require("a", "ABg A, 1/sr").asNumber(NumberRange::atLeast(0.0));
    p.b = t.require("b", "ABg B").asNumber(NumberRange::above(0.0));
    p.g = t.require("g", "ABg g").asNumber(NumberRange::atLeast(0.0));
    return p;
}

AbgParams readHarveyShackParams(const TomlValue& v) {
    if (!v.isTable())
        v.failExpected("a table { b0 = ..., l = ..., s = ... } (or an array of them)");
    const TomlTable t = v.asTable();
    const double b0 =
        t.require("b0", "BSDF at the specular direction, 1/sr").asNumber(NumberRange::atLeast(0.0));
    const double l =
        t.require("l", "shoulder, in direction cosines").asNumber(NumberRange::above(0.0));
    const double s =
        t.require("s", "slope beyond the shoulder, <= 0").asNumber(NumberRange::between(-1e3, 0.0));
    return harveyShack(b0, l, s);
}

// Dust at an IEST-STD-CC1246 level: the level, the smallest size counted and the particles'
// complex refractive index.
ParticulateScatter readParticulate(const TomlTable& t) {
    // Every key read before any is judged against the others, so that an error is about the
    // value, not a key left unread.
    ParticulateParams p;
    const TomlValue level = t.require("level", "IEST-STD-CC1246 cleanliness level, 1 to 1000");
    p.level = level.asNumber(NumberRange::atLeast(1.0));
    const std::optional<TomlValue> minUm = t.get("min_um");
    p.minUm = t.number("min_um", 1.0, NumberRange::atLeast(1.0));
    p.index = t.require("index", "the particles' refractive index, real part")
                  .asNumber(NumberRange::strictlyBetween(0.0, 10.0));
    p.k = t.number("k", 0.0, NumberRange{0.0, 10.0, false, true});
    if (p.level > 1000.0)
        level.fail(t.path() + ": level " + number(p.level) +
                   " is past 1000, where the particles cover more than 11 % of the surface: "
                   "the single-scatter dust model does not hold there");
    if (!(p.minUm < p.level)) {
        const std::string message = t.path() + ": the smallest particle counted (min_um " +
                                    number(p.minUm) + ") must be below the level " +
                                    number(p.level);
        if (minUm) minUm->fail(message);
        t.fail(message);
    }
    try {
        return ParticulateScatter(p);
    } catch (const std::invalid_argument& e) {
        t.fail(t.path() + ": " + e.what());
    }
}

// The PSD as A, B and C, or as the RMS roughness, B and C (A = sigma^2 B^2 (C - 2) / 2 pi).
KCorrelationScatter readKCorrelation(const TomlTable& t) {
    KCorrelationParams p;
    const std::optional<TomlValue> a = t.get("a"), sigma = t.get("sigma_nm");
    if (a && sigma)
        sigma->fail(t.path() +
                    ": give the PSD either by `a` or by its RMS roughness `sigma_nm`, "
                    "not both");
    if (!a && !sigma)
        t.fail(t.path() +
               ": K-correlation scatter needs `a` (nm^2 um^2) or `sigma_nm`, with "
               "`b_um` and `c`");
    p.bUm = t.require("b_um", "correlation length B, um").asNumber(NumberRange::above(0.0));
    const TomlValue cv = t.require("c", "PSD slope C");
    p.c = cv.asNumber(NumberRange{0.0, 1e3, true, false});
    if (a) {
        p.aNm2Um2 = a->asNumber(NumberRange::atLeast(0.0));
    } else {
        const double s = sigma->asNumber(NumberRange::atLeast(0.0));
        if (!(p.c > 2.0))
            cv.fail(t.path() +
                    ": the RMS roughness of a K-correlation PSD is finite only for "
                    "c > 2 (got " +
                    number(p.c) + "); give `a` for flatter spectra");
        p.aNm2Um2 = kCorrelationA(s, p.bUm, p.c);
    }
    const TomlValue r = t.require("reflectance", "the surface's reflectance Q, 0 to 1");
    p.reflectance = r.asNumber(NumberRange::between(0.0, 1.0));
    p.transmission = t.has("transmission") ? t.get("transmission")->asBool() : false;
    if (p.reflectance == 0.0 && !p.transmission)
        r.fail(t.path() + ": reflectance 0 and no transmission scatter nothing");
    return KCorrelationScatter(p);
}

// Tables from Zemax .bsdf files named relative to the file that names them.
TabulatedScatter readTabulated(const TomlTable& t) {
    const std::optional<TomlValue> brdf = t.get("brdf"), btdf = t.get("btdf");
    if (!brdf && !btdf)
        t.fail(t.path() + ": tabulated scatter needs `brdf` or `btdf` (a .bsdf file), or both");
    bool scale = false;
    if (const std::optional<TomlValue> tis = t.get("tis")) {
        const std::string mode = tis->asString();
        if (mode == "file") {
            scale = true;
        } else if (mode != "table") {
            tis->fail(
                "tis must be \"table\" (the table's own integral) or \"file\" (each "
                "block scaled to the TIS its file states), got '" +
                mode + "'");
        }
    }
    auto lobe = [&](const std::optional<TomlValue>& v,
                    bool transmission) -> std::shared_ptr<const TabulatedLobe> {
        if (!v) return nullptr;
        if (!v->isString()) v->failExpected("the path of a .bsdf file");
        const std::filesystem::path path =
            (std::filesystem::path(v->loc().file).parent_path() / v->asString()).lexically_normal();
        if (!inputFileExists(path)) v->fail("BSDF file '" + path.string() + "' does not exist");
        const ZemaxBsdf data = readZemaxBsdf(path);
        if (data.transmission != transmission)
            v->fail("'" + path.string() + "' holds a " + (data.transmission ? "BTDF" : "BRDF") +
                    " (its ScatterType), given here as the " + (transmission ? "btdf" : "brdf"));
        try {
            return std::make_shared<const TabulatedLobe>(data, scale);
        } catch (const ModelError& e) {
            v->fail(e.what());
        }
    };
    return TabulatedScatter(lobe(brdf, false), lobe(btdf, true));
}

ScatterModel readScatter(const TomlValue& v) {
    if (v.isString()) {
        if (v.asString() == "none") return NoScatter{};
        v.fail("scatter must be a table { model = \"...\", ... } or \"none\" (got '" +
               v.asString() + "')");
    }
    if (!v.isTable()) v.failExpected("a table { model = \"...\", ... }");
    const TomlTable t = v.asTable();
    const TomlValue modelValue = t.require("model", "the scatter model");
    const std::string model = modelValue.asString();
    const NumberRange unit = NumberRange::between(0.0, 1.0);
    auto checkSum = [&](double r, double tr) {
        if (r + tr > 1.0)
            t.fail(t.path() + ": reflectance + transmittance = " + number(r + tr) + " exceeds 1");
    };
    if (model == "lambertian") {
        const double r = t.number("reflectance", 0.0, unit);
        const double tr = t.number("transmittance", 0.0, unit);
        checkSum(r, tr);
        return LambertianScatter{r, tr};
    }
    if (model == "gaussian") {
        const double r = t.number("reflectance", 0.0, unit);
        const double tr = t.number("transmittance", 0.0, unit);
        checkSum(r, tr);
        const double w = t.require("half_width_deg", "half width at half maximum, degrees")
                             .asNumber(NumberRange{0.0, 90.0, true, false});
        return GaussianScatter(r, tr, w);
    }
    if (model == "abg" || model == "harvey_shack") {
        const bool hs = model == "harvey_shack";
        const std::optional<TomlValue> brdf = t.get("brdf"), btdf = t.get("btdf");
        if (!brdf && !btdf)
            t.fail(t.path() + ": " + (hs ? "Harvey-Shack" : "ABg") +
                   " scatter needs `brdf` or `btdf` (or both)");
        // A lobe's table, or an array of them (a fit of several terms: their sum).
        auto lobes = [&](const std::optional<TomlValue>& table) {
            std::vector<AbgParams> out;
            if (!table) return out;
            auto one = [&](const TomlValue& x) {
                return hs ? readHarveyShackParams(x) : readAbgParams(x);
            };
            if (table->isArray()) {
                const std::vector<TomlValue> list = table->asArray();
                if (list.empty()) table->fail(table->path() + " must list at least one lobe");
                for (const TomlValue& x : list) out.push_back(one(x));
            } else {
                out.push_back(one(*table));
            }
            return out;
        };
        const std::vector<AbgParams> r = lobes(brdf), tr = lobes(btdf);
        try {
            return AbgScatter(r, tr);
        } catch (const std::invalid_argument& e) {
            t.fail(t.path() + ": " + e.what());
        }
    }
    if (model == "k_correlation") return readKCorrelation(t);
    if (model == "tabulated") return readTabulated(t);
    if (model == "particulate") return readParticulate(t);
    if (model == "none") return NoScatter{};
    const std::string hint = didYouMean(model, kScatterModels);
    modelValue.fail("unknown scatter model '" + model + "'" +
                    (hint.empty() ? " (expected one of " + joinNames(kScatterModels) + ")" : hint));
}

OpticalProperty readProperty(const std::string& name, const TomlValue& v) {
    if (!v.isTable()) v.failExpected("a table [properties." + name + "]");
    const TomlTable t = v.asTable();
    const std::optional<TomlValue> specular = t.get("specular"), scatter = t.get("scatter");
    if (!specular && !scatter)
        t.fail("[properties." + name + "] needs `specular`, `scatter` or both");
    SpecularModel sm = specular ? readSpecular(*specular) : SpecularModel{AbsorberSpecular{}};
    ScatterModel sc = scatter ? readScatter(*scatter) : ScatterModel{NoScatter{}};
    try {
        return OpticalProperty(name, std::move(sm), std::move(sc));
    } catch (const ModelError& e) {
        t.fail(e.what());
    }
}

// Assign Rules

AssignRule readRule(const TomlValue& entry, const PropertyTable& table) {
    if (!entry.isTable()) entry.failExpected("a table [[assign]]");
    const TomlTable t = entry.asTable();
    AssignRule rule;
    rule.loc = t.loc();
    const TomlValue objects = t.require("objects", "object name glob or list of globs");
    auto addPattern = [&](const TomlValue& p) {
        if (!p.isString()) p.failExpected("a name glob (string)");
        const std::string s = p.asString();
        if (s.empty()) p.fail(p.path() + " must not be empty");
        rule.patterns.push_back(s);
        rule.patternLocs.push_back(p.loc());
    };
    if (objects.isArray()) {
        const std::vector<TomlValue> list = objects.asArray();
        if (list.empty()) objects.fail(objects.path() + " must list at least one glob");
        for (const TomlValue& p : list) addPattern(p);
    } else if (objects.isString()) {
        addPattern(objects);
    } else {
        objects.failExpected("a name glob or an array of globs");
    }
    const TomlValue property = t.require("property", "name of a [properties.*] table or built-in");
    rule.property = property.asString();
    if (table.find(rule.property) < 0) {
        std::vector<std::string> names;
        for (const OpticalProperty& p : table.properties()) names.push_back(p.name());
        property.fail("unknown optical property '" + rule.property + "'" +
                      didYouMean(rule.property, names));
    }
    return rule;
}

}  // namespace

// Globs

bool globMatch(std::string_view pattern, std::string_view text) {
    size_t p = 0, s = 0;
    size_t starP = std::string_view::npos, starS = 0;
    while (s < text.size()) {
        if (p < pattern.size() && (pattern[p] == '?' || pattern[p] == text[s])) {
            ++p;
            ++s;
        } else if (p < pattern.size() && pattern[p] == '*') {
            starP = p++;
            starS = s;
        } else if (starP != std::string_view::npos) {
            p = starP + 1;
            s = ++starS;
        } else {
            return false;
        }
    }
    while (p < pattern.size() && pattern[p] == '*') ++p;
    return p == pattern.size();
}

std::ostream& operator<<(std::ostream& os, const AssignRule& r) {
    os << "AssignRule{";
    for (size_t i = 0; i < r.patterns.size(); ++i) os << (i ? " " : "") << r.patterns[i];
    return os << " -> " << r.property << "}";
}

// Property Table

PropertyTable::PropertyTable() {
    properties_.push_back(OpticalProperty::uncoated("uncoated"));
    properties_.push_back(OpticalProperty::idealAr("ideal_ar"));
    properties_.push_back(OpticalProperty::absorber("absorber"));
    properties_.push_back(OpticalProperty::mirror(1.0, "mirror"));
    properties_.push_back(groundGlass("ground_glass"));
    properties_.push_back(groundGlass("lens_edge"));
    properties_.push_back(groundGlass("lens_flat"));
}

bool PropertyTable::isBuiltInName(std::string_view name) {
    return std::find(kBuiltInNames.begin(), kBuiltInNames.end(), name) != kBuiltInNames.end();
}

std::string_view PropertyTable::defaultName(ObjectKind kind) {
    switch (kind) {
        case ObjectKind::LensFace:
            return "uncoated";
        case ObjectKind::MirrorFace:
            return "mirror";
        case ObjectKind::LensEdge:
            return "lens_edge";
        case ObjectKind::LensFlat:
            return "lens_flat";
        case ObjectKind::Dummy:
            return "ideal_ar";
        case ObjectKind::Stop:
        case ObjectKind::Mechanics:
        case ObjectKind::ImportedMesh:
        case ObjectKind::Detector:
            return "absorber";
    }
    return "absorber";
}

std::vector<std::string> PropertyTable::uncoatedFaces(const Scene& scene) const {
    const std::vector<int> of = resolve(scene);
    std::vector<std::string> names;
    for (const SceneObject& o : scene.objects()) {
        if (o.kind != ObjectKind::LensFace || isCementedFace(o)) continue;
        const int p = of[static_cast<size_t>(o.id)];
        if (p >= 0 && std::holds_alternative<FresnelSpecular>(property(p).specular()))
            names.push_back(o.name);
    }
    return names;
}

int PropertyTable::define(OpticalProperty p) {
    const int i = find(p.name());
    if (i >= 0) {
        properties_[i] = std::move(p);
        return i;
    }
    properties_.push_back(std::move(p));
    return static_cast<int>(properties_.size()) - 1;
}

void PropertyTable::addRule(AssignRule rule) {
    if (find(rule.property) < 0)
        throw ModelError(rule.property, "[[assign]] names an undefined optical property");
    rules_.push_back(std::move(rule));
}

int PropertyTable::find(std::string_view name) const {
    for (size_t i = 0; i < properties_.size(); ++i)
        if (properties_[i].name() == name) return static_cast<int>(i);
    return -1;
}

namespace {

// The [properties.NAME] tables of a document, in file order (so the first error reported is
// the first in the file).
void readPropertyTables(const TomlTable& root, PropertyTable& table) {
    if (const std::optional<TomlValue> props = root.get("properties")) {
        if (!props->isTable()) props->failExpected("tables [properties.NAME]");
        const TomlTable t = props->asTable();
        // In file order, so the first error reported is the first in the file.
        std::vector<std::pair<toml::source_position, std::string>> keys;
        for (auto&& [key, node] : t.table())
            keys.emplace_back(node.source().begin, std::string(key.str()));
        std::sort(keys.begin(), keys.end(), [](const auto& a, const auto& b) {
            return a.first.line != b.first.line ? a.first.line < b.first.line
                                                : a.first.column < b.first.column;
        });
        for (const auto& [pos, name] : keys) table.define(readProperty(name, *t.get(name)));
    }
}

}  // namespace

PropertyTable PropertyTable::read(const TomlDocument& doc) {
    PropertyTable table;
    const TomlTable root = doc.root();
    // Material libraries first: files of [properties.NAME] tables (nothing else), named
    // relative to this file; the scene's own tables replace theirs of the same name.
    if (const std::optional<TomlValue> materials = root.get("materials")) {
        std::vector<TomlValue> files;
        if (materials->isArray()) {
            files = materials->asArray();
        } else if (materials->isString()) {
            files.push_back(*materials);
        } else {
            materials->failExpected("a material library file or an array of them");
        }
        for (const TomlValue& f : files) {
            if (!f.isString()) f.failExpected("the path of a material library (.toml)");
            const std::filesystem::path path =
                std::filesystem::path(f.loc().file).parent_path() / f.asString();
            if (!inputFileExists(path))
                f.fail("material library '" + path.string() + "' does not exist");
            const TomlDocument lib = TomlDocument::fromFile(path);
            const TomlTable libRoot = lib.root();
            if (!libRoot.has("properties"))
                f.fail("'" + path.string() + "' has no [properties.NAME] tables");
            readPropertyTables(libRoot, table);
            lib.checkAllUsed();
        }
    }
    readPropertyTables(root, table);
    if (const std::optional<TomlValue> assign = root.get("assign")) {
        if (!assign->isArray()) assign->failExpected("an array of tables [[assign]]");
        for (const TomlValue& entry : assign->asArray())
            table.rules_.push_back(readRule(entry, table));
    }
    return table;
}

std::vector<int> PropertyTable::resolve(const Scene& scene) const {
    const std::vector<SceneObject>& objects = scene.objects();
    auto matches = [](const std::string& pattern, const SceneObject& o) {
        if (globMatch(pattern, o.name)) return true;
        for (const std::string& a : o.aliases)
            if (globMatch(pattern, a)) return true;
        return false;
    };

    // A rule that matches nothing is a typo or a stale name: say so at the pattern.
    for (const AssignRule& r : rules_) {
        for (size_t k = 0; k < r.patterns.size(); ++k) {
            const bool any = std::any_of(objects.begin(), objects.end(), [&](const SceneObject& o) {
                return matches(r.patterns[k], o);
            });
            if (!any) {
                const FileLoc loc = k < r.patternLocs.size() ? r.patternLocs[k] : r.loc;
                throw ParseError(loc, "[[assign]] objects = '" + r.patterns[k] +
                                          "' matches no object in the scene" +
                                          didYouMean(r.patterns[k], namesAndAliases(objects)));
            }
        }
    }

    std::vector<int> out(objects.size(), -1);
    for (size_t id = 0; id < objects.size(); ++id) {
        const SceneObject& o = objects[id];
        std::string_view name = o.property;
        const bool placeholder = (o.kind == ObjectKind::LensEdge && name == "lens_edge") ||
                                 (o.kind == ObjectKind::LensFlat && name == "lens_flat");
        if (name.empty() || placeholder) {
            name = {};
            for (auto r = rules_.rbegin(); r != rules_.rend() && name.empty(); ++r)
                for (const std::string& p : r->patterns)
                    if (coatingPatternReaches(p, o)) {
                        name = r->property;
                        break;
                    }
            if (name.empty()) name = defaultName(o.kind);
        }
        const int index = find(name);
        if (index < 0) {
            std::vector<std::string> names;
            for (const OpticalProperty& p : properties_) names.push_back(p.name());
            throw ModelError(o.name, "object '" + o.name + "' has the unknown optical property " +
                                         quoted(name) + didYouMean(name, names) +
                                         " (define it in [properties." + std::string(name) + "])");
        }
        out[id] = index;
    }
    return out;
}

std::ostream& operator<<(std::ostream& os, const PropertyTable& t) {
    os << "PropertyTable{" << t.properties().size() << " properties";
    for (const OpticalProperty& p : t.properties()) os << ", " << p.name();
    os << "; " << t.rules().size() << " rules}";
    return os;
}

// Scatter Energy

void PropertyTable::checkScatterEnergy(const SequentialModel& model) const {
    for (const OpticalProperty& p : properties_) {
        const auto* k = std::get_if<KCorrelationScatter>(&p.scatter());
        if (!k) continue;
        for (int w = 0; w < model.wavelengthCount(); ++w) {
            double nMax = 1.0;
            for (int g = 0; g + 1 < model.surfaceCount(); ++g)
                nMax = std::max(nMax, std::abs(model.index(g, w)));
            const double nm = model.wavelengthNm(w);
            for (int deg = 0; deg < 90; ++deg) {
                const double cosI = std::cos(deg * std::numbers::pi / 180.0);
                double r = 0.0, t = 0.0, n1 = 1.0;
                for (double n : {1.0, nMax}) {
                    const double rn = k->tis(k->reflectLobe(nm, n, cosI));
                    if (rn > r) r = rn, n1 = n;
                }
                if (k->transmits()) {
                    const double sinT = std::sqrt(1.0 - cosI * cosI) / nMax;
                    t = k->tis(k->transmitLobe(nm, 1.0, nMax, cosI, std::sqrt(1.0 - sinT * sinT)));
                }
                if (r + t > 1.0)
                    throw ModelError(
                        p.name(),
                        "K-correlation scatter at " + number(nm) + " nm and " +
                            std::to_string(deg) + " deg incidence takes " + number(r + t) +
                            " of the light (reflected " + number(r) + " from n = " + number(n1) +
                            (k->transmits()
                                 ? ", transmitted " + number(t) + " into n = " + number(nMax)
                                 : std::string()) +
                            "): the surface is too rough for the smooth-surface (Rayleigh-Rice) "
                            "model at this wavelength");
            }
        }
    }
}

}  // namespace veil
