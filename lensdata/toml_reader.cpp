// The [system] table of a veil TOML file. User documentation: docs/format.md.
//
//   key                 type                         default       meaning
//   name, notes         string                       ""            title; data source
//   wavelengths_nm      [nm, ...] | [{nm, weight}]   [587.5618]    in air, nm
//   primary_wavelength  integer, 1-based             middle entry  reference wavelength
//   aperture            { f_number | epd_mm | object_na | float_by_stop = true }, required
//   fields_deg          [y, ...] | [[x, y], ...]     [0.0]         field angles, degrees
//   fields_mm           same                         -             object heights, mm
//   field_weights       [w, ...]                     all 1         one per field
//   rectangular_field   bool                         false
//   object_distance_mm  number | inf                 inf           object to surface 1, mm
//   glass_catalogs      [name, ...]                  []            searched first
//   surfaces            [{ row }, ...]               required      surfaces 1, 2, ...
//
//   row key             type                         default       meaning
//   r | c               number (r = 0 or inf: flat)  flat          radius mm | curvature 1/mm
//   t                   number                       required      to the next vertex, mm
//   glass               "N-BK7" | "AIR" | {nd, vd, dpgf}           air; mirror: incident medium
//   sd, mech_sd         number >= 0                  0 = not given clear, mechanical semi-dia.
//   hole_sd             number >= 0, < sd            0 = none      central hole / obscuration
//   conic               number                       0             conic constant k
//   asph                [A4, A6, ..., A20]           []            even asphere terms
//   asph_r2             number                       0             A2 (r^2 term)
//   asph_odd            [B3, B5, ..., B19]           []            odd asphere terms
//   stop, mirror        bool                         false
//   coating, name, comment  string                   ""
//   image               bool, last row only          false         the row is the image
//
// The reader builds the object surface from object_distance_mm, one surface per row, and the
// image surface (flat, after the last row's t, unless the last row is an image row).

#include "lensdata/toml_reader.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <sstream>

#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "lensdata/toml_document.h"

namespace veil {

namespace {

bool equalsIgnoringCase(std::string_view a, std::string_view b) {
    return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
               return std::tolower(static_cast<unsigned char>(x)) ==
                      std::tolower(static_cast<unsigned char>(y));
           });
}

// "'A', 'B' or 'C'"
std::string quotedList(const std::vector<std::string>& items, std::string_view lastJoin) {
    std::string out;
    for (size_t i = 0; i < items.size(); ++i) {
        if (i > 0) out += i + 1 == items.size() ? std::string(lastJoin) : std::string(", ");
        out += "'" + items[i] + "'";
    }
    return out;
}

std::string rowPath(int surfaceIndex) {
    return "system.surfaces[" + std::to_string(surfaceIndex) + "]";
}

// Among the values present, the one written last in the file (for "not both" errors).
const TomlValue& laterInFile(const TomlValue& a, const TomlValue& b);

// A curvature given as a radius (rKey: mm, 0 or inf = flat) or as a curvature (cKey: 1/mm);
// nullopt when neither key is there; both is an error at the later one.
std::optional<double> curvatureOf(const TomlTable& t, const char* rKey, const char* cKey) {
    const auto r = t.get(rKey);
    const auto c = t.get(cKey);
    if (r && c)
        laterInFile(*r, *c).fail(std::string("give the radius ") + rKey + " or the curvature " +
                                 cKey + ", not both");
    if (r) {
        const double radius = r->asNumber(NumberRange::any().orInfinite());
        return radius == 0.0 || std::isinf(radius) ? 0.0 : 1.0 / radius;
    }
    if (c) return c->asNumber();
    return std::nullopt;
}

const TomlValue& laterInFile(const TomlValue& a, const TomlValue& b) {
    const FileLoc la = a.loc(), lb = b.loc();
    return std::pair(la.line, la.column) > std::pair(lb.line, lb.column) ? a : b;
}

// Lens Reader Definition

class LensReader {
  public:
    explicit LensReader(const GlassCatalog& catalog) : catalog_(catalog) {}

    // Reads everything; names and validation come in finish().
    void read(TomlDocument& doc);
    Prescription finish();

  private:
    void readGlassCatalogs(const TomlTable& system);
    void readWavelengths(const TomlTable& system);
    void readObjectDistance(const TomlTable& system);
    void readSurfaces(const TomlTable& system);
    void readRow(const TomlTable& row, bool last, Material& incident);
    void readShape(const TomlTable& row, Surface& s);
    void readBreakRow(const TomlTable& row, const TomlValue& brk, Surface& s,
                      const Material& incident);
    Material readMaterial(const TomlValue& value) const;
    void readAperture(const TomlTable& system);
    void readFields(const TomlTable& system);

    const GlassCatalog& catalog_;
    Prescription p_;
    int stopIndex_ = -1;  // the row flagged stop so far
    bool sawImageRow_ = false;
    // Names given in the file, by surface index, so duplicates are reported at the name.
    std::vector<std::pair<int, TomlValue>> userNames_;
};

// Lens Reader Methods

void LensReader::read(TomlDocument& doc) {
    p_.sourceFile = doc.fileName();
    const TomlTable root = doc.root();
    const TomlValue systemValue = root.require(
        "system", "a lens file starts with [system]: wavelengths_nm, aperture, fields, surfaces");
    if (!systemValue.isTable()) systemValue.failExpected("a table [system]");
    const TomlTable system = systemValue.asTable();

    p_.system.name = system.string("name");
    p_.system.notes = system.string("notes");
    readGlassCatalogs(system);
    readWavelengths(system);
    readObjectDistance(system);
    readSurfaces(system);
    readAperture(system);  // after the surfaces: float_by_stop needs the stop
    readFields(system);
}

void LensReader::readGlassCatalogs(const TomlTable& system) {
    const auto value = system.get("glass_catalogs");
    if (!value) return;
    const std::vector<std::string> known = catalog_.catalogNames();
    for (const TomlValue& entry : value->asArray()) {
        const std::string name = entry.asString();
        const auto it = std::find_if(known.begin(), known.end(), [&](const std::string& k) {
            return equalsIgnoringCase(k, name);
        });
        if (it == known.end())
            entry.fail("unknown glass catalog '" + name +
                       "' (known: " + quotedList(known, " and ") + ")");
        p_.system.glassCatalogs.push_back(*it);  // the catalog's own spelling
    }
}

void LensReader::readWavelengths(const TomlTable& system) {
    std::vector<Wavelength>& wavelengths = p_.system.wavelengths;
    if (const auto value = system.get("wavelengths_nm")) {
        const std::vector<TomlValue> entries = value->asArray();
        if (entries.empty()) value->fail("wavelengths_nm needs at least one wavelength");
        for (const TomlValue& entry : entries) {
            Wavelength w;
            if (entry.isTable()) {
                const TomlTable t = entry.asTable();
                w.nm = t.require("nm", "wavelength in nm").asNumber(NumberRange::above(0.0));
                w.weight = t.number("weight", 1.0, NumberRange::atLeast(0.0));
            } else if (entry.isNumber()) {
                w.nm = entry.asNumber(NumberRange::above(0.0));
            } else {
                entry.failExpected("a wavelength in nm or a table { nm = 587.56, weight = 1 }");
            }
            // Not an error: EUV mirror systems work at 13.5 nm. But 0.5876 is far more
            // often a wavelength in micrometres.
            if (w.nm < 100.0) {
                std::ostringstream message;
                message << "wavelength " << w.nm
                        << " nm is below 100 nm; wavelengths_nm is in nm, not um";
                p_.report.push_back({ImportNote::Severity::Warning, entry.loc(), message.str()});
            }
            wavelengths.push_back(w);
        }
    } else {
        wavelengths.push_back({kLineD, 1.0});
    }
    const int n = static_cast<int>(wavelengths.size());
    if (const auto value = system.get("primary_wavelength"))
        p_.system.primaryWavelength =
            static_cast<int>(value->asInteger(NumberRange::between(1, n))) - 1;
    else
        p_.system.primaryWavelength = (n - 1) / 2;
}

void LensReader::readObjectDistance(const TomlTable& system) {
    Surface object;
    object.thicknessMm = kInfinity;
    object.origin = system.loc();
    if (const auto value = system.get("object_distance_mm")) {
        object.thicknessMm = value->asNumber(NumberRange::any().orInfinite());
        if (object.thicknessMm == -kInfinity)
            value->fail("object_distance_mm = -inf: write inf for an object at infinity");
        object.origin = value->loc();
    }
    p_.surfaces.push_back(object);
}

void LensReader::readSurfaces(const TomlTable& system) {
    const TomlValue rowsValue = system.require(
        "surfaces", "the lens rows: surfaces = [ { r = ..., t = ..., glass = ... }, ... ]");
    const std::vector<TomlValue> rows = rowsValue.asArray();
    Material incident = Material::air();  // object space
    for (size_t i = 0; i < rows.size(); ++i) {
        if (!rows[i].isTable())
            rows[i].failExpected("a surface row { r = ..., t = ..., glass = ..., sd = ... }");
        readRow(rows[i].asTable(), i + 1 == rows.size(), incident);
    }
    // Object plus at least one real surface; the image may be the last row or implicit.
    const size_t realSurfaces = p_.surfaces.size() - 1 - (sawImageRow_ ? 1 : 0);
    if (realSurfaces == 0)
        rowsValue.fail("surfaces needs at least one surface row before the image");
    if (!sawImageRow_) {
        Surface image;
        image.material = incident;
        image.origin = rows.back().loc();
        p_.surfaces.push_back(image);
    }
}

void LensReader::readRow(const TomlTable& row, bool last, Material& incident) {
    const int index = static_cast<int>(p_.surfaces.size());
    Surface s;
    s.origin = row.loc();

    bool image = false;
    if (const auto flag = row.get("image")) {
        image = flag->asBool();
        if (image && !last)
            flag->fail("only the last row can be the image row { image = true, ... }");
    }

    readShape(row, s);
    s.clearSemiDiameterMm = row.number("sd", 0.0, NumberRange::atLeast(0.0));
    s.mechSemiDiameterMm = row.number("mech_sd", 0.0, NumberRange::atLeast(0.0));
    if (const auto automatic = row.get("sd_auto")) {
        s.semiDiameterAutomatic = automatic->asBool();
        if (s.semiDiameterAutomatic && !(s.clearSemiDiameterMm > 0.0))
            automatic->fail(
                "sd_auto marks a given sd as computed by the program that wrote it; "
                "this row has no sd");
    }
    if (const auto hole = row.get("hole_sd")) {
        s.innerSemiDiameterMm = hole->asNumber(NumberRange::atLeast(0.0));
        // Reported at the value here; validate() would only name the surface.
        if (s.innerSemiDiameterMm > 0.0 && !(s.clearSemiDiameterMm > 0.0))
            hole->fail("hole_sd needs the clear semi-diameter sd of the annulus around the hole");
        if (s.innerSemiDiameterMm > 0.0 && s.innerSemiDiameterMm >= s.clearSemiDiameterMm) {
            std::ostringstream message;
            message << "hole_sd = " << s.innerSemiDiameterMm
                    << " mm must be smaller than the clear semi-diameter sd = "
                    << s.clearSemiDiameterMm << " mm";
            hole->fail(message.str());
        }
    }
    s.coating = row.string("coating");
    s.comment = row.string("comment");
    if (const auto name = row.get("name")) {
        s.name = name->asString();
        const bool valid = !s.name.empty() && std::all_of(s.name.begin(), s.name.end(), [](char c) {
            return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '-';
        });
        if (!valid)
            name->fail("surface name '" + s.name +
                       "' may hold letters, digits, '_', '.' and '-' only (names are typed in "
                       "path criteria)");
        userNames_.emplace_back(index, *name);
    }

    if (const auto brk = row.get("break")) {
        if (image) brk->fail("the image row cannot be a coordinate break");
        readBreakRow(row, *brk, s, incident);
        p_.surfaces.push_back(s);
        return;
    }
    if (image) {
        for (const char* key : {"t", "glass", "stop", "mirror"}) {
            if (const auto v = row.get(key))
                v->fail(std::string("the image row takes no '") + key +
                        "' (the previous row's t is the distance to the image)");
        }
        if (const auto v = row.get("hole_sd"))
            v->fail("the image row takes no 'hole_sd' (the image surface has no hole)");
        s.material = incident;
        sawImageRow_ = true;
        p_.surfaces.push_back(s);
        return;
    }

    s.thicknessMm =
        row.require("t", "thickness to the next surface in mm; t = 0 is allowed").asNumber();
    if (const auto flag = row.get("stop")) {
        s.stop = flag->asBool();
        if (s.stop && stopIndex_ >= 0)
            flag->fail("only one surface can be the stop; " + rowPath(stopIndex_) + " already is");
        if (s.stop) stopIndex_ = index;
    }
    s.mirror = row.boolean("mirror", false);
    const auto glass = row.get("glass");
    if (s.mirror) {
        // A mirror reflects back into the medium the light came from.
        s.material = incident;
        if (glass && !(readMaterial(*glass) == incident))
            glass->fail("a mirror keeps the medium: after the mirror " + rowPath(index) +
                        " the light travels back through the incident medium " + incident.label() +
                        "; leave 'glass' out of mirror rows (or repeat " + incident.label() + ")");
    } else {
        s.material = glass ? readMaterial(*glass) : Material::air();
    }
    incident = s.material;
    p_.surfaces.push_back(s);
}

void LensReader::readBreakRow(const TomlTable& row, const TomlValue& brk, Surface& s,
                              const Material& incident) {
    // { break = { decenter_mm = [x, y], tilt_deg = [x, y, z], tilt_first = false }, t = ... }
    for (const char* key :
         {"r", "c", "conic", "asph", "asph_r2", "asph_odd", "qbfs", "qcon", "toroidal", "biconic",
          "sd", "mech_sd", "sd_auto", "hole_sd", "stop", "mirror", "coating"})
        if (const auto v = row.get(key))
            v->fail(std::string("a coordinate break row takes no '") + key +
                    "': it is a flat dummy surface (only break, t, glass, name and comment)");
    if (!brk.isTable())
        brk.failExpected("a table { decenter_mm = [x, y], tilt_deg = [x, y, z], tilt_first = ... }");
    const TomlTable b = brk.asTable();
    CoordinateBreak cb;
    if (const auto d = b.get("decenter_mm")) {
        const std::vector<TomlValue> v = d->asArray();
        if (v.size() != 2) d->fail("decenter_mm = [x, y]: two numbers (mm)");
        cb.decenterXMm = v[0].asNumber();
        cb.decenterYMm = v[1].asNumber();
    }
    if (const auto t = b.get("tilt_deg")) {
        const std::vector<TomlValue> v = t->asArray();
        if (v.size() != 3) t->fail("tilt_deg = [x, y, z]: three angles (degrees)");
        cb.tiltXDeg = v[0].asNumber(NumberRange::between(-360.0, 360.0));
        cb.tiltYDeg = v[1].asNumber(NumberRange::between(-360.0, 360.0));
        cb.tiltZDeg = v[2].asNumber(NumberRange::between(-360.0, 360.0));
    }
    cb.tiltFirst = b.boolean("tilt_first", false);
    s.coordinateBreak = cb;
    s.thicknessMm =
        row.require("t", "distance along the new z axis to the next surface in mm").asNumber();
    s.material = incident;
    if (const auto glass = row.get("glass"); glass && !(readMaterial(*glass) == incident))
        glass->fail("a coordinate break keeps the medium " + incident.label() +
                    "; leave 'glass' out of break rows (or repeat " + incident.label() + ")");
}

void LensReader::readShape(const TomlTable& row, Surface& s) {
    if (const auto c = curvatureOf(row, "r", "c")) s.curvature = *c;
    s.conic = row.number("conic", 0.0);
    s.asphere[0] = row.number("asph_r2", 0.0);
    if (const auto asph = row.get("asph")) {
        const std::vector<TomlValue> terms = asph->asArray();
        if (terms.size() + 1 > s.asphere.size())
            asph->fail("asph lists A4, A6, ..., A20: at most " +
                       std::to_string(s.asphere.size() - 1) + " terms (got " +
                       std::to_string(terms.size()) + ")");
        for (size_t j = 0; j < terms.size(); ++j) s.asphere[j + 1] = terms[j].asNumber();
    }
    for (const char* key : {"qbfs", "qcon"}) {
        const auto q = row.get(key);
        if (!q) continue;
        const bool bfs = std::string(key) == "qbfs";
        if (s.qAsphere)
            laterInFile(*row.get("qbfs"), *q).fail("give qbfs or qcon, not both");
        if (!q->isTable())
            q->failExpected("a table { norm_radius_mm = ..., terms = [a0, a1, ...] }");
        const TomlTable t = q->asTable();
        QAsphere qa;
        qa.kind = bfs ? QAsphere::Kind::Bfs : QAsphere::Kind::Con;
        qa.normRadiusMm =
            t.require("norm_radius_mm", "the normalisation radius of the Q polynomials (mm)")
                .asNumber(NumberRange::above(0.0));
        const TomlValue terms = t.require("terms", "the Q polynomial coefficients a0, a1, ... (mm)");
        const std::vector<TomlValue> list = terms.asArray();
        if (list.empty() || list.size() > 9)
            terms.fail(std::string(key) + " terms: 1 to 9 coefficients a0 .. a8 (got " +
                       std::to_string(list.size()) + ")");
        for (const TomlValue& v : list) qa.terms.push_back(v.asNumber());
        s.qAsphere = qa;
        for (const char* other : {"asph", "asph_r2", "asph_odd"})
            if (const auto v = row.get(other))
                v->fail(std::string("a ") + key + " surface takes no '" + other +
                        "': the Q polynomials are its whole departure");
        if (bfs)
            if (const auto k = row.get("conic"); k && k->asNumber() != 0.0)
                k->fail("qbfs departs from a best-fit sphere: conic must be 0 (use qcon on a "
                        "conic)");
    }
    for (const char* key : {"toroidal", "biconic"}) {
        const auto a = row.get(key);
        if (!a) continue;
        const bool toroidal = std::string(key) == "toroidal";
        if (s.anamorphic)
            laterInFile(*row.get("toroidal"), *a).fail("give toroidal or biconic, not both");
        if (!a->isTable())
            a->failExpected(toroidal ? "a table { x_r = radius of rotation (mm; inf: a cylinder) }"
                                     : "a table { x_r = x radius (mm), x_conic = ... }");
        const TomlTable t = a->asTable();
        Anamorphic an;
        an.kind = toroidal ? Anamorphic::Kind::Toroidal : Anamorphic::Kind::Biconic;
        const std::optional<double> xc = curvatureOf(t, "x_r", "x_c");
        if (!xc)
            a->fail(std::string(key) + " needs its x section: x_r = radius (mm; inf: flat in x) " +
                    "or x_c = curvature (1/mm)");
        an.xCurvature = *xc;
        if (const auto k = t.get("x_conic")) {
            if (toroidal)
                k->fail("a toroidal surface has no x conic: its x-z section is the circle of "
                        "its radius of rotation (use biconic)");
            an.xConic = k->asNumber();
        }
        s.anamorphic = an;
        for (const char* other : {"asph_odd", "qbfs", "qcon"})
            if (const auto v = row.get(other))
                v->fail(std::string("a ") + key + " surface takes no '" + other + "'");
        if (!toroidal)
            for (const char* other : {"asph", "asph_r2"})
                if (const auto v = row.get(other))
                    v->fail(std::string("a biconic surface takes no '") + other +
                            "' (a toroidal one takes asphere terms in y)");
    }
    if (const auto odd = row.get("asph_odd")) {
        const std::vector<TomlValue> terms = odd->asArray();
        if (terms.size() > s.oddAsphere.size())
            odd->fail("asph_odd lists the terms of r^3, r^5, ..., r^19: at most " +
                      std::to_string(s.oddAsphere.size()) + " (got " +
                      std::to_string(terms.size()) + ")");
        for (size_t j = 0; j < terms.size(); ++j) s.oddAsphere[j] = terms[j].asNumber();
    }
}

Material LensReader::readMaterial(const TomlValue& value) const {
    if (value.isString()) {
        const std::string name = value.asString();
        if (equalsIgnoringCase(name, "AIR")) return Material::air();
        if (const Glass* glass = catalog_.find(name, p_.system.glassCatalogs))
            return Material::catalog(glass->name());
        std::string message = "unknown glass '" + name + "'";
        const std::vector<std::string> suggestions = catalog_.suggestions(name);
        if (!suggestions.empty())
            message += " (did you mean " + quotedList(suggestions, " or ") + "?)";
        value.fail(message + "; " + kGlassCatalogHint);
    }
    if (value.isTable() && value.asTable().has("formula")) {
        const TomlTable table = value.asTable();
        const std::string name = table.require("name", "the glass's name").asString();
        const TomlValue f = table.require("formula", "a dispersion formula's name (\"Schott\")");
        std::optional<DispersionFormula> formula;
        std::vector<std::string> names;
        for (int k = 1; k <= 13; ++k) {
            const DispersionFormula d = *dispersionFormulaFromAgf(k);
            names.emplace_back(formulaName(d));
            if (equalsIgnoringCase(f.asString(), formulaName(d))) formula = d;
        }
        if (!formula)
            f.fail("unknown dispersion formula; the formulas are " + quotedList(names, " or "));
        std::vector<double> c;
        for (const TomlValue& v :
             table.require("coefficients", "the formula's coefficients").asArray())
            c.push_back(v.asNumber());
        try {
            Glass::withFormula(name, *formula, c);
        } catch (const std::invalid_argument& e) {
            value.fail(e.what());
        }
        return Material::withFormula(name, *formula, std::move(c));
    }
    if (value.isTable() && value.asTable().has("nm")) {
        const TomlTable table = value.asTable();
        const std::string name = table.require("name", "the glass's name").asString();
        const TomlValue nm = table.require("nm", "the wavelengths, nm");
        const TomlValue n = table.require("n", "the index at each wavelength");
        std::vector<double> wavelengths, indices;
        for (const TomlValue& v : nm.asArray())
            wavelengths.push_back(v.asNumber(NumberRange::above(0.0)));
        for (const TomlValue& v : n.asArray())
            indices.push_back(v.asNumber(NumberRange::above(0.0)));
        try {
            Glass::table(name, wavelengths, indices);
        } catch (const std::invalid_argument& e) {
            value.fail(e.what());
        }
        return Material::table(name, std::move(wavelengths), std::move(indices));
    }
    if (value.isTable()) {
        const TomlTable model = value.asTable();
        const double nd = model.require("nd", "refractive index at 587.56 nm")
                              .asNumber(NumberRange::atLeast(1.0));
        const double vd = model.require("vd", "Abbe number (0: no dispersion)")
                              .asNumber(NumberRange::atLeast(0.0));
        const double dPgF = model.number("dpgf", 0.0);
        return Material::model(nd, vd, dPgF);
    }
    value.failExpected(
        "a catalog glass name (\"N-BK7\"), \"AIR\", a model glass { nd = 1.5168, vd = 64.17 } "
        "or a table { name = \"E48\", nm = [486.1, 587.6, 656.3], n = [1.5378, 1.5312, 1.5286] }");
}

void LensReader::readAperture(const TomlTable& system) {
    const TomlValue value =
        system.require("aperture",
                       "one of { f_number = ... }, { epd_mm = ... }, { object_na = ... }, "
                       "{ float_by_stop = true }");
    if (!value.isTable()) value.failExpected("a table such as { f_number = 2.0 }");
    const TomlTable aperture = value.asTable();

    std::vector<std::pair<std::string, TomlValue>> given;
    for (const char* key : {"f_number", "epd_mm", "object_na", "float_by_stop"})
        if (const auto v = aperture.get(key)) given.emplace_back(key, *v);
    if (given.empty())
        aperture.fail("aperture needs one of f_number, epd_mm, object_na or float_by_stop = true");
    if (given.size() > 1)
        laterInFile(given[0].second, given[1].second)
            .fail("aperture takes one of f_number, epd_mm, object_na and float_by_stop, not '" +
                  given[0].first + "' and '" + given[1].first + "'");

    const auto& [key, v] = given.front();
    SystemAperture& a = p_.system.aperture;
    if (key == "f_number") {
        a = {SystemAperture::Kind::ImageSpaceFNumber, v.asNumber(NumberRange::above(0.0))};
    } else if (key == "epd_mm") {
        a = {SystemAperture::Kind::EntrancePupilDiameter, v.asNumber(NumberRange::above(0.0))};
    } else if (key == "object_na") {
        a = {SystemAperture::Kind::ObjectSpaceNA, v.asNumber(NumberRange::strictlyBetween(0, 1))};
        if (std::isinf(p_.surfaces[0].thicknessMm))
            v.fail(
                "object_na needs a finite object_distance_mm; use f_number or epd_mm for an "
                "object at infinity");
    } else {
        if (!v.asBool())
            v.fail("float_by_stop = false sets no aperture; give f_number, epd_mm or object_na");
        const int stop = p_.stopIndex();
        if (p_.surfaces[stop].clearSemiDiameterMm <= 0.0)
            v.fail("float_by_stop takes the aperture from the stop's sd, but the stop " +
                   rowPath(stop) + " has none");
        a = {SystemAperture::Kind::FloatByStop, 0.0};
    }
}

void LensReader::readFields(const TomlTable& system) {
    SystemData& sys = p_.system;
    const auto deg = system.get("fields_deg");
    const auto objectMm = system.get("fields_mm");
    const auto paraxialMm = system.get("fields_paraxial_image_mm");
    const auto realMm = system.get("fields_real_image_mm");
    std::optional<TomlValue> given;
    for (const auto* f : {&deg, &objectMm, &paraxialMm, &realMm}) {
        if (!*f) continue;
        if (given)
            laterInFile(*given, **f).fail(
                "give one of fields_deg (angles), fields_mm (object heights), "
                "fields_paraxial_image_mm or fields_real_image_mm (image heights), not two");
        given = **f;
    }
    if (objectMm && std::isinf(p_.surfaces[0].thicknessMm))
        objectMm->fail(
            "fields_mm gives object heights, which need a finite object_distance_mm; use "
            "fields_deg for an object at infinity");
    sys.fieldKind = objectMm     ? SystemData::FieldKind::ObjectHeightMm
                    : paraxialMm ? SystemData::FieldKind::ParaxialImageHeightMm
                    : realMm     ? SystemData::FieldKind::RealImageHeightMm
                                 : SystemData::FieldKind::AngleDeg;
    const NumberRange range = deg ? NumberRange::strictlyBetween(-90, 90) : NumberRange::any();

    if (const auto& list = given) {
        const std::vector<TomlValue> entries = list->asArray();
        if (entries.empty()) list->fail(list->path() + " needs at least one field");
        for (const TomlValue& entry : entries) {
            Field f;
            if (entry.isNumber()) {
                f.y = entry.asNumber(range);
            } else if (entry.isArray()) {
                const std::vector<TomlValue> xy = entry.asArray();
                if (xy.size() != 2)
                    entry.fail(entry.path() + " must be a pair [x, y] (got " +
                               std::to_string(xy.size()) + " numbers)");
                f.x = xy[0].asNumber(range);
                f.y = xy[1].asNumber(range);
            } else {
                entry.failExpected("a number (y) or a pair [x, y]");
            }
            sys.fields.push_back(f);
        }
    } else {
        sys.fields.push_back({});  // on axis
    }

    if (const auto weights = system.get("field_weights")) {
        const std::vector<TomlValue> entries = weights->asArray();
        if (entries.size() != sys.fields.size())
            weights->fail("field_weights has " + std::to_string(entries.size()) + " entries for " +
                          std::to_string(sys.fields.size()) + " fields");
        for (size_t i = 0; i < entries.size(); ++i)
            sys.fields[i].weight = entries[i].asNumber(NumberRange::atLeast(0.0));
    }
    if (const auto v = system.get("field_vignetting")) {
        const std::vector<TomlValue> entries = v->asArray();
        if (entries.size() != sys.fields.size())
            v->fail("field_vignetting has " + std::to_string(entries.size()) + " entries for " +
                    std::to_string(sys.fields.size()) + " fields");
        for (size_t i = 0; i < entries.size(); ++i) {
            const std::vector<TomlValue> f = entries[i].asArray();
            if (f.size() != 4)
                entries[i].fail(entries[i].path() +
                                " must be [vdx, vdy, vcx, vcy] (4 numbers, got " +
                                std::to_string(f.size()) + ")");
            Field& field = sys.fields[i];
            field.vdx = f[0].asNumber(NumberRange::any());
            field.vdy = f[1].asNumber(NumberRange::any());
            // A compression of 1 or more would leave no beam.
            const NumberRange compression{-std::numeric_limits<double>::infinity(), 1.0, false,
                                          true};
            field.vcx = f[2].asNumber(compression);
            field.vcy = f[3].asNumber(compression);
        }
    }
    sys.rectangularField = system.boolean("rectangular_field", false);
}

Prescription LensReader::finish() {
    p_.assignNames();
    const int n = static_cast<int>(p_.surfaces.size());
    for (const auto& [index, value] : userNames_) {
        for (int j = 0; j < n; ++j) {
            if (j == index || p_.surfaces[j].name != p_.surfaces[index].name) continue;
            const std::string other = j == 0       ? "the object surface"
                                      : j == n - 1 ? "the image surface"
                                                   : rowPath(j);
            value.fail("surface name '" + p_.surfaces[index].name + "' is also the name of " +
                       other);
        }
    }
    p_.validate();
    p_.notePlausibility();
    return std::move(p_);
}

}  // namespace

// TOML Reader Public Functions

Prescription readTomlPrescription(TomlDocument& doc, const GlassCatalog& catalog) {
    LensReader reader(catalog);
    reader.read(doc);
    return reader.finish();
}

Prescription readTomlPrescriptionText(std::string_view text, const std::string& fileName,
                                      const GlassCatalog& catalog) {
    TomlDocument doc = TomlDocument::fromString(text, fileName);
    LensReader reader(catalog);
    reader.read(doc);
    doc.checkAllUsed();  // a misspelt key explains more than the model check it may cause
    return reader.finish();
}

Prescription readTomlPrescriptionFile(const std::filesystem::path& path,
                                      const GlassCatalog& catalog) {
    TomlDocument doc = TomlDocument::fromFile(path);
    LensReader reader(catalog);
    reader.read(doc);
    doc.checkAllUsed();
    return reader.finish();
}

}  // namespace veil
