#include "analysis/studies/pst.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analysis/ghosts/ghost_tracer.h"
#include "analysis/lens/default_scene.h"
#include "analysis/lens/first_order.h"
#include "analysis/pictures/chart.h"
#include "analysis/reports/format.h"
#include "analysis/runs/render_run.h"
#include "analysis/runs/stray_light_run.h"
#include "lensdata/glass_catalog.h"
#include "lensdata/output_file.h"
#include "tracer/records/detector.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_spec.h"

namespace veil {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const char* kNominal = "not fresnel and not scatter";
const char* kStray = "fresnel or scatter";


}  // namespace

namespace {

// Every option checked before anything is read or built.
void checkPstSpec(const PstSpec& spec) {
    if (spec.anglesDeg.empty()) throw ParseError({"--angles", 0, 0}, "no angle to trace");
    for (double a : spec.anglesDeg)
        if (!(a >= 0.0 && a < 90.0))
            throw ParseError({"--angles", 0, 0}, "an off-axis angle must be in [0, 90) degrees");
    if (!std::isfinite(spec.azimuthDeg))
        throw ParseError({"--azimuth", 0, 0}, "the azimuth must be a number of degrees");
    if (spec.batches < 2)
        throw ParseError({"--batches", 0, 0},
                         "PST needs at least 2 batches (render: passes) for its errors");
    if (!spec.render && spec.raysPerAngle < static_cast<uint64_t>(spec.batches))
        throw ParseError({"-n", 0, 0}, "fewer rays than batches");
    if (spec.render) {
        RenderOptions checked = spec.renderOptions;
        if (checked.initialRadiusMm <= 0.0) checked.initialRadiusMm = 1.0;  // set per scene
        try {
            checked.check();
        } catch (const std::invalid_argument& e) {
            throw ParseError({"--measure render", 0, 0}, e.what());
        }
    }
}

// A PST under way: the geometry built once, the beam and the pupil, and the steps that
// measure an angle and gather the rows (across ranks).
class PstRunner {
  public:
    PstRunner(const PstSpec& spec, const GlassCatalog& catalog);
    PstResult run();

  private:
    std::pair<double, double> fieldOf(double theta) const {
        return {theta * std::sin(phi_), theta * std::cos(phi_)};
    }
    void progress(size_t a, int batchesDone) const;
    // The quantities: the total, the nominal image and the stray light (trace) or the specular
    // and scattered light (render), the user's criteria, and the ghost estimate.
    void nameQuantities();
    PstRow measure(size_t a);
    // [quantity][batch]: flux on the first detector over the flux through the pupil.
    void renderShares(size_t a, double emitted, std::vector<std::vector<double>>& shares) const;
    void traceShares(size_t a, std::vector<std::vector<double>>& shares) const;
    // The sequential ghost estimate: exact for its model, no error.
    double ghostShare(double emitted) const;
    static void send(const Ranks& ranks, const PstRow& row);
    static PstRow receive(const Ranks& ranks, size_t a);

    const PstSpec& spec_;
    const GlassCatalog& catalog_;
    const double phi_;
    SceneSpec base_;
    std::unique_ptr<PreparedScene> prepared_;
    double throughPupil_ = 0.0;
    std::vector<std::string> where_;
    size_t ghostQuantity_ = 0;
    PstResult result_;
};

PstRunner::PstRunner(const PstSpec& spec, const GlassCatalog& catalog)
    : spec_(spec),
      catalog_(catalog),
      phi_(spec.azimuthDeg * M_PI / 180.0),
      base_(readSceneFile(spec.scene, catalog, spec.edits)) {
    if (base_.prescription.system.fieldKind != SystemData::FieldKind::AngleDeg)
        throw ModelError(spec.scene.string(),
                         "PST needs a lens with an object at infinity (fields in degrees)");
    SceneSpec first = base_;
    setFieldSources(first, catalog, {fieldOf(spec.anglesDeg.front())});
    prepared_ = PreparedScene::build(std::move(first), catalog);
    for (const Field& f : base_.prescription.system.fields)
        result_.fieldDeg = std::max(result_.fieldDeg, std::hypot(f.x, f.y));
    // The beam is uniform over the first surface's aperture disk (mech_sd, else sd) and
    // brings 1 W through it; the entrance pupil, a disk of the paraxial entrance pupil
    // diameter, takes (pupil / beam)^2 of that at any angle (collimated light crosses every
    // disk of the same radius alike, whatever its plane).
    const EntranceAperture ap = entranceAperture(base_.prescription, *base_.model);
    const FirstOrderData fo = computeFirstOrder(*base_.model, base_.model->primaryWavelength());
    result_.pupilRadiusMm = 0.5 * fo.entrancePupilDiameterMm;
    result_.beamRadiusMm = ap.radiusMm;
    if (!(result_.pupilRadiusMm > 0.0) || !(result_.beamRadiusMm >= result_.pupilRadiusMm))
        throw ModelError(spec.scene.string(),
                         "the beam over the first surface (radius " +
                             std::to_string(result_.beamRadiusMm) +
                             " mm) does not cover the entrance pupil (radius " +
                             std::to_string(result_.pupilRadiusMm) + " mm)");
    result_.apertureAreaMm2 = M_PI * result_.pupilRadiusMm * result_.pupilRadiusMm;
    throughPupil_ = std::pow(result_.pupilRadiusMm / result_.beamRadiusMm, 2);
    const DetectorGeometry& det = prepared_->geometry().detectors.front();
    result_.detector = det.name;
    result_.detectorAreaMm2 = det.widthMm * det.heightMm;
    nameQuantities();
}

void PstRunner::nameQuantities() {
    where_ = {kNominal, kStray};
    where_.insert(where_.end(), spec_.where.begin(), spec_.where.end());
    result_.measure = spec_.render ? "render" : "trace";
    if (spec_.render)
        result_.quantities = {{"total", ""},
                              {"specular", "render: visible (nominal image and ghosts)"},
                              {"scattered", "render: direct + caustic + secondary"}};
    else
        result_.quantities = {{"total", ""}, {"nominal", kNominal}, {"stray", kStray}};
    for (size_t k = 0; k < spec_.where.size(); ++k)
        result_.quantities.push_back({"where" + std::to_string(k + 1), spec_.where[k]});
    ghostQuantity_ = result_.quantities.size();
    result_.quantities.push_back({"ghost_estimate", "sequential, all two-reflection ghosts"});
}

void PstRunner::progress(size_t a, int batchesDone) const {
    if (!spec_.progress) return;
    std::ostringstream task;
    task << "pst: angle " << a + 1 << " of " << spec_.anglesDeg.size() << " ("
         << spec_.anglesDeg[a] << " deg)";
    spec_.progress({task.str(), static_cast<uint64_t>(batchesDone),
                    static_cast<uint64_t>(spec_.batches), "batches"});
}

void PstRunner::renderShares(size_t a, double emitted,
                             std::vector<std::vector<double>>& shares) const {
    RenderRunSpec run;
    run.options = spec_.renderOptions;
    run.options.seed = spec_.transport.seed;
    run.stop.passes = spec_.batches;
    run.detector = result_.detector;
    run.where = spec_.where;
    RenderRun(*prepared_, run).run([&](const RenderPassEvent& e) {
        const RenderPassTotals t = passTotals(*e.rendered);
        progress(a, e.pass);
        const double incident = emitted * throughPupil_;
        const double visible = t.components[static_cast<size_t>(RenderComponent::Visible)];
        std::vector<double> values = {t.total(), visible, t.total() - visible};
        values.insert(values.end(), t.criteria.begin(), t.criteria.end());
        for (size_t q = 0; q < ghostQuantity_; ++q) shares[q].push_back(values[q] / incident);
    });
}

void PstRunner::traceShares(size_t a, std::vector<std::vector<double>>& shares) const {
    StrayLightSpec run;
    run.raysPerSource = spec_.raysPerAngle;
    run.transport = spec_.transport;
    run.where = where_;
    runStrayLightBatches(*prepared_, run, spec_.batches, [&](int b, const StrayLightResult& r) {
        progress(a, b + 1);
        // The first detector's rows: its total, then the nominal image, the stray light, the
        // user's criteria, and the rest (not kept). Each over the flux the beam brings
        // through the entrance pupil.
        const std::vector<StrayLightRow> rows = r.report();
        const double incident = r.budget.emitted * throughPupil_;
        for (size_t q = 0; q < ghostQuantity_; ++q)
            shares[q].push_back(incident > 0.0 ? rows[q].flux / incident : 0.0);
    });
}

double PstRunner::ghostShare(double emitted) const {
    GhostOptions go;
    go.detector = result_.detector;
    const GhostAnalysis ghosts =
        GhostTracer(prepared_->geometry(), prepared_->transport(), catalog_, go).analyse();
    double ghostFlux = 0.0;
    for (const GhostEstimate& g : ghosts.ghosts) ghostFlux += g.flux();
    return ghostFlux / (emitted * throughPupil_);
}

PstRow PstRunner::measure(size_t a) {
    progress(a, 0);
    const double theta = spec_.anglesDeg[a];
    if (a > 0) {
        SceneSpec file = base_;
        setFieldSources(file, catalog_, {fieldOf(theta)});
        prepared_->replaceTransport(std::move(file), catalog_);
    }
    std::vector<std::vector<double>> shares(ghostQuantity_);
    const double emitted = prepared_->transport().view.sources.front().totalFlux();
    if (spec_.render)
        renderShares(a, emitted, shares);
    else
        traceShares(a, shares);
    PstRow row;
    row.angleDeg = theta;
    row.inField = theta <= result_.fieldDeg;
    for (const auto& s : shares) {
        const BatchMean m = batchMean(s);
        row.pst.push_back(m.value);
        row.error.push_back(m.error);
    }
    row.pst.push_back(ghostShare(emitted));
    row.error.push_back(0.0);
    return row;
}

void PstRunner::send(const Ranks& ranks, const PstRow& row) {
    ByteWriter out;
    out.put(row.angleDeg);
    out.put(uint8_t(row.inField));
    out.putVector(row.pst);
    out.putVector(row.error);
    ranks.send(0, out.take());
}

PstRow PstRunner::receive(const Ranks& ranks, size_t a) {
    const Bytes bytes = ranks.receive(static_cast<int>(a % ranks.size()));
    ByteReader in(bytes);
    PstRow row;
    row.angleDeg = in.get<double>();
    row.inField = in.get<uint8_t>() != 0;
    row.pst = in.getVector<double>();
    row.error = in.getVector<double>();
    if (!in.done()) throw std::runtime_error("a PST row from another rank is damaged");
    return row;
}

PstResult PstRunner::run() {
    // Across ranks angle a is measured on rank a mod K; rank 0 takes the rows in order (its
    // own as it measures them, the others' as they arrive).
    const Ranks& ranks = spec_.ranks;
    for (size_t a = 0; a < spec_.anglesDeg.size(); ++a) {
        if (ranks.owns(a)) {
            PstRow row = measure(a);
            if (ranks.root())
                result_.rows.push_back(std::move(row));
            else
                send(ranks, row);
        } else if (ranks.root()) {
            progress(a, 0);
            result_.rows.push_back(receive(ranks, a));
            progress(a, spec_.batches);
        }
    }
    return std::move(result_);
}

}  // namespace

PstResult runPst(const PstSpec& spec, const GlassCatalog& catalog) {
    checkPstSpec(spec);
    return PstRunner(spec, catalog).run();
}

ReportTable PstResult::table() const {
    ReportTable table(std::vector<ReportColumn>{{"angle_deg", "angle (deg)"}, {"in_field", "in field"}});
    for (const PstQuantity& q : quantities) {
        table.addColumn({"pst/" + q.name, "PST " + q.name, "pst_" + q.name});
        ReportColumn error{"error/" + q.name, "", "error_" + q.name};
        error.markdown = error.terminal = false;
        table.addColumn(error);
    }
    ReportColumn ratio{"irradiance_ratio_total"};
    ratio.markdown = ratio.terminal = ratio.json = false;
    table.addColumn(ratio);
    const double toIrradiance = detectorAreaMm2 > 0.0 ? apertureAreaMm2 / detectorAreaMm2 : kNaN;
    for (const PstRow& r : rows) {
        std::ostringstream angle;
        angle << r.angleDeg;
        std::vector<ReportCell> cells{ReportCell::number(r.angleDeg, angle.str(), angle.str(), angle.str()),
                                      ReportCell::flag(r.inField)};
        for (size_t q = 0; q < quantities.size(); ++q) {
            const double v = r.pst[q], e = r.error[q];
            std::string shown;
            if (v == 0.0 && !(e > 0.0))
                shown = "0";
            else if (e == 0.0)  // the sequential estimate
                shown = scientific(v, 3);
            else
                shown = scientific(v, 3) + " +- " + scientific(e, 2);
            cells.push_back(ReportCell::number(v, scientific(v, 6), shown, shown));
            cells.push_back(ReportCell::number(e, scientific(e, 3), "", ""));
        }
        const double irradiance = r.pst[0] * toIrradiance * std::cos(r.angleDeg * M_PI / 180.0);
        cells.push_back(ReportCell::number(irradiance, scientific(irradiance, 6), "", ""));
        table.addRow(std::move(cells));
    }
    return table;
}

std::string PstResult::csv() const { return table().csv(); }

std::string PstResult::markdown() const {
    std::ostringstream os;
    os << table().markdown();
    os << "\nPST = flux on " << detector
       << " / flux the collimated beam brings through the entrance pupil (radius " << pupilRadiusMm
       << " mm; the beam fills the first surface out to " << beamRadiusMm
       << " mm). The system's field reaches " << fieldDeg << " deg.\n";
    for (const PstQuantity& q : quantities)
        if (!q.criterion.empty()) os << "- " << q.name << ": `" << q.criterion << "`\n";
    return os.str();
}

std::string PstResult::json() const {
    nlohmann::json j;
    j["detector"] = detector;
    j["measure"] = measure;
    j["field_deg"] = fieldDeg;
    j["aperture_area_mm2"] = apertureAreaMm2;
    j["pupil_radius_mm"] = pupilRadiusMm;
    j["beam_radius_mm"] = beamRadiusMm;
    j["detector_area_mm2"] = detectorAreaMm2;
    j["quantities"] = nlohmann::json::array();
    for (const PstQuantity& q : quantities)
        j["quantities"].push_back({{"name", q.name}, {"criterion", q.criterion}});
    j["rows"] = table().json();
    return j.dump(2) + "\n";
}

std::vector<std::filesystem::path> writePst(const PstResult& r,
                                            const std::filesystem::path& folder) {
    std::filesystem::create_directories(folder);
    std::vector<std::filesystem::path> written;
    auto text = [&](const char* name, const std::string& body) {
        writeTextFile(folder / name, body);
        written.push_back(folder / name);
    };
    text("pst.csv", r.csv());
    text("pst.md", r.markdown());
    text("pst.json", r.json());
    ChartSpec chart;
    chart.title = "veil pst: point source transmittance on " + r.detector;
    chart.xLabel = "source angle off axis (deg)";
    chart.yLabel = "PST (detector flux / flux through the entrance pupil)";
    chart.logY = true;
    if (r.fieldDeg > 0.0) {
        std::ostringstream edge;
        edge << "field edge, " << r.fieldDeg << " deg";
        chart.xMarkers.push_back({r.fieldDeg, edge.str()});
    }
    for (size_t q = 0; q < r.quantities.size(); ++q) {
        ChartSeries s;
        s.label = r.quantities[q].name;
        if (!r.quantities[q].criterion.empty()) s.label += " (" + r.quantities[q].criterion + ")";
        s.dashed = q == 0;
        // The ghost estimate: points where it is above 0 (no error bars: it has none).
        const bool estimate = r.quantities[q].name == "ghost_estimate";
        for (const PstRow& row : r.rows) {
            s.x.push_back(row.angleDeg);
            s.y.push_back(row.pst[q]);
            s.yError.push_back(estimate ? 0.0 : row.error[q]);
        }
        chart.series.push_back(std::move(s));
    }
    try {
        const Picture pic = drawChart(chart);
        pic.writeSvg(folder / "pst.svg");
        pic.writePng(folder / "pst.png", 1600);
        written.push_back(folder / "pst.svg");
        written.push_back(folder / "pst.png");
    } catch (const std::invalid_argument&) {
        // Nothing reached the detector at any angle: the tables say so, there is no curve.
    }
    return written;
}

}  // namespace veil
