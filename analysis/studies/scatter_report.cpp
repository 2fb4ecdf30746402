#include "analysis/studies/scatter_report.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "analysis/pictures/chart.h"
#include "analysis/reports/format.h"
#include "geometry/scene.h"
#include "lensdata/errors.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/surfaces/property_table.h"
#include "tracer/surfaces/scatter_tabulation.h"
#include "tracer/transport/interaction.h"

namespace veil {

namespace {

constexpr double kDeg = std::numbers::pi / 180.0;
constexpr double kAssumedIndex = 1.5;

bool hasTransmission(const OpticalProperty& p) {
    // Dust scatters into a substrate that takes light in: not through a mirror or an absorber.
    if (std::holds_alternative<ParticulateScatter>(p.scatter()))
        return !std::holds_alternative<MirrorSpecular>(p.specular()) &&
               !std::holds_alternative<AbsorberSpecular>(p.specular());
    const ScatterModel& m = p.scatter();
    return std::visit(
        [](const auto& s) -> bool {
            using T = std::decay_t<decltype(s)>;
            if constexpr (std::is_same_v<T, LambertianScatter>) return s.transmittance > 0.0;
            if constexpr (std::is_same_v<T, GaussianScatter>) return s.transmittance() > 0.0;
            if constexpr (std::is_same_v<T, AbgScatter>) return s.transmitLobe() != nullptr;
            if constexpr (std::is_same_v<T, KCorrelationScatter>) return s.transmits();
            if constexpr (std::is_same_v<T, TabulatedScatter>) return s.transmitLobe() != nullptr;
            return false;
        },
        m);
}

void addFileBlocks(const TabulatedLobe* lobe, ScatterPropertyReport& r) {
    if (!lobe) return;
    for (size_t k = 0; k < lobe->incidenceDeg().size(); ++k)
        r.fileBlocks.push_back({lobe->transmission(), lobe->incidenceDeg()[k], lobe->fileTis()[k],
                                lobe->tis(lobe->incidenceDeg()[k])});
}

}  // namespace

ScatterReport scatterReport(const PropertyTable& table, const Scene& scene,
                            const std::vector<int>& propertyOf, const SequentialModel& model,
                            const ScatterReportSpec& spec) {
    ScatterReport report;
    report.wavelengthsNm = spec.wavelengthsNm;
    if (report.wavelengthsNm.empty())
        for (int w = 0; w < model.wavelengthCount(); ++w)
            report.wavelengthsNm.push_back(model.wavelengthNm(w));
    report.incidencesDeg = spec.incidencesDeg;

    std::vector<int> chosen;
    for (const std::string& name : spec.properties) {
        const int p = table.find(name);
        if (p < 0) throw ModelError(name, "no property of this name in the scene or built in");
        if (!table.property(p).hasScatter())
            throw ModelError(name, "this property does not scatter (it has no `scatter` model)");
        if (std::find(chosen.begin(), chosen.end(), p) == chosen.end()) chosen.push_back(p);
    }
    if (spec.properties.empty())
        for (int id = 0; id < static_cast<int>(propertyOf.size()); ++id) {
            const int p = propertyOf[id];
            if (p >= 0 && table.property(p).hasScatter() &&
                std::find(chosen.begin(), chosen.end(), p) == chosen.end())
                chosen.push_back(p);
        }

    for (int p : chosen) {
        const OpticalProperty& prop = table.property(p);
        ScatterPropertyReport r;
        r.name = prop.name();
        std::ostringstream os;
        os << prop.scatter();
        r.model = os.str();
        // The carriers, and the densest medium next to a lens face among them.
        bool anyTransparent = false;
        std::vector<double> index(report.wavelengthsNm.size(), 0.0);
        for (int id = 0; id < static_cast<int>(propertyOf.size()); ++id) {
            if (propertyOf[id] != p) continue;
            const SceneObject& o = scene.object(id);
            r.objects.push_back(o.name);
            if (isOpaqueKind(o.kind)) continue;
            anyTransparent = true;
            const int s = o.sequentialSurface;
            if (s < 0) continue;
            for (size_t w = 0; w < index.size(); ++w) {
                // The model's wavelengths by position; a --wavelength outside them takes the
                // nearest.
                int mw = 0;
                for (int k = 1; k < model.wavelengthCount(); ++k)
                    if (std::abs(model.wavelengthNm(k) - report.wavelengthsNm[w]) <
                        std::abs(model.wavelengthNm(mw) - report.wavelengthsNm[w]))
                        mw = k;
                for (int gap : {s - 1, s})
                    if (gap >= 0 && gap + 1 < model.surfaceCount())
                        index[w] = std::max(index[w], std::abs(model.index(gap, mw)));
            }
        }
        r.opaqueOnly = !r.objects.empty() && !anyTransparent;
        r.indexAssumed = true;
        for (double& n : index) {
            if (n > 1.0) r.indexAssumed = false;
            if (!(n > 1.0)) n = kAssumedIndex;
        }
        r.transmitIndex = index;
        const bool transmits = hasTransmission(prop) && !r.opaqueOnly;
        for (double incidence : report.incidencesDeg) {
            std::vector<double> rr, tt;
            for (size_t w = 0; w < report.wavelengthsNm.size(); ++w) {
                const double nm = report.wavelengthsNm[w];
                rr.push_back(
                    prop.channels(incidenceContext(incidence, nm, 1.0, 1.0, true)).scatterReflect);
                if (transmits)
                    tt.push_back(
                        prop.channels(incidenceContext(incidence, nm, 1.0, index[w], false))
                            .scatterTransmit);
            }
            r.reflectTis.push_back(rr);
            if (transmits) r.transmitTis.push_back(tt);
        }
        if (const auto* t = std::get_if<TabulatedScatter>(&prop.scatter())) {
            addFileBlocks(t->reflectLobe(), r);
            addFileBlocks(t->transmitLobe(), r);
        }
        if (const auto* d = std::get_if<ParticulateScatter>(&prop.scatter()))
            for (const double nm : report.wavelengthsNm) {
                const auto e = d->at(nm, 1.0);
                r.notes.push_back("at " + significant(nm, 6) + " nm in air: extinction " +
                                  significant(e->extinction(), 4) + " and scatter " +
                                  significant(e->scattering(), 4) +
                                  " of cross section per area of surface (albedo " +
                                  significant(e->albedo(), 4) + "); the particles cover " +
                                  significant(100.0 * e->coverage(), 4) +
                                  " % of the surface (IEST-STD-CC1246's fit: " +
                                  significant(cc1246Pac(d->params().level), 4) + " %)");
            }
        report.properties.push_back(std::move(r));
    }
    return report;
}

std::string ScatterReport::markdown() const {
    std::ostringstream os;
    if (properties.empty()) {
        os << "No object of the scene carries a scattering property (give one with "
              "[properties.NAME] scatter = { ... } and [[assign]], or name one with "
              "--property).\n";
        return os.str();
    }
    os << "Total integrated scatter (TIS: the scattered fraction of the incident light) "
          "against incidence; reflection from air, transmission from air into the index "
          "given\n";
    for (const ScatterPropertyReport& r : properties) {
        os << "\n## " << r.name << "\n\n" << r.model << "\n\n";
        for (const std::string& note : r.notes) os << "- " << note << "\n";
        if (!r.notes.empty()) os << "\n";
        if (r.objects.empty()) {
            os << "Carried by no object of the scene.\n\n";
        } else {
            os << "Carried by " << r.objects.size() << " object"
               << (r.objects.size() == 1 ? "" : "s") << ": ";
            for (size_t i = 0; i < r.objects.size() && i < 8; ++i)
                os << (i ? ", " : "") << r.objects[i];
            if (r.objects.size() > 8) os << ", ...";
            os << (r.opaqueOnly ? " (all opaque: no transmission)" : "") << "\n\n";
        }
        os << tisTable(r).markdown();
        if (!r.fileBlocks.empty()) {
            os << "\nThe tables' blocks: the TIS each file states and the model's TIS at that "
                  "angle\n\n"
               << fileBlockTable(r).markdown();
        }
    }
    return os.str();
}

namespace {

ReportColumn right(const std::string& key, const std::string& heading) {
    ReportColumn c{key, heading};
    c.markdownRule = "---:";
    return c;
}

ReportCell shown(double v) {
    std::ostringstream os;
    os << std::setprecision(9) << v;
    return ReportCell::number(v, os.str(), significant(v, 4), significant(v, 4));
}

}  // namespace

ReportTable ScatterReport::tisTable(const ScatterPropertyReport& r) const {
    ReportTable table(std::vector<ReportColumn>{right("incidence_deg", "incidence (deg)")});
    for (double nm : wavelengthsNm)
        table.addColumn(right("reflect_" + significant(nm, 6), "R " + significant(nm, 6) + " nm"));
    if (!r.transmitTis.empty())
        for (size_t w = 0; w < wavelengthsNm.size(); ++w)
            table.addColumn(right("transmit_" + significant(wavelengthsNm[w], 6),
                                  "T " + significant(wavelengthsNm[w], 6) + " nm (n " +
                                      significant(r.transmitIndex[w], 5) +
                                      (r.indexAssumed ? ", assumed" : "") + ")"));
    for (size_t i = 0; i < incidencesDeg.size(); ++i) {
        std::vector<ReportCell> row{shown(incidencesDeg[i])};
        for (double v : r.reflectTis[i]) row.push_back(shown(v));
        if (!r.transmitTis.empty())
            for (double v : r.transmitTis[i]) row.push_back(shown(v));
        table.addRow(std::move(row));
    }
    return table;
}

ReportTable ScatterReport::fileBlockTable(const ScatterPropertyReport& r) const {
    ReportColumn table_{"table", "table"};
    ReportTable table(std::vector<ReportColumn>{table_, right("angle_deg", "angle (deg)"),
                                                right("file_tis", "file TIS"),
                                                right("model_tis", "model TIS"),
                                                right("model_over_file", "model / file")});
    for (const ScatterFileBlock& b : r.fileBlocks) {
        ReportCell ratio =
            ReportCell::text(b.fileTis > 0.0 ? significant(b.modelTis / b.fileTis, 4) : "-");
        ratio.withoutJson();
        table.addRow({ReportCell::text(b.transmission ? "BTDF" : "BRDF"), shown(b.angleDeg),
                      shown(b.fileTis), shown(b.modelTis), ratio});
    }
    return table;
}

ReportTable ScatterReport::tisRows() const {
    ReportTable table;
    for (const char* k : {"property", "channel", "incidence_deg", "wavelength_nm", "index", "tis"})
        table.addColumn({k, k});
    for (const ScatterPropertyReport& r : properties)
        for (size_t i = 0; i < incidencesDeg.size(); ++i)
            for (size_t w = 0; w < wavelengthsNm.size(); ++w) {
                table.addRow({ReportCell::text(r.name), ReportCell::text("reflect"),
                              shown(incidencesDeg[i]), shown(wavelengthsNm[w]),
                              ReportCell::count(1), shown(r.reflectTis[i][w])});
                if (!r.transmitTis.empty())
                    table.addRow({ReportCell::text(r.name), ReportCell::text("transmit"),
                                  shown(incidencesDeg[i]), shown(wavelengthsNm[w]),
                                  shown(r.transmitIndex[w]), shown(r.transmitTis[i][w])});
            }
    return table;
}

std::string ScatterReport::csv() const { return tisRows().csv(); }

std::string ScatterReport::json() const {
    nlohmann::json j;
    j["wavelengths_nm"] = wavelengthsNm;
    j["incidences_deg"] = incidencesDeg;
    ReportTable table;
    for (const char* k : {"name", "model", "objects", "opaque_only", "reflect_tis", "notes",
                          "transmit_tis", "transmit_index", "transmit_index_assumed",
                          "file_blocks"})
        table.addColumn({k});
    for (const ScatterPropertyReport& r : properties) {
        auto value = [](nlohmann::json v, bool present = true) {
            ReportCell c;
            c.json = std::move(v);
            if (!present) c.withoutJson();
            return c;
        };
        const bool transmit = !r.transmitTis.empty();
        table.addRow({value(r.name), value(r.model), value(r.objects), value(r.opaqueOnly),
                      value(r.reflectTis), value(r.notes, !r.notes.empty()),
                      value(r.transmitTis, transmit), value(r.transmitIndex, transmit),
                      value(r.indexAssumed, transmit),
                      value(fileBlockTable(r).json(), !r.fileBlocks.empty())});
    }
    j["properties"] = table.json();
    return j.dump(2) + "\n";
}

namespace {

// A 0.25 degree grid of scatter angles in the plane of incidence, and points crowding toward
// the specular direction for narrow lobes.
std::vector<double> planeAngles(double specularDeg) {
    std::vector<double> angles;
    for (double a = -89.75; a <= 89.76; a += 0.25) angles.push_back(a);
    for (int k = 0; k < 40; ++k) {
        const double d = std::pow(10.0, -3.0 + 3.0 * k / 39.0) * 0.25;
        for (double a : {specularDeg - d, specularDeg + d})
            if (std::abs(a) < 89.9) angles.push_back(a);
    }
    angles.push_back(specularDeg);
    std::sort(angles.begin(), angles.end());
    return angles;
}

}  // namespace

Picture drawBrdfComparison(const std::vector<const OpticalProperty*>& properties,
                           double wavelengthNm, double incidenceDeg) {
    ChartSpec spec;
    spec.title = "BRDF in the plane of incidence at " + significant(incidenceDeg, 4) +
                 " deg incidence, " + significant(wavelengthNm, 6) + " nm";
    spec.xLabel = "scatter angle from the normal (deg; positive on the specular side)";
    spec.yLabel = "BRDF (1/sr)";
    spec.logY = true;
    const SurfaceContext c = incidenceContext(incidenceDeg, wavelengthNm, 1.0, 1.0, true);
    for (const OpticalProperty* p : properties) {
        ChartSeries s;
        s.label = p->name();
        s.markers = false;
        for (double a : planeAngles(incidenceDeg)) {
            const double t = a * kDeg;
            s.x.push_back(a);
            s.y.push_back(p->bsdf(c, Vec3(std::sin(t), 0.0, std::cos(t))));
        }
        spec.series.push_back(std::move(s));
    }
    return drawChart(spec);
}

Picture drawBsdfChart(const OpticalProperty& property, bool transmit, double wavelengthNm,
                      double n2, const std::vector<double>& incidencesDeg) {
    ChartSpec spec;
    spec.title = property.name() + ": " + (transmit ? "BTDF" : "BRDF") + " in the plane of " +
                 "incidence at " + significant(wavelengthNm, 6) + " nm" +
                 (transmit ? " into n = " + significant(n2, 5) : std::string());
    spec.xLabel = std::string("scatter angle from the ") + (transmit ? "inward normal" : "normal") +
                  " (deg; positive on the specular side)";
    spec.yLabel = std::string(transmit ? "BTDF" : "BRDF") + " (1/sr)";
    spec.logY = true;
    for (double incidence : incidencesDeg) {
        const SurfaceContext c =
            incidenceContext(incidence, wavelengthNm, 1.0, transmit ? n2 : 1.0, !transmit);
        double specularDeg = incidence;
        if (transmit) specularDeg = std::asin(std::sin(incidence * kDeg) / n2) / kDeg;
        const std::vector<double> angles = planeAngles(specularDeg);
        ChartSeries s;
        s.label = significant(incidence, 4) + " deg incidence";
        s.markers = false;
        for (double a : angles) {
            const double t = a * kDeg;
            const Vec3 out(std::sin(t), 0.0, transmit ? -std::cos(t) : std::cos(t));
            s.x.push_back(a);
            s.y.push_back(property.bsdf(c, out));
        }
        spec.series.push_back(std::move(s));
    }
    return drawChart(spec);
}

Picture drawTisChart(const ScatterReport& report, int w) {
    ChartSpec spec;
    spec.title = "Total integrated scatter at " + significant(report.wavelengthsNm[w], 6) + " nm";
    spec.xLabel = "incidence (deg)";
    spec.yLabel = "TIS";
    std::vector<double> all;
    for (const ScatterPropertyReport& r : report.properties) {
        ChartSeries s;
        s.label = r.name + (r.transmitTis.empty() ? "" : " R");
        for (size_t i = 0; i < report.incidencesDeg.size(); ++i) {
            s.x.push_back(report.incidencesDeg[i]);
            s.y.push_back(r.reflectTis[i][w]);
            all.push_back(r.reflectTis[i][w]);
        }
        spec.series.push_back(std::move(s));
        if (!r.transmitTis.empty()) {
            ChartSeries t;
            t.label = r.name + " T";
            t.dashed = true;
            for (size_t i = 0; i < report.incidencesDeg.size(); ++i) {
                t.x.push_back(report.incidencesDeg[i]);
                t.y.push_back(r.transmitTis[i][w]);
                all.push_back(r.transmitTis[i][w]);
            }
            spec.series.push_back(std::move(t));
        }
    }
    spec.logY = chooseLogAxis(all);
    return drawChart(spec);
}

}  // namespace veil
