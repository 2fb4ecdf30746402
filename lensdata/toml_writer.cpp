#include "lensdata/toml_writer.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <sstream>

#include "lensdata/errors.h"

namespace veil {

namespace {

// The shortest text that reads back to the same double; TOML's inf and nan.
std::string num(double v) {
    if (std::isnan(v)) return "nan";
    if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
    std::array<char, 32> buf{};
    const auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v);
    // "5" is a TOML integer and "1e-05" a float: veil's reader takes both as numbers.
    return std::string(buf.data(), end);
}

// A TOML basic string.
std::string str(const std::string& s) {
    std::string out = "\"";
    for (const char c : s) {
        switch (c) {
            case '"':
                out += "\\\"";
                break;
            case '\\':
                out += "\\\\";
                break;
            case '\n':
                out += "\\n";
                break;
            case '\t':
                out += "\\t";
                break;
            case '\r':
                out += "\\r";
                break;
            default:
                if (static_cast<unsigned char>(c) < 0x20) {
                    char esc[8];
                    std::snprintf(esc, sizeof esc, "\\u%04x", c);
                    out += esc;
                } else {
                    out += c;
                }
        }
    }
    return out + "\"";
}

template <class Range>
std::string list(const Range& values, size_t count) {
    std::string out = "[";
    for (size_t i = 0; i < count; ++i) out += (i ? ", " : "") + num(values[i]);
    return out + "]";
}

// The values up to the last non-zero one.
template <size_t N>
size_t used(const std::array<double, N>& a, size_t from = 0) {
    size_t n = from;
    for (size_t i = from; i < N; ++i)
        if (a[i] != 0.0) n = i + 1;
    return n;
}

std::string material(const Material& m) {
    switch (m.kind) {
        case Material::Kind::Air:
            return "\"AIR\"";
        case Material::Kind::Catalog:
            return str(m.name);
        case Material::Kind::Model:
            return "{ nd = " + num(m.nd) + ", vd = " + num(m.vd) +
                   (m.dPgF != 0.0 ? ", dpgf = " + num(m.dPgF) : "") + " }";
        case Material::Kind::Table: {
            std::string nm, n;
            for (size_t i = 0; i < m.tableNm.size(); ++i) {
                if (i) {
                    nm += ", ";
                    n += ", ";
                }
                nm += num(m.tableNm[i]);
                n += num(m.tableIndex[i]);
            }
            return "{ name = " + str(m.name) + ", nm = [" + nm + "], n = [" + n + "] }";
        }
        case Material::Kind::Formula: {
            std::string c;
            for (size_t i = 0; i < m.coefficients.size(); ++i) {
                if (i) c += ", ";
                c += num(m.coefficients[i]);
            }
            return "{ name = " + str(m.name) +
                   ", formula = " + str(std::string(formulaName(m.formula))) +
                   ", coefficients = [" + c + "] }";
        }
    }
    return "\"AIR\"";
}

// The surface's shape keys (r or c, conic, aspheres, Q-type, anamorphic).
void writeShape(std::ostream& os, const Surface& s) {
    if (s.curvature != 0.0) {
        const double r = 1.0 / s.curvature;
        // The radius where it reads back to the same curvature, else the curvature itself.
        if (1.0 / r == s.curvature)
            os << "r = " << num(r) << "\n";
        else
            os << "c = " << num(s.curvature) << "\n";
    }
    if (s.conic != 0.0) os << "conic = " << num(s.conic) << "\n";
    if (s.asphere[0] != 0.0) os << "asph_r2 = " << num(s.asphere[0]) << "\n";
    if (const size_t n = used(s.asphere, 1); n > 1) {
        os << "asph = [";
        for (size_t i = 1; i < n; ++i) os << (i > 1 ? ", " : "") << num(s.asphere[i]);
        os << "]\n";
    }
    if (const size_t n = used(s.oddAsphere); n > 0)
        os << "asph_odd = " << list(s.oddAsphere, n) << "\n";
    if (s.qAsphere)
        os << (s.qAsphere->kind == QAsphere::Kind::Bfs ? "qbfs" : "qcon")
           << " = { norm_radius_mm = " << num(s.qAsphere->normRadiusMm)
           << ", terms = " << list(s.qAsphere->terms, s.qAsphere->terms.size()) << " }\n";
    if (s.anamorphic) {
        if (s.anamorphic->kind == Anamorphic::Kind::Toroidal)
            os << "toroidal = { x_c = " << num(s.anamorphic->xCurvature) << " }\n";
        else
            os << "biconic = { x_c = " << num(s.anamorphic->xCurvature)
               << ", x_conic = " << num(s.anamorphic->xConic) << " }\n";
    }
}

void writeApertures(std::ostream& os, const Surface& s, bool image) {
    if (s.clearSemiDiameterMm != 0.0) os << "sd = " << num(s.clearSemiDiameterMm) << "\n";
    if (s.semiDiameterAutomatic && s.clearSemiDiameterMm != 0.0) os << "sd_auto = true\n";
    if (s.mechSemiDiameterMm != 0.0) os << "mech_sd = " << num(s.mechSemiDiameterMm) << "\n";
    if (!image && s.innerSemiDiameterMm != 0.0)
        os << "hole_sd = " << num(s.innerSemiDiameterMm) << "\n";
}

}  // namespace

std::string prescriptionToml(const Prescription& lens, const GlassCatalog& catalog,
                             const std::string& source) {
    const int n = static_cast<int>(lens.surfaces.size());
    if (n < 2) throw ModelError(source, "the lens has no surfaces to write");
    const Surface& object = lens.surfaces.front();
    if (object.curvature != 0.0 || object.conic != 0.0 || object.hasAsphere() ||
        object.anamorphic || object.coordinateBreak)
        throw ModelError(object.name.empty() ? "object" : object.name,
                         "a curved or tilted object surface cannot be written as a veil lens "
                         "file (its object is a plane at object_distance_mm)");
    // The names veil would give: only the others are written.
    Prescription unnamed = lens;
    for (Surface& s : unnamed.surfaces) s.name.clear();
    unnamed.assignNames();

    const SystemData& sys = lens.system;
    std::ostringstream os;
    os << "# A veil lens file (docs/format.md), written by veil export-lens from " << source
       << ".\n# Every value the import kept; `veil info` on this file gives the same lens.\n\n";
    os << "[system]\n";
    if (!sys.name.empty()) os << "name = " << str(sys.name) << "\n";
    if (!sys.notes.empty()) os << "notes = " << str(sys.notes) << "\n";
    os << "wavelengths_nm = [";
    for (size_t i = 0; i < sys.wavelengths.size(); ++i) {
        const Wavelength& w = sys.wavelengths[i];
        os << (i ? ", " : "");
        if (w.weight == 1.0)
            os << num(w.nm);
        else
            os << "{ nm = " << num(w.nm) << ", weight = " << num(w.weight) << " }";
    }
    os << "]\n";
    os << "primary_wavelength = " << sys.primaryWavelength + 1 << "\n";
    switch (sys.aperture.kind) {
        case SystemAperture::Kind::EntrancePupilDiameter:
            os << "aperture = { epd_mm = " << num(sys.aperture.value) << " }\n";
            break;
        case SystemAperture::Kind::ImageSpaceFNumber:
            os << "aperture = { f_number = " << num(sys.aperture.value) << " }\n";
            break;
        case SystemAperture::Kind::ObjectSpaceNA:
            os << "aperture = { object_na = " << num(sys.aperture.value) << " }\n";
            break;
        case SystemAperture::Kind::FloatByStop:
            os << "aperture = { float_by_stop = true }\n";
            break;
    }
    // The fields as the file gave them: image heights stay image heights.
    using FK = SystemData::FieldKind;
    const bool heights = (sys.givenFieldKind == FK::ParaxialImageHeightMm ||
                          sys.givenFieldKind == FK::RealImageHeightMm) &&
                         sys.imageHeights.size() == sys.fields.size();
    const std::vector<Field>& fields = heights ? sys.imageHeights : sys.fields;
    const FK kind = heights ? sys.givenFieldKind : sys.fieldKind;
    os << (kind == FK::AngleDeg                ? "fields_deg"
           : kind == FK::ObjectHeightMm        ? "fields_mm"
           : kind == FK::ParaxialImageHeightMm ? "fields_paraxial_image_mm"
                                               : "fields_real_image_mm")
       << " = [";
    for (size_t i = 0; i < fields.size(); ++i)
        os << (i ? ", " : "") << "[" << num(fields[i].x) << ", " << num(fields[i].y) << "]";
    os << "]\n";
    bool weighted = false, vignetted = false;
    for (const Field& f : sys.fields) {
        weighted = weighted || f.weight != 1.0;
        vignetted = vignetted || f.vignetted();
    }
    if (weighted) {
        os << "field_weights = [";
        for (size_t i = 0; i < sys.fields.size(); ++i)
            os << (i ? ", " : "") << num(sys.fields[i].weight);
        os << "]\n";
    }
    if (vignetted) {
        os << "field_vignetting = [";
        for (size_t i = 0; i < sys.fields.size(); ++i) {
            const Field& f = sys.fields[i];
            os << (i ? ", " : "") << "[" << num(f.vdx) << ", " << num(f.vdy) << ", " << num(f.vcx)
               << ", " << num(f.vcy) << "]";
        }
        os << "]\n";
    }
    if (sys.rectangularField) os << "rectangular_field = true\n";
    os << "object_distance_mm = " << num(object.thicknessMm) << "\n";
    std::vector<std::string> known;
    const std::vector<std::string> loaded = catalog.catalogNames();
    for (const std::string& c : sys.glassCatalogs)
        for (const std::string& l : loaded)
            if (std::equal(c.begin(), c.end(), l.begin(), l.end(), [](char a, char b) {
                    return std::toupper(static_cast<unsigned char>(a)) ==
                           std::toupper(static_cast<unsigned char>(b));
                }))
                known.push_back(l);
    if (!known.empty()) {
        os << "glass_catalogs = [";
        for (size_t i = 0; i < known.size(); ++i) os << (i ? ", " : "") << str(known[i]);
        os << "]\n";
    }

    for (int i = 1; i < n; ++i) {
        const Surface& s = lens.surfaces[i];
        const bool image = i == n - 1;
        os << "\n[[system.surfaces]]\n";
        if (s.name != unnamed.surfaces[i].name) os << "name = " << str(s.name) << "\n";
        if (s.coordinateBreak) {
            const CoordinateBreak& b = *s.coordinateBreak;
            os << "break = { decenter_mm = [" << num(b.decenterXMm) << ", " << num(b.decenterYMm)
               << "], tilt_deg = [" << num(b.tiltXDeg) << ", " << num(b.tiltYDeg) << ", "
               << num(b.tiltZDeg) << "], tilt_first = " << (b.tiltFirst ? "true" : "false")
               << " }\n";
            os << "t = " << num(s.thicknessMm) << "\n";
        } else if (image) {
            os << "image = true\n";
            writeShape(os, s);
            writeApertures(os, s, true);
        } else {
            writeShape(os, s);
            os << "t = " << num(s.thicknessMm) << "\n";
            if (s.mirror)
                os << "mirror = true\n";
            else if (!s.material.isAir())
                os << "glass = " << material(s.material) << "\n";
            if (s.stop) os << "stop = true\n";
            writeApertures(os, s, false);
        }
        if (!s.coordinateBreak && !s.coating.empty()) os << "coating = " << str(s.coating) << "\n";
        if (!s.comment.empty()) os << "comment = " << str(s.comment) << "\n";
    }
    return os.str();
}

}  // namespace veil
