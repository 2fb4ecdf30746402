#include "analysis/ghosts/ghost_report.h"

#include <cmath>
#include <iomanip>
#include <numeric>
#include <sstream>

#include "analysis/reports/format.h"
#include "tracer/scene/scene_geometry.h"
#include "tracer/scene/scene_transport.h"

namespace veil {

namespace {


std::string sci(double v, int digits = 3) {
    if (!std::isfinite(v)) return "-";
    std::ostringstream os;
    os << std::scientific << std::setprecision(digits - 1) << v;
    return os.str();
}

// A number as a stream writes it by default (CSV).
std::string plain(double v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

// A CSV cell: empty when not finite (a ghost focused at infinity).
std::string csvNumber(double v) {
    if (!std::isfinite(v)) return "";
    std::ostringstream os;
    os << v;
    return os.str();
}

// Non-finite (a ghost focused at infinity: collimated) prints n/a.
std::string fix(double v, int digits = 3) {
    if (!std::isfinite(v)) return "n/a";
    std::ostringstream os;
    os << std::fixed << std::setprecision(digits) << v;
    return os.str();
}

// A Monte Carlo flux and its relative error; a flux of exactly zero (no ray) says so instead
// of an infinite error.
std::string mcText(double flux, double relativeError, const char* pm = " +-",
                   const char* percent = "%") {
    if (flux == 0.0) return "0 (no hits)";
    return sci(flux) + pm + (std::isfinite(relativeError) ? fix(100.0 * relativeError, 1) : "?") +
           percent;
}

// The source where the ghost's peak irradiance is highest.
const GhostSourceResult& worst(const GhostEstimate& g) {
    size_t best = 0;
    for (size_t s = 1; s < g.sources.size(); ++s)
        if (g.sources[s].peakIrradiance > g.sources[best].peakIrradiance) best = s;
    return g.sources[best];
}

}  // namespace

std::string GhostReportRow::flags() const {
    std::string f;
    if (nearFocus) f += "near-focus";
    if (!glassFocus.empty()) f += std::string(f.empty() ? "" : " ") + "focus-in-glass";
    if (!mcCheck.empty()) f += std::string(f.empty() ? "" : " ") + mcCheck;
    return f;
}

void checkAgainstMonteCarlo(GhostReport& r, size_t mechanicalParts) {
    std::vector<double> perHit;
    for (const GhostReportRow& g : r.rows)
        if (g.mcFlux > 0.0 && g.mcRelativeError > 0.0)
            perHit.push_back(g.mcFlux * g.mcRelativeError * g.mcRelativeError);
    double typicalHit = NAN;
    if (!perHit.empty()) {
        std::nth_element(perHit.begin(), perHit.begin() + perHit.size() / 2, perHit.end());
        typicalHit = perHit[perHit.size() / 2];
    }
    const bool mechanics = mechanicalParts > 0;
    r.mcFlagged = 0;
    r.mcNote.clear();
    for (GhostReportRow& g : r.rows) {
        g.mcZ = NAN;
        g.mcExpectedHits = NAN;
        g.mcCheck.clear();
        g.mcWhy.clear();
        if (g.mcFlux > 0.0 && g.mcRelativeError > 0.0) {
            g.mcZ = (g.mcFlux - g.flux) / (g.mcFlux * g.mcRelativeError);
            if (std::abs(g.mcZ) > kMcDisagreeSigma) g.mcCheck = "mc-disagrees";
        } else if (g.mcFlux == 0.0 && g.flux > 0.0 && typicalHit > 0.0) {
            g.mcExpectedHits = g.flux / typicalHit;
            if (g.mcExpectedHits >= kMcExpectedHits) g.mcCheck = "mc-none";
        }
        if (g.mcCheck.empty()) continue;
        ++r.mcFlagged;
        const bool less = g.mcCheck == "mc-none" || g.mcZ < 0.0;
        if (less && mechanics)
            g.mcWhy = "the Monte Carlo meets the mechanics (" + std::to_string(mechanicalParts) +
                      " parts), which the sequential estimate does not";
        else if (less)
            g.mcWhy = "the sequential estimate clips at the faces' apertures only";
        else
            g.mcWhy =
                "the Monte Carlo also counts other paths through the same surfaces "
                "(the criterion's)";
    }
    if (r.mcFlagged > 0)
        r.mcNote = std::to_string(r.mcFlagged) + " of " + std::to_string(r.rows.size()) +
                   " ghosts flagged where the Monte Carlo contradicts the sequential estimate "
                   "(mc-disagrees: beyond " +
                   fix(kMcDisagreeSigma, 0) + " of its sigmas; mc-none: no hit where " +
                   fix(kMcExpectedHits, 0) +
                   " or more were expected). The sequential estimate follows the ghost's "
                   "faces alone, clipped at their apertures; the Monte Carlo traces the whole "
                   "scene, mechanics included. Their rank is the sequential one";
}

GhostReport makeGhostReport(const GhostReportSpec& spec, const SceneGeometry& setup,
                            const SceneTransport& trace, const GhostAnalysis& a,
                            const GhostMonteCarlo* mc, int det) {
    GhostReport r;
    r.scene = spec.scene;
    r.lensName = setup.prescription.system.name;
    r.title = r.lensName.empty() ? spec.scene : r.lensName;
    r.defaultScene = spec.defaultScene;
    r.imageShiftMm = spec.imageShiftMm;
    r.order = spec.order;
    r.detector = a.detector;
    r.unit = trace.view.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
    r.ghostSurfaces = a.surfaceNames;
    r.ghostSurfaceCount = a.surfaces.size();
    r.pruned = a.pruned;
    r.gridRays = spec.gridRays;
    r.sequentialSeconds = a.seconds;
    r.coatingOverrides = spec.coatingOverrides;
    r.coatingChanges = spec.coatingChanges;
    for (const Source& s : trace.view.sources) r.sources.push_back(s.name());
    r.nominalFlux = a.nominal.flux();
    r.nominalPeak = a.nominal.peakIrradiance();
    r.allGhostsFlux =
        std::accumulate(a.ghosts.begin(), a.ghosts.end(), 0.0,
                        [](double f, const GhostEstimate& g) { return f + g.flux(); });
    r.haveMc = mc && mc->images;
    const size_t all = a.ghosts.size() + 1;  // the all-ghosts layer
    if (r.haveMc) {
        r.mcNominalFlux = mc->flux(0, det);
        r.mcNominalError = mc->relativeError(0, det);
        r.mcAllGhostsFlux = mc->flux(all, det);
        r.mcAllGhostsError = mc->relativeError(all, det);
        r.mcRaysPerSource = spec.mcRaysPerSource;
        r.mcEmittedRays = mc->emittedRays;
        r.mcSegments = mc->budget.segments;
        r.mcSeconds = mc->seconds;
    }
    r.seed = spec.seed;
    for (size_t k = 0; k < a.ghosts.size(); ++k) {
        const GhostEstimate& g = a.ghosts[k];
        const GhostSourceResult& w = worst(g);
        GhostReportRow row;
        row.rank = k + 1;
        row.label = g.path.label;
        row.surfaces = g.path.names;
        row.criterion = g.path.criterion;
        row.flux = g.flux();
        row.relativeFlux = g.relativeFlux();
        row.peakIrradiance = g.peakIrradiance();
        row.relativeIrradiance = g.relativeIrradiance();
        row.source = w.source;
        row.nearFocus = w.nearFocus;
        row.glassFocus = w.glassFocus;
        row.focusMm = w.focusMm;
        row.footprintMm = w.footprintMm;
        row.perSource = g.sources;
        row.mcFlux = r.haveMc ? mc->flux(k + 1, det) : NAN;
        row.mcRelativeFlux = r.haveMc && r.mcNominalFlux > 0 ? row.mcFlux / r.mcNominalFlux : NAN;
        row.mcRelativeError = r.haveMc ? mc->relativeError(k + 1, det) : NAN;
        if (auto it = spec.baseline.find(g.path.label); it != spec.baseline.end()) {
            row.baselineRank = it->second.first;
            row.baselineRelativeFlux = it->second.second;
        }
        r.rows.push_back(std::move(row));
    }
    if (r.haveMc) checkAgainstMonteCarlo(r, setup.mechanicalParts.size());
    return r;
}

nlohmann::json GhostReport::json() const {
    nlohmann::json j;
    j["scene"] = scene;
    j["lens"] = lensName;
    j["default_scene"] = defaultScene;
    j["image_shift_mm"] = imageShiftMm;
    j["order"] = order;
    j["detector"] = detector;
    j["unit"] = unit;
    j["ghost_surfaces"] = ghostSurfaces;
    j["ghost_count"] = rows.size();
    j["pruned_fourth_order"] = pruned;
    j["grid_rays"] = gridRays;
    j["sequential_seconds"] = sequentialSeconds;
    j["coating_overrides"] = coatingOverrides;
    j["coating_changes"] = coatingChanges;
    j["sources"] = sources;
    j["nominal"] = {{"flux", nominalFlux},
                    {"mc_flux", haveMc ? jsonNumber(mcNominalFlux) : nlohmann::json()},
                    {"mc_relative_error", haveMc ? jsonNumber(mcNominalError) : nlohmann::json()}};
    j["all_ghosts"] = {{"flux", allGhostsFlux}};
    if (haveMc) {
        j["all_ghosts"]["mc_flux"] = mcAllGhostsFlux;
        j["all_ghosts"]["mc_relative_error"] = jsonNumber(mcAllGhostsError);
        j["mc_flagged"] = mcFlagged;
        j["mc_note"] = mcNote;
        j["monte_carlo"] = {{"rays_per_source", mcRaysPerSource},
                            {"emitted_rays", mcEmittedRays},
                            {"seed", seed},
                            {"seconds", mcSeconds},
                            {"segments", mcSegments}};
    }
    j["ghosts"] = table().json();
    return j;
}

ReportTable GhostReport::table() const {
    ReportTable table;
    // key, Markdown heading, CSV header (empty: the key), terminal heading and layout.
    auto column = [&](std::string key, std::string heading, std::string csvHeader,
                      std::string terminalHeading, int width, Align align = Align::Right,
                      std::string gap = "") {
        ReportColumn c{std::move(key), std::move(heading), std::move(csvHeader)};
        c.terminalHeading = std::move(terminalHeading);
        c.width = width;
        c.align = align;
        c.gap = std::move(gap);
        c.json = c.key != "flags";  // flags is text made of near_focus and focus_in_glass
        table.addColumn(std::move(c));
    };
    column("rank", "rank", "", "", 5, Align::Left);
    column("ghost", "ghost", "", "", 30, Align::Left);
    column("flux", "flux (" + unit + ")", "flux_" + unit, "flux " + unit, 11);
    column("relative_flux", "flux / nominal", "", "flux/nom", 10);
    column("mc_flux", "Monte Carlo (" + unit + ")", "mc_flux_" + unit, "Monte Carlo", 20);
    column("mc_relative_flux", "", "", "", 0);
    column("mc_relative_error", "", "", "", 0);
    column("mc_z", "", "", "", 0);
    column("mc_expected_hits", "", "", "", 0);
    column("mc_check", "", "", "", 0);
    column("mc_why", "", "", "", 0);
    column("focus_mm", "focus - detector (mm)", "", "focus mm", 10);
    column("footprint_mm", "footprint (mm)", "", "foot mm", 9);
    column("peak_irradiance", "peak irradiance (" + unit + "/mm²)",
           "peak_irradiance_" + unit + "_per_mm2", "peak/mm2", 11);
    column("relative_irradiance", "peak / nominal peak", "", "", 0);
    column("near_focus", "", "", "", 0);
    column("focus_in_glass", "", "", "", 0);
    column("flags", "flags", "", "", 0, Align::Left, "  ");
    column("baseline_rank", "was", "", "(was)", 0, Align::Left, "  ");
    column("baseline_relative_flux", "", "", "", 0);
    column("criterion", "", "", "", 0);
    column("source", "source", "", "", 8, Align::Left, "  ");
    column("surfaces", "", "", "", 0);
    column("per_source", "", "", "", 0);
    for (const GhostReportRow& g : rows) {
        ReportCell rank = ReportCell::count(static_cast<long long>(g.rank));
        ReportCell ghost = ReportCell::text(g.label, true);
        ReportCell flux = ReportCell::number(g.flux, plain(g.flux), sci(g.flux), sci(g.flux));
        const std::string relFlux = nominalFlux > 0 ? sci(g.relativeFlux) : "-";
        ReportCell relativeFlux =
            ReportCell::number(g.relativeFlux, plain(g.relativeFlux), relFlux, relFlux);
        ReportCell mc = ReportCell::number(
            g.mcFlux, haveMc ? sci(g.mcFlux, 6) : "",
            haveMc ? mcText(g.mcFlux, g.mcRelativeError, " ± ", " %") : "-",
            haveMc ? mcText(g.mcFlux, g.mcRelativeError) : "-");
        ReportCell mcRel = ReportCell::number(g.mcRelativeFlux, haveMc ? sci(g.mcRelativeFlux, 6) : "", "", "");
        ReportCell mcErr = ReportCell::number(g.mcRelativeError, haveMc ? sci(g.mcRelativeError, 3) : "", "", "");
        ReportCell mcZ = ReportCell::number(g.mcZ, haveMc ? csvNumber(g.mcZ) : "", "", "");
        ReportCell mcExpected =
            ReportCell::number(g.mcExpectedHits, haveMc ? csvNumber(g.mcExpectedHits) : "", "", "");
        ReportCell mcCheck = ReportCell::text(g.mcCheck, true);
        ReportCell mcWhy = ReportCell::text(g.mcWhy, true);
        mcZ.json = jsonNumber(g.mcZ);
        mcExpected.json = jsonNumber(g.mcExpectedHits);
        if (!haveMc) {
            mc.withoutJson();
            mcRel.withoutJson();
            mcErr.withoutJson();
            mcZ.withoutJson();
            mcExpected.withoutJson();
            mcCheck.withoutJson();
            mcWhy.withoutJson();
        }
        ReportCell focus = ReportCell::number(g.focusMm, csvNumber(g.focusMm), fix(g.focusMm, 2),
                                              fix(g.focusMm, 1));
        focus.withoutJson();
        ReportCell footprint = ReportCell::number(g.footprintMm, csvNumber(g.footprintMm),
                                                  fix(g.footprintMm, 3), fix(g.footprintMm, 2));
        footprint.withoutJson();
        ReportCell peak = ReportCell::number(g.peakIrradiance, plain(g.peakIrradiance),
                                             sci(g.peakIrradiance), sci(g.peakIrradiance));
        const std::string relPeak = nominalPeak > 0 ? sci(g.relativeIrradiance) : "-";
        ReportCell relativePeak = ReportCell::number(
            g.relativeIrradiance, plain(g.relativeIrradiance), relPeak, relPeak);
        ReportCell nearFocus = ReportCell::flag(g.nearFocus, "1", "0");
        ReportCell glass = ReportCell::text(g.glassFocus, true);
        ReportCell flags = ReportCell::text(g.flags());
        flags.markdown += g.glassFocus.empty() ? "" : " (" + g.glassFocus + ")";
        ReportCell baseline = ReportCell::count(g.baselineRank);
        baseline.csv = g.baselineRank > 0 ? std::to_string(g.baselineRank) : "";
        baseline.markdown = g.baselineRank > 0 ? std::to_string(g.baselineRank) : "-";
        baseline.terminal = g.baselineRank > 0 ? "(" + std::to_string(g.baselineRank) + ")" : "";
        ReportCell baselineFlux = ReportCell::number(g.baselineRelativeFlux, "", "", "");
        if (g.baselineRank <= 0) {
            baseline.withoutJson();
            baselineFlux.withoutJson();
        }
        ReportCell criterion = ReportCell::text(g.criterion, true);
        ReportCell source = ReportCell::text(g.source, true);
        ReportCell surfaces = ReportCell::text("");
        surfaces.json = g.surfaces;
        ReportCell perSource = ReportCell::text("");
        perSource.json = nlohmann::json::array();
        for (const GhostSourceResult& s : g.perSource)
            perSource.json.push_back({{"source", s.source},
                                      {"flux", s.flux},
                                      {"relative_flux", s.relativeFlux},
                                      {"focus_mm", jsonNumber(s.focusMm)},
                                      {"footprint_mm", s.footprintMm},
                                      {"centroid_mm", {s.centroidMm.x, s.centroidMm.y}},
                                      {"peak_irradiance", s.peakIrradiance},
                                      {"relative_irradiance", s.relativeIrradiance},
                                      {"near_focus", s.nearFocus},
                                      {"focus_in_glass", s.glassFocus},
                                      {"rays_traced", s.raysTraced},
                                      {"rays_arrived", s.raysArrived}});
        table.addRow({rank,      ghost,        flux,         relativeFlux, mc,       mcRel,
                      mcErr,     mcZ,          mcExpected,   mcCheck,      mcWhy,    focus,
                      footprint, peak,         relativePeak, nearFocus,    glass,    flags,
                      baseline,  baselineFlux, criterion,    source,       surfaces, perSource});
    }
    return table;
}

std::string GhostReport::csv() const {
    return table().csv({"rank", "ghost", "flux", "relative_flux", "mc_flux", "mc_relative_flux",
                        "mc_relative_error", "focus_mm", "footprint_mm", "peak_irradiance",
                        "relative_irradiance", "near_focus", "focus_in_glass", "baseline_rank",
                        "criterion", "source"});
}

std::string GhostReport::markdown() const {
    std::ostringstream md;
    md << "# Ghosts of " << title << "\n\n"
       << rows.size() << " " << (order == 2 ? "two" : "two- and four") << "-reflection ghosts of "
       << ghostSurfaceCount << " ghost surfaces on detector " << detector << "; sources:";
    for (const std::string& s : sources) md << " " << s;
    md << ". Sequential grid " << gridRays << " rays across each beam";
    if (haveMc) md << "; Monte Carlo " << mcRaysPerSource << " rays per source, seed " << seed;
    md << ".\n\n";
    const bool several = sources.size() > 1;
    if (several)
        md << "Flux and Monte Carlo columns sum all " << sources.size()
           << " sources; focus, footprint, peak irradiance and flags are those of the source "
              "named in the last column, where the ghost's peak irradiance is highest.\n\n";
    if (!coatingChanges.empty()) {
        md << "Coating what-if (" << coatingChanges.size() << " objects changed):\n\n";
        for (const std::string& c : coatingChanges) md << "- " << c << "\n";
        md << "\n";
    }
    std::vector<std::string> columns{"rank",          "ghost",           "flux",
                                     "mc_flux",       "relative_flux",   "focus_mm",
                                     "footprint_mm",  "peak_irradiance", "relative_irradiance",
                                     "flags"};
    if (!coatingChanges.empty()) columns.push_back("baseline_rank");
    if (several) columns.push_back("source");
    md << table().markdown(columns);
    if (!mcNote.empty()) {
        md << "\n" << mcNote << ":\n\n";
        for (const GhostReportRow& g : rows)
            if (!g.mcCheck.empty())
                md << "- " << g.rank << ". " << g.label << ": " << g.mcCheck
                   << (std::isfinite(g.mcZ) ? " (z " + fix(g.mcZ, 1) + ")" : "") << "; " << g.mcWhy
                   << "\n";
    }
    md << "\nCriteria (docs/criteria.md) of the ranked ghosts, usable with veil trace --where and "
          "veil paths --where:\n\n";
    for (const GhostReportRow& g : rows) md << g.rank << ". `" << g.criterion << "`\n";
    return md.str();
}

std::string GhostReport::terminal(size_t topRows, const std::string& footer) const {
    std::ostringstream out;
    out << "Ghosts of " << title
        << (defaultScene ? " (default scene: collimated sources at the system fields, "
                           "detector at the paraxial image plane, " +
                               fix(imageShiftMm, 3) + " mm from the file's image surface)"
                         : "")
        << "\n  " << ghostSurfaceCount << " ghost surfaces, " << rows.size() << " ghosts"
        << (pruned
                ? " (" + std::to_string(pruned) + " four-reflection paths below the energy bound)"
                : "")
        << " on detector " << detector << "; sequential estimate " << fix(sequentialSeconds, 3)
        << " s";
    if (haveMc)
        out << "; Monte Carlo " << mcEmittedRays << " rays in " << fix(mcSeconds, 1) << " s";
    out << "\n  nominal image " << sci(nominalFlux) << " " << unit;
    if (haveMc) out << " (Monte Carlo " << mcText(mcNominalFlux, mcNominalError) << ")";
    out << "; all ghosts " << sci(allGhostsFlux) << " " << unit;
    if (haveMc) out << " (Monte Carlo " << mcText(mcAllGhostsFlux, mcAllGhostsError) << ")";
    out << "\n";
    for (const std::string& c : coatingChanges) out << "  coating what-if: " << c << "\n";
    const bool several = sources.size() > 1;
    if (several)
        out << "  flux sums all " << sources.size()
            << " sources; focus, footprint, peak and flags are of the source where the ghost "
               "peaks (source column)\n";
    std::vector<std::string> columns{"rank",    "ghost",         "flux",
                                     "mc_flux", "relative_flux", "focus_mm",
                                     "footprint_mm", "peak_irradiance"};
    if (several) columns.push_back("source");
    columns.push_back("flags");
    if (!coatingChanges.empty()) columns.push_back("baseline_rank");
    out << "\n" << table().terminal(topRows, columns);
    if (!mcNote.empty()) out << "  " << mcNote << "\n";
    out << footer;
    return out.str();
}

}  // namespace veil
