#include "analysis/lens/info_report.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "analysis/reports/format.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/prescription.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

namespace {

nlohmann::json firstOrderJson(const FirstOrderData& d) {
    nlohmann::json j;
    j["wavelength_nm"] = d.wavelengthNm;
    j["efl_mm"] = jsonNumber(d.eflMm);
    j["bfl_mm"] = jsonNumber(d.bflMm);
    j["ffl_mm"] = jsonNumber(d.fflMm);
    j["front_principal_plane_from_surface1_mm"] = jsonNumber(d.frontPrincipalPlaneMm);
    j["rear_principal_plane_from_image_mm"] = jsonNumber(d.rearPrincipalPlaneMm);
    j["paraxial_image_from_image_surface_mm"] = jsonNumber(d.paraxialImageDistanceMm);
    j["entrance_pupil_from_surface1_mm"] = jsonNumber(d.entrancePupilPositionMm);
    j["entrance_pupil_diameter_mm"] = jsonNumber(d.entrancePupilDiameterMm);
    j["exit_pupil_from_image_mm"] = jsonNumber(d.exitPupilPositionMm);
    j["exit_pupil_diameter_mm"] = jsonNumber(d.exitPupilDiameterMm);
    j["stop_semi_diameter_mm"] = jsonNumber(d.stopSemiDiameterMm);
    j["f_number"] = jsonNumber(d.imageSpaceFNumber);
    j["working_f_number"] = jsonNumber(d.workingFNumber);
    j["image_space_na"] = jsonNumber(d.imageSpaceNA);
    j["object_space_na"] = jsonNumber(d.objectSpaceNA);
    j["paraxial_magnification"] = jsonNumber(d.paraxialMagnification);
    j["total_track_mm"] = jsonNumber(d.totalTrackMm);
    j["petzval_radius_mm"] = jsonNumber(d.petzvalRadiusMm);
    nlohmann::json h = nlohmann::json::array();
    for (double v : d.paraxialImageHeightsMm) h.push_back(jsonNumber(v));
    j["paraxial_image_heights_mm"] = h;
    return j;
}

std::string fmt(double v, int prec = 6) {
    if (!std::isfinite(v)) return v > 0 ? "inf" : (v < 0 ? "-inf" : "nan");
    if (v == 0.0) v = 0.0;  // -0 prints as 0
    std::ostringstream os;
    os << std::setprecision(prec) << v;
    return os.str();
}

// Fixed-point millimetres to the nanometre, with -0 shown as 0.
std::string fmtMm(double v) {
    if (!std::isfinite(v)) return fmt(v);
    if (std::abs(v) < 5e-7) v = 0.0;
    std::ostringstream os;
    os << std::fixed << std::setprecision(6) << v;
    return os.str();
}

const char* severityName(ImportNote::Severity s) {
    switch (s) {
        case ImportNote::Severity::Info:
            return "info";
        case ImportNote::Severity::Warning:
            return "warning";
        case ImportNote::Severity::Error:
            return "error";
    }
    return "?";
}

}  // namespace

InfoReport makeInfoReport(const std::string& file, Prescription prescription,
                          const GlassCatalog& catalog, AimMode aim, int rings) {
    InfoReport r;
    r.file = file;
    r.prescription = std::move(prescription);
    r.model = std::make_shared<const SequentialModel>(
        SequentialModel::build(r.prescription, catalog));
    const SequentialModel& model = *r.model;
    r.firstOrder = computeFirstOrder(model);
    if (r.prescription.firstAnamorphic() >= 0)
        r.xSection = computeXSectionFirstOrder(model, r.firstOrder.primaryData(), catalog);
    const RayAimer aimer(model, aim);
    r.aim = aimer.mode();
    r.rings = rings;
    SpotOptions spotOptions;
    spotOptions.rings = rings;
    spotOptions.aim = aimer.mode();
    for (int f = 0; f < static_cast<int>(r.prescription.system.fields.size()); ++f)
        for (int w = 0; w < model.wavelengthCount(); ++w)
            r.spots.push_back(computeSpot(model, aimer, f, w, spotOptions));
    return r;
}

nlohmann::json InfoReport::json() const {
    const bool angle = prescription.system.fieldKind == SystemData::FieldKind::AngleDeg;
    nlohmann::json j = firstOrderJson(firstOrder.primaryData());
    j["file"] = file;
    j["name"] = prescription.system.name;
    j["primary_wavelength_nm"] = model->wavelengthNm(model->primaryWavelength());
    j["wavelengths"] = nlohmann::json::array();
    for (const FirstOrderData& d : firstOrder.wavelengths)
        j["wavelengths"].push_back(firstOrderJson(d));
    if (xSection) j["x_section"] = firstOrderJson(*xSection);
    j["field_unit"] = angle ? "deg" : "mm";
    if (!prescription.system.imageHeights.empty()) {
        j["fields_given_as"] =
            prescription.system.givenFieldKind == SystemData::FieldKind::RealImageHeightMm
                ? "real_image_height_mm"
                : "paraxial_image_height_mm";
        j["image_heights_mm"] = nlohmann::json::array();
        for (const Field& f : prescription.system.imageHeights)
            j["image_heights_mm"].push_back({{"x", f.x}, {"y", f.y}});
    }
    j["fields"] = nlohmann::json::array();
    for (const Field& f : prescription.system.fields)
        j["fields"].push_back({{"x", f.x}, {"y", f.y}, {"weight", f.weight}});
    j["surfaces"] = nlohmann::json::array();
    for (const Surface& s : prescription.surfaces) {
        nlohmann::json js{{"name", s.name},
                          {"radius_mm", jsonNumber(s.radiusMm())},
                          {"thickness_mm", jsonNumber(s.thicknessMm)},
                          {"material", s.material.label()},
                          {"conic", s.conic},
                          {"clear_semi_diameter_mm", s.clearSemiDiameterMm},
                          {"mech_semi_diameter_mm", s.mechSemiDiameterMm},
                          {"stop", s.stop},
                          {"mirror", s.mirror}};
        if (!s.coating.empty()) js["coating"] = s.coating;
        if (s.innerSemiDiameterMm > 0.0) js["hole_semi_diameter_mm"] = s.innerSemiDiameterMm;
        if (const auto& b = s.coordinateBreak)
            js["coordinate_break"] = {{"decenter_mm", {b->decenterXMm, b->decenterYMm}},
                                      {"tilt_deg", {b->tiltXDeg, b->tiltYDeg, b->tiltZDeg}},
                                      {"tilt_first", b->tiltFirst}};
        if (const auto& q = s.qAsphere)
            js[q->kind == QAsphere::Kind::Bfs ? "qbfs" : "qcon"] = {
                {"norm_radius_mm", q->normRadiusMm}, {"terms", q->terms}};
        if (const auto& a = s.anamorphic) {
            const double xr = a->xCurvature == 0.0 ? kInfinity : 1.0 / a->xCurvature;
            js[a->label()] = {{"x_radius_mm", jsonNumber(xr)}};
            if (a->kind == Anamorphic::Kind::Biconic) js[a->label()]["x_conic"] = a->xConic;
        }
        j["surfaces"].push_back(js);
    }
    j["elements"] = nlohmann::json::array();
    for (const Element& e : prescription.elements())
        j["elements"].push_back({{"name", e.name},
                                 {"front", prescription.surfaces[e.frontSurface].name},
                                 {"back", prescription.surfaces[e.backSurface].name},
                                 {"material", e.material.label()}});
    if (build) {
        nlohmann::json b{{"built", build->built},     {"elements", build->elements},
                         {"objects", build->objects}, {"mechanical_parts", build->mechanicalParts},
                         {"notes", build->notes},     {"size_changes", nlohmann::json::array()}};
        if (!build->built) b["error"] = build->error;
        for (const LensSizeChange& c : build->sizeChanges) {
            nlohmann::json faces = nlohmann::json::array();
            for (const LensSizeChange::Face& f : c.faces)
                faces.push_back({{"name", f.name},
                                 {"clear_semi_diameter_mm_file", f.clearBeforeMm},
                                 {"clear_semi_diameter_mm", f.clearAfterMm}});
            b["size_changes"].push_back({{"element", c.element},
                                         {"faces", faces},
                                         {"outer_radius_mm_file", c.radiusBeforeMm},
                                         {"outer_radius_mm", c.radiusAfterMm},
                                         {"reason", c.reason}});
        }
        j["scene_build"] = b;
    }
    j["spots"] = nlohmann::json::array();
    auto landed = [](const SpotResult& s, double v) {
        return s.raysLanded > 0 ? jsonNumber(v) : nlohmann::json();
    };
    for (const SpotResult& s : spots)
        j["spots"].push_back({{"field", s.field},
                              {"wavelength_nm", model->wavelengthNm(s.wavelength)},
                              {"rays_traced", s.raysTraced},
                              {"rays_landed", s.raysLanded},
                              // null where no ray landed or the value overflowed
                              {"centroid_x_mm", landed(s, s.centroidMm.x)},
                              {"centroid_y_mm", landed(s, s.centroidMm.y)},
                              {"rms_radius_mm", landed(s, s.rmsRadiusMm)},
                              {"rms_radius_chief_mm", landed(s, s.rmsRadiusChiefMm)}});
    j["import_report"] = nlohmann::json::array();
    for (const ImportNote& n : prescription.report)
        j["import_report"].push_back({{"severity", severityName(n.severity)},
                                      {"file", n.loc.file},
                                      {"line", n.loc.line},
                                      {"column", n.loc.column},
                                      {"message", n.message}});
    return j;
}

std::string InfoReport::text() const {
    const bool angle = prescription.system.fieldKind == SystemData::FieldKind::AngleDeg;
    std::ostringstream os;
    os << (prescription.system.name.empty() ? file : prescription.system.name) << "\n";
    if (!prescription.system.notes.empty()) os << "  " << prescription.system.notes << "\n";
    os << "\nSurfaces\n";
    os << "  " << std::left << std::setw(4) << "#" << std::setw(12) << "name" << std::right
       << std::setw(13) << "radius" << std::setw(12) << "thickness"
       << "  " << std::left << std::setw(22) << "material" << std::right << std::setw(9) << "sd"
       << "\n";
    for (size_t i = 0; i < prescription.surfaces.size(); ++i) {
        const Surface& s = prescription.surfaces[i];
        std::string flags;
        if (s.stop) flags += " STOP";
        if (s.mirror) flags += " MIRROR";
        if (s.innerSemiDiameterMm > 0.0) flags += " hole=" + fmt(s.innerSemiDiameterMm, 5);
        if (s.conic != 0.0) flags += " k=" + fmt(s.conic);
        if (s.qAsphere)
            flags += s.qAsphere->kind == QAsphere::Kind::Bfs ? " Qbfs" : " Qcon";
        else if (s.hasAsphere())
            flags += " asphere";
        if (const auto& a = s.anamorphic) {
            flags += a->kind == Anamorphic::Kind::Toroidal ? " TOROIDAL" : " BICONIC";
            flags += " x_r=" + fmt(a->xCurvature == 0.0 ? kInfinity : 1.0 / a->xCurvature, 8);
            if (a->xConic != 0.0) flags += " x_k=" + fmt(a->xConic);
        }
        if (const auto& b = s.coordinateBreak) {
            flags += " BREAK";
            if (b->decenterXMm != 0.0 || b->decenterYMm != 0.0)
                flags += " decenter " + fmt(b->decenterXMm) + ", " + fmt(b->decenterYMm) + " mm";
            if (b->tiltXDeg != 0.0 || b->tiltYDeg != 0.0 || b->tiltZDeg != 0.0)
                flags += " tilt " + fmt(b->tiltXDeg) + ", " + fmt(b->tiltYDeg) + ", " +
                         fmt(b->tiltZDeg) + " deg";
            if (b->tiltFirst) flags += " (tilt first)";
        }
        os << "  " << std::left << std::setw(4) << i << std::setw(12) << s.name << std::right
           << std::setw(13) << fmt(s.radiusMm(), 8) << std::setw(12) << fmt(s.thicknessMm, 7)
           << "  " << std::left << std::setw(22) << s.material.label() << std::right << std::setw(9)
           << fmt(s.clearSemiDiameterMm, 5) << flags << "\n";
    }
    const FirstOrderData& d = firstOrder.primaryData();
    os << "\nFirst-order data at " << fmt(d.wavelengthNm) << " nm (primary)\n";
    if (std::any_of(prescription.surfaces.begin(), prescription.surfaces.end(), [](const Surface& s) {
            return s.coordinateBreak && !s.coordinateBreak->identity();
        }))
        os << "  of the unfolded system: paraxial data ignore coordinate breaks\n";
    if (xSection) os << "  of the y-z section (anamorphic surfaces: the x-z section follows)\n";
    // An afocal system has its focal points and principal planes at infinity: n/a, said why.
    auto row = [&](const char* label, double v, const char* unit) {
        os << "  " << std::left << std::setw(40) << label << std::right << std::setw(14)
           << (std::isfinite(v) ? fmt(v, 8) + " " + unit : "n/a (at infinity: afocal)") << "\n";
    };
    row("effective focal length", d.eflMm, "mm");
    row("back focal length (from last surface)", d.bflMm, "mm");
    row("front focal length (from surface 1)", d.fflMm, "mm");
    row("front principal plane (from surface 1)", d.frontPrincipalPlaneMm, "mm");
    row("rear principal plane (from image)", d.rearPrincipalPlaneMm, "mm");
    row("paraxial image (from image surface)", d.paraxialImageDistanceMm, "mm");
    row("entrance pupil position (from surface 1)", d.entrancePupilPositionMm, "mm");
    row("entrance pupil diameter", d.entrancePupilDiameterMm, "mm");
    row("exit pupil position (from image)", d.exitPupilPositionMm, "mm");
    row("exit pupil diameter", d.exitPupilDiameterMm, "mm");
    row("stop semi-diameter", d.stopSemiDiameterMm, "mm");
    row("image-space F/# (EFL/EPD)", d.imageSpaceFNumber, "");
    row("paraxial working F/#", d.workingFNumber, "");
    row("image-space NA", d.imageSpaceNA, "");
    row("total track (surface 1 to image)", d.totalTrackMm, "mm");
    row("Petzval radius", d.petzvalRadiusMm, "mm");
    for (size_t f = 0; f < d.paraxialImageHeightsMm.size(); ++f) {
        std::string label = "paraxial image height y, field " + std::to_string(f + 1) + " (" +
                            fmt(prescription.system.fields[f].y) + (angle ? " deg)" : " mm)");
        row(label.c_str(), d.paraxialImageHeightsMm[f], "mm");
    }
    if (xSection) {
        const FirstOrderData& x = *xSection;
        os << "\n  x-z section\n";
        row("effective focal length", x.eflMm, "mm");
        row("back focal length (from last surface)", x.bflMm, "mm");
        row("paraxial image (from image surface)", x.paraxialImageDistanceMm, "mm");
        row("entrance pupil position (from surface 1)", x.entrancePupilPositionMm, "mm");
        row("exit pupil position (from image)", x.exitPupilPositionMm, "mm");
        row("image-space F/# (EFL/EPD)", x.imageSpaceFNumber, "");
    }
    if (firstOrder.wavelengths.size() > 1) {
        os << "\n  " << std::setw(12) << "wavelength" << std::setw(14) << "EFL" << std::setw(14)
           << "BFL" << std::setw(14) << "EP diameter" << std::setw(12) << "F/#"
           << "\n";
        auto finite = [](double v, int prec) { return std::isfinite(v) ? fmt(v, prec) : "n/a"; };
        for (const FirstOrderData& x : firstOrder.wavelengths)
            os << "  " << std::setw(12) << fmt(x.wavelengthNm) << std::setw(14)
               << finite(x.eflMm, 8) << std::setw(14) << finite(x.bflMm, 8) << std::setw(14)
               << fmt(x.entrancePupilDiameterMm, 7) << std::setw(12)
               << finite(x.imageSpaceFNumber, 5) << "\n";
    }
    if (!prescription.system.imageHeights.empty()) {
        const bool realHeights = prescription.system.givenFieldKind == SystemData::FieldKind::RealImageHeightMm;
        os << "\nFields given as " << (realHeights ? "real" : "paraxial")
           << " image heights, resolved into " << (angle ? "field angles" : "object heights")
           << (realHeights ? " by aiming the real chief ray at them"
                           : " through the paraxial chief ray")
           << "\n";
        for (size_t f = 0; f < prescription.system.fields.size(); ++f) {
            const Field& h = prescription.system.imageHeights[f];
            const Field& o = prescription.system.fields[f];
            os << "  field " << f + 1 << ": (" << fmt(h.x) << ", " << fmt(h.y) << ") mm -> ("
               << fmt(o.x, 8) << ", " << fmt(o.y, 8) << ")" << (angle ? " deg" : " mm") << "\n";
        }
    }
    os << "\nSpots on the image surface (" << aim << " aiming, " << rings
       << " rings)\n";
    os << "  " << std::setw(16) << "field (x, y)" << std::setw(12) << "wavelength" << std::setw(10)
       << "rays" << std::setw(28) << "centroid (x, y) mm" << std::setw(16) << "RMS radius mm"
       << "\n";
    // A spot no ray reached, or one whose numbers overflowed (an image 1e300 mm away), has
    // no centroid or size to print: n/a, and why below the table.
    bool noRays = false, notFinite = false;
    auto cell = [&](const SpotResult& s, double v) -> std::string {
        if (s.raysLanded == 0) {
            noRays = true;
            return "n/a";
        }
        if (!std::isfinite(v)) {
            notFinite = true;
            return "n/a";
        }
        return fmtMm(v);
    };
    for (const SpotResult& s : spots) {
        const Field& f = prescription.system.fields[s.field];
        const std::string centroid = s.raysLanded == 0
                                         ? cell(s, 0.0)
                                         : cell(s, s.centroidMm.x) + ", " + cell(s, s.centroidMm.y);
        os << "  " << std::setw(16) << (fmt(f.x, 4) + ", " + fmt(f.y, 4)) << std::setw(12)
           << fmt(model->wavelengthNm(s.wavelength)) << std::setw(10)
           << (std::to_string(s.raysLanded) + "/" + std::to_string(s.raysTraced)) << std::setw(28)
           << centroid << std::setw(16) << cell(s, s.rmsRadiusMm) << "\n";
    }
    if (noRays)
        os << "  n/a: no ray of the bundle landed on the image surface (vignetted or missed)\n";
    if (notFinite) os << "  n/a: the value is beyond the range of double precision\n";
    if (build) {
        os << "\nScene build: ";
        if (build->built)
            os << "the lens builds (" << build->elements << " element(s), " << build->objects
               << " objects, " << build->mechanicalParts << " mechanical part(s))\n";
        else
            os << "FAILED: " << build->error << "\n";
        if (!build->sizeChanges.empty()) {
            os << "  Sized to fit: the file's sizes do not build; these elements were made "
                  "smaller\n"
               << "  element  face          clear sd (file -> built)   outer radius (file -> built)"
                  "   because the file's sizes gave\n";
            for (const LensSizeChange& c : build->sizeChanges) {
                for (size_t k = 0; k < c.faces.size(); ++k) {
                    const LensSizeChange::Face& f = c.faces[k];
                    std::ostringstream clear, radius;
                    clear << std::fixed << std::setprecision(3) << f.clearBeforeMm << " -> "
                          << f.clearAfterMm;
                    if (k == 0)
                        radius << std::fixed << std::setprecision(3) << c.radiusBeforeMm << " -> "
                               << c.radiusAfterMm;
                    os << "  " << std::left << std::setw(9) << (k == 0 ? c.element : "")
                       << std::setw(14) << f.name << std::setw(27) << clear.str() << std::setw(31)
                       << radius.str() << (k == 0 ? c.reason : "") << std::right << "\n";
                }
            }
        }
        for (const std::string& n : build->notes) os << "  " << n << "\n";
    }
    os << "\nImport report: ";
    if (prescription.report.empty()) {
        os << "nothing to report\n";
    } else {
        os << prescription.report.size() << " note(s)\n";
        for (const ImportNote& n : prescription.report) os << "  " << n << "\n";
    }
    return os.str();
}

}  // namespace veil
