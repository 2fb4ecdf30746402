#include "lensdata/prescription.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace veil {

// Material Public Methods

std::string Material::label() const {
    switch (kind) {
        case Kind::Air:
            return "AIR";
        case Kind::Catalog:
            return name;
        case Kind::Model: {
            std::ostringstream os;
            os << "model " << nd << "/" << vd;
            if (dPgF != 0.0) os << "/" << dPgF;
            return os.str();
        }
        case Kind::Table:
            return name + " (table)";
        case Kind::Formula:
            return name + " (" + std::string(formulaName(formula)) + ")";
    }
    return "?";
}

std::optional<Glass> Material::ownGlass() const {
    if (kind == Kind::Model) return Glass::model(nd, vd, dPgF);
    if (kind == Kind::Table) return Glass::table(name, tableNm, tableIndex);
    if (kind == Kind::Formula) return Glass::withFormula(name, formula, coefficients);
    return std::nullopt;
}

std::ostream& operator<<(std::ostream& os, const Material& m) { return os << m.label(); }

// Surface Public Methods

bool Surface::hasAsphere() const {
    for (double a : asphere)
        if (a != 0.0) return true;
    for (double b : oddAsphere)
        if (b != 0.0) return true;
    return qAsphere.has_value();
}

std::ostream& operator<<(std::ostream& os, const QAsphere& q) {
    os << (q.kind == QAsphere::Kind::Bfs ? "Qbfs" : "Qcon") << "{norm radius " << q.normRadiusMm
       << " mm, terms [";
    for (size_t i = 0; i < q.terms.size(); ++i) os << (i ? ", " : "") << q.terms[i];
    return os << "]}";
}

std::ostream& operator<<(std::ostream& os, const Anamorphic& a) {
    os << (a.kind == Anamorphic::Kind::Toroidal ? "Toroidal" : "Biconic") << "{x curvature "
       << a.xCurvature << " /mm";
    if (a.kind == Anamorphic::Kind::Biconic) os << ", x conic " << a.xConic;
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const CoordinateBreak& b) {
    os << "CoordinateBreak{decenter " << b.decenterXMm << ", " << b.decenterYMm << " mm, tilt "
       << b.tiltXDeg << ", " << b.tiltYDeg << ", " << b.tiltZDeg << " deg";
    if (b.tiltFirst) os << ", tilt first";
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const Surface& s) {
    os << "Surface{" << (s.name.empty() ? "?" : s.name);
    if (s.coordinateBreak) os << " " << *s.coordinateBreak;
    if (s.anamorphic) os << " " << *s.anamorphic;
    os << " R=";
    if (s.curvature == 0.0)
        os << "inf";
    else
        os << s.radiusMm();
    os << " t=" << s.thicknessMm << " " << s.material;
    if (s.conic != 0.0) os << " k=" << s.conic;
    if (s.hasAsphere()) os << " asphere";
    if (s.clearSemiDiameterMm > 0.0) os << " sd=" << s.clearSemiDiameterMm;
    if (s.innerSemiDiameterMm > 0.0) os << " hole=" << s.innerSemiDiameterMm;
    if (s.mechSemiDiameterMm > 0.0) os << " msd=" << s.mechSemiDiameterMm;
    if (s.stop) os << " STOP";
    if (s.mirror) os << " MIRROR";
    if (!s.coating.empty()) os << " coating=" << s.coating;
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const Element& e) {
    return os << "Element{" << e.name << " surfaces " << e.frontSurface << ".." << e.backSurface
              << " " << e.material << "}";
}

std::ostream& operator<<(std::ostream& os, const SystemAperture& a) {
    switch (a.kind) {
        case SystemAperture::Kind::EntrancePupilDiameter:
            return os << "EPD " << a.value << " mm";
        case SystemAperture::Kind::ImageSpaceFNumber:
            return os << "F/" << a.value;
        case SystemAperture::Kind::ObjectSpaceNA:
            return os << "object NA " << a.value;
        case SystemAperture::Kind::FloatByStop:
            return os << "float by stop size";
    }
    return os;
}

std::ostream& operator<<(std::ostream& os, const ImportNote& n) {
    const char* sev = n.severity == ImportNote::Severity::Info      ? "info"
                      : n.severity == ImportNote::Severity::Warning ? "warning"
                                                                    : "error";
    return os << n.loc << ": " << sev << ": " << n.message;
}

// Prescription Public Methods

int Prescription::stopIndex() const {
    for (size_t i = 0; i < surfaces.size(); ++i)
        if (surfaces[i].stop) return static_cast<int>(i);
    return surfaces.size() > 1 ? 1 : 0;
}

std::vector<Element> Prescription::elements() const {
    // Gap i runs from surface i to surface i+1; gaps 1..N-2 lie inside the system. Each gap
    // holding glass is an element, except the return pass through a second-surface mirror
    // (Mangin): the gap after a mirror inside glass belongs to the element in front of it.
    // Coordinate breaks inside glass do not end an element: it runs on to the next surface
    // that is not a break.
    std::vector<Element> out;
    const int n = static_cast<int>(surfaces.size());
    for (int i = 1; i + 1 < n; ++i) {
        const Surface& s = surfaces[i];
        if (s.material.isAir() || s.coordinateBreak) continue;
        const bool returnPass = s.mirror && !out.empty() && out.back().backSurface == i;
        if (returnPass) continue;
        int back = i + 1;
        while (back + 1 < n && surfaces[back].coordinateBreak) ++back;
        // Appended, not "L" + ...: GCC 12 warns falsely (-Wrestrict) on the inlined concat.
        std::string name = "L";
        name += std::to_string(out.size() + 1);
        out.push_back({std::move(name), i, back, s.material});
    }
    return out;
}

void Prescription::assignNames() {
    const int n = static_cast<int>(surfaces.size());
    if (n == 0) return;
    std::vector<std::string> names(n);
    names[0] = "object";
    names[n - 1] = "image";
    for (const Element& e : elements()) {
        if (names[e.frontSurface].empty()) names[e.frontSurface] = e.name + ".front";
        if (names[e.backSurface].empty()) names[e.backSurface] = e.name + ".back";
    }
    int mirrorCount = 0;
    for (int i = 1; i < n - 1; ++i) {
        if (surfaces[i].mirror && names[i].empty()) {
            names[i] = "M";
            names[i] += std::to_string(++mirrorCount);
        }
    }
    for (int i = 1; i < n - 1; ++i) {
        if (!names[i].empty()) continue;
        names[i] = surfaces[i].stop ? "stop" : "S";
        if (!surfaces[i].stop) names[i] += std::to_string(i);
    }
    for (int i = 0; i < n; ++i)
        if (surfaces[i].name.empty()) surfaces[i].name = names[i];
}

std::vector<std::string> Prescription::aliasesOf(int surfaceIndex) const {
    std::vector<std::string> out;
    for (const Element& e : elements()) {
        const std::string front = e.name + ".front";
        const std::string back = e.name + ".back";
        if (e.frontSurface == surfaceIndex && surfaces[surfaceIndex].name != front)
            out.push_back(front);
        if (e.backSurface == surfaceIndex && surfaces[surfaceIndex].name != back)
            out.push_back(back);
    }
    if (surfaces[surfaceIndex].stop && surfaces[surfaceIndex].name != "stop") out.push_back("stop");
    return out;
}

void Prescription::validate() const {
    const int n = static_cast<int>(surfaces.size());
    if (n < 3)
        throw ModelError(sourceFile.empty() ? "prescription" : sourceFile,
                         "a system needs an object surface, at least one surface and an image "
                         "surface (got " +
                             std::to_string(n) + " surfaces)");
    auto nameOf = [&](int i) {
        return surfaces[i].name.empty() ? "surface " + std::to_string(i) : surfaces[i].name;
    };
    int stops = 0;
    for (int i = 0; i < n; ++i) {
        const Surface& s = surfaces[i];
        if (!std::isfinite(s.curvature)) throw ModelError(nameOf(i), "curvature is not finite");
        if (!std::isfinite(s.conic)) throw ModelError(nameOf(i), "conic is not finite");
        for (double a : s.asphere)
            if (!std::isfinite(a)) throw ModelError(nameOf(i), "asphere term is not finite");
        if (i > 0 && i < n - 1 && !std::isfinite(s.thicknessMm))
            throw ModelError(nameOf(i), "only the object distance may be infinite");
        if (std::isnan(s.thicknessMm)) throw ModelError(nameOf(i), "thickness is NaN");
        if (s.clearSemiDiameterMm < 0.0 || s.mechSemiDiameterMm < 0.0)
            throw ModelError(nameOf(i), "negative semi-diameter");
        if (s.mechSemiDiameterMm > 0.0 && s.clearSemiDiameterMm > s.mechSemiDiameterMm)
            throw ModelError(nameOf(i), "clear semi-diameter " +
                                            std::to_string(s.clearSemiDiameterMm) +
                                            " mm exceeds the mechanical semi-diameter " +
                                            std::to_string(s.mechSemiDiameterMm) + " mm");
        if (!(s.innerSemiDiameterMm >= 0.0) || !std::isfinite(s.innerSemiDiameterMm))
            throw ModelError(nameOf(i), "hole semi-diameter must be finite and >= 0 (got " +
                                            std::to_string(s.innerSemiDiameterMm) + " mm)");
        if (s.innerSemiDiameterMm > 0.0 && (i == 0 || i == n - 1))
            throw ModelError(nameOf(i), "the object and image surfaces cannot have a hole");
        // A hole without a clear semi-diameter gets the traced one around it (the scene's
        // automatic semi-diameters); the solids need one either way.
        if (s.innerSemiDiameterMm > 0.0 && s.clearSemiDiameterMm > 0.0 &&
            s.innerSemiDiameterMm >= s.clearSemiDiameterMm)
            throw ModelError(nameOf(i), "hole semi-diameter " +
                                            std::to_string(s.innerSemiDiameterMm) +
                                            " mm must be smaller than the clear semi-diameter " +
                                            std::to_string(s.clearSemiDiameterMm) + " mm");
        if (s.stop) ++stops;
        if (s.mirror && (i == 0 || i == n - 1))
            throw ModelError(nameOf(i), "the object and image surfaces cannot be mirrors");
        if (s.mirror && !(s.material == surfaces[i - 1].material))
            throw ModelError(nameOf(i), "a mirror keeps the medium: material after it must be " +
                                            surfaces[i - 1].material.label());
        if (s.qAsphere) {
            const QAsphere& q = *s.qAsphere;
            const char* kind = q.kind == QAsphere::Kind::Bfs ? "Qbfs" : "Qcon";
            if (!(q.normRadiusMm > 0.0) || !std::isfinite(q.normRadiusMm))
                throw ModelError(nameOf(i), std::string(kind) +
                                                " normalisation radius must be finite and > 0");
            if (q.terms.empty() || q.terms.size() > 9)
                throw ModelError(nameOf(i), std::string(kind) + " takes 1 to 9 terms (got " +
                                                std::to_string(q.terms.size()) + ")");
            for (double a : q.terms)
                if (!std::isfinite(a))
                    throw ModelError(nameOf(i), std::string(kind) + " term is not finite");
            for (double a : s.asphere)
                if (a != 0.0)
                    throw ModelError(nameOf(i), std::string(kind) +
                                                    " surface with even asphere terms: give one "
                                                    "or the other");
            for (double b : s.oddAsphere)
                if (b != 0.0)
                    throw ModelError(nameOf(i), std::string(kind) +
                                                    " surface with odd asphere terms: give one or "
                                                    "the other");
            if (q.kind == QAsphere::Kind::Bfs && s.conic != 0.0)
                throw ModelError(nameOf(i), "Qbfs departs from a best-fit sphere: its conic must "
                                            "be 0 (a conic base is Qcon)");
        }
        if (s.anamorphic) {
            const Anamorphic& a = *s.anamorphic;
            const std::string kind = a.label();
            if (!std::isfinite(a.xCurvature) || !std::isfinite(a.xConic))
                throw ModelError(nameOf(i), kind + " x curvature or conic is not finite");
            if (i == 0 || i == n - 1)
                throw ModelError(nameOf(i), "the object and image surfaces cannot be " + kind);
            if (s.qAsphere || std::any_of(s.oddAsphere.begin(), s.oddAsphere.end(),
                                          [](double b) { return b != 0.0; }))
                throw ModelError(nameOf(i), "a " + kind +
                                                " surface takes no Q-type or odd asphere terms");
            if (a.kind == Anamorphic::Kind::Toroidal && a.xConic != 0.0)
                throw ModelError(nameOf(i), "a toroidal surface has no x conic (its x-z section "
                                            "is the circle of its radius of rotation)");
            if (a.kind == Anamorphic::Kind::Biconic &&
                std::any_of(s.asphere.begin(), s.asphere.end(), [](double v) { return v != 0.0; }))
                throw ModelError(nameOf(i), "a biconic surface takes no asphere terms (a toroidal "
                                            "one takes terms in y)");
        }
        if (s.coordinateBreak) {
            const CoordinateBreak& b = *s.coordinateBreak;
            for (double v : {b.decenterXMm, b.decenterYMm, b.tiltXDeg, b.tiltYDeg, b.tiltZDeg})
                if (!std::isfinite(v))
                    throw ModelError(nameOf(i), "coordinate break decenter or tilt is not finite");
            if (i == 0 || i == n - 1)
                throw ModelError(nameOf(i),
                                 "the object and image surfaces cannot be coordinate breaks");
            if (s.mirror || s.stop || s.curvature != 0.0 || s.conic != 0.0 || s.hasAsphere() ||
                s.anamorphic || s.innerSemiDiameterMm > 0.0)
                throw ModelError(nameOf(i),
                                 "a coordinate break is a flat dummy surface: it cannot be a "
                                 "mirror or the stop, or have a curvature, conic, asphere or hole");
            if (!(s.material == surfaces[i - 1].material))
                throw ModelError(nameOf(i), "a coordinate break keeps the medium: material after "
                                            "it must be " +
                                                surfaces[i - 1].material.label());
        }
        if (s.material.kind == Material::Kind::Model &&
            (s.material.nd < 1.0 || s.material.vd < 0.0))
            throw ModelError(nameOf(i), "model glass needs nd >= 1 and Vd >= 0 (0: no dispersion)");
        if (s.material.kind == Material::Kind::Table ||
            s.material.kind == Material::Kind::Formula) {
            try {
                s.material.ownGlass();
            } catch (const std::invalid_argument& e) {
                throw ModelError(nameOf(i), "glass " + s.material.name + ": " + e.what());
            }
        }
    }
    if (stops > 1) throw ModelError("stop", "more than one surface is flagged as the stop");
    if (surfaces[0].stop) throw ModelError("object", "the object surface cannot be the stop");
}

void Prescription::notePlausibility() {
    const int n = static_cast<int>(surfaces.size());
    auto num = [](double v) {
        std::ostringstream os;
        os << std::setprecision(6) << v;
        return os.str();
    };
    auto warn = [&](int i, const std::string& message) {
        const Surface& s = surfaces[i];
        FileLoc loc = s.origin;
        if (loc.file.empty()) loc.file = sourceFile;
        report.push_back({ImportNote::Severity::Warning, loc,
                          (s.name.empty() ? "surface " + std::to_string(i) : s.name) + ": " +
                              message});
    };
    // A flat surface in air, not a mirror: a reference plane whose gaps may run back.
    auto dummy = [&](int i) {
        const Surface& s = surfaces[i];
        return i == 0 || i == n - 1 ||
               (s.curvature == 0.0 && !s.hasAsphere() && !s.anamorphic && !s.mirror &&
                s.material.isAir() && surfaces[i - 1].material.isAir());
    };
    double direction = 1.0;  // +1 along +z; every mirror turns it
    for (int i = 1; i < n - 1; ++i) {
        const Surface& s = surfaces[i];
        if (s.coordinateBreak) continue;
        const double sd = s.clearSemiDiameterMm;
        if (s.curvature != 0.0 && std::abs(s.radiusMm()) < 1e-3)
            warn(i, "radius " + num(s.radiusMm()) + " mm is below a micrometre");
        // The height a conic section reaches: c^2 (1 + k) r^2 <= 1.
        auto reach = [&](double c, double k, const std::string& section) {
            if (c == 0.0 || !(1.0 + k > 0.0) || !(sd > 0.0)) return;
            const double limit = 1.0 / (std::abs(c) * std::sqrt(1.0 + k));
            if (sd > limit * (1.0 + 1e-12))
                warn(i, "clear semi-diameter " + num(sd) + " mm exceeds the height the " +
                            section + " reaches, " + num(limit) +
                            " mm (|R| / sqrt(1 + conic)): rays beyond it miss the surface");
        };
        reach(s.curvature, s.conic, s.anamorphic ? "y-z section" : "surface");
        if (s.anamorphic && s.anamorphic->kind == Anamorphic::Kind::Biconic)
            reach(s.anamorphic->xCurvature, s.anamorphic->xConic, "x-z section");
        if (s.mirror) direction = -direction;
        const double along = s.thicknessMm * direction;
        if (!s.material.isAir() && !(along > 0.0))
            warn(i, "thickness " + num(s.thicknessMm) + " mm in " + s.material.label() +
                        (s.thicknessMm == 0.0 ? " (glass of no thickness)"
                                              : " runs against the light (no mirror turns it)"));
        else if (s.material.isAir() && along < 0.0 && !dummy(i) && !dummy(i + 1))
            warn(i, "air gap " + num(s.thicknessMm) +
                        " mm runs against the light: the next surface lies behind this one "
                        "(meant for a dummy surface or a stop placed back; lenses there "
                        "overlap)");
    }
}

int Prescription::firstAnamorphic() const {
    for (size_t i = 0; i < surfaces.size(); ++i)
        if (surfaces[i].anamorphic) return static_cast<int>(i);
    return -1;
}

Prescription Prescription::xSection() const {
    Prescription x = *this;
    for (Surface& s : x.surfaces) {
        if (!s.anamorphic) continue;
        const Anamorphic a = *s.anamorphic;
        s.anamorphic.reset();
        s.curvature = a.xCurvature;
        // A toroid's x-z section is the circle of its radius of rotation; its asphere terms
        // are in y alone.
        s.conic = a.kind == Anamorphic::Kind::Biconic ? a.xConic : 0.0;
        s.asphere = {};
    }
    return x;
}

}  // namespace veil
