#include "analysis/ghosts/ghost_report.h"

#include <cmath>
#include <iomanip>
#include <numeric>
#include <sstream>

namespace veil {

namespace {

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); }

std::string sci(double v, int digits = 3) {
    if (!std::isfinite(v)) return "-";
    std::ostringstream os;
    os << std::scientific << std::setprecision(digits - 1) << v;
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
    return f;
}

GhostReport makeGhostReport(const GhostReportSpec& spec, const SceneSetup& setup,
                            const TraceSetup& trace, const GhostAnalysis& a,
                            const GhostMonteCarlo* mc, int det) {
    GhostReport r;
    r.scene = spec.scene;
    r.lensName = setup.prescription.system.name;
    r.title = r.lensName.empty() ? spec.scene : r.lensName;
    r.defaultScene = spec.defaultScene;
    r.imageShiftMm = spec.imageShiftMm;
    r.order = spec.order;
    r.detector = a.detector;
    r.unit = trace.transport.sources.front().unit() == FluxUnit::Lumen ? "lm" : "W";
    r.ghostSurfaces = a.surfaceNames;
    r.ghostSurfaceCount = a.surfaces.size();
    r.pruned = a.pruned;
    r.gridRays = spec.gridRays;
    r.sequentialSeconds = a.seconds;
    r.coatingOverrides = spec.coatingOverrides;
    r.coatingChanges = spec.coatingChanges;
    for (const Source& s : trace.transport.sources) r.sources.push_back(s.name());
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
                    {"mc_flux", haveMc ? num(mcNominalFlux) : nlohmann::json()},
                    {"mc_relative_error", haveMc ? num(mcNominalError) : nlohmann::json()}};
    j["all_ghosts"] = {{"flux", allGhostsFlux}};
    if (haveMc) {
        j["all_ghosts"]["mc_flux"] = mcAllGhostsFlux;
        j["all_ghosts"]["mc_relative_error"] = num(mcAllGhostsError);
        j["monte_carlo"] = {{"rays_per_source", mcRaysPerSource},
                            {"emitted_rays", mcEmittedRays},
                            {"seed", seed},
                            {"seconds", mcSeconds},
                            {"segments", mcSegments}};
    }
    j["ghosts"] = nlohmann::json::array();
    for (const GhostReportRow& g : rows) {
        nlohmann::json row;
        row["rank"] = g.rank;
        row["ghost"] = g.label;
        row["surfaces"] = g.surfaces;
        row["criterion"] = g.criterion;
        row["flux"] = g.flux;
        row["relative_flux"] = g.relativeFlux;
        row["peak_irradiance"] = g.peakIrradiance;
        row["relative_irradiance"] = g.relativeIrradiance;
        row["source"] = g.source;
        row["near_focus"] = g.nearFocus;
        row["focus_in_glass"] = g.glassFocus;
        if (haveMc) {
            row["mc_flux"] = g.mcFlux;
            row["mc_relative_flux"] = num(g.mcRelativeFlux);
            row["mc_relative_error"] = num(g.mcRelativeError);
        }
        if (g.baselineRank > 0) {
            row["baseline_rank"] = g.baselineRank;
            row["baseline_relative_flux"] = g.baselineRelativeFlux;
        }
        row["per_source"] = nlohmann::json::array();
        for (const GhostSourceResult& s : g.perSource)
            row["per_source"].push_back({{"source", s.source},
                                         {"flux", s.flux},
                                         {"relative_flux", s.relativeFlux},
                                         {"focus_mm", num(s.focusMm)},
                                         {"footprint_mm", s.footprintMm},
                                         {"centroid_mm", {s.centroidMm.x, s.centroidMm.y}},
                                         {"peak_irradiance", s.peakIrradiance},
                                         {"relative_irradiance", s.relativeIrradiance},
                                         {"near_focus", s.nearFocus},
                                         {"focus_in_glass", s.glassFocus},
                                         {"rays_traced", s.raysTraced},
                                         {"rays_arrived", s.raysArrived}});
        j["ghosts"].push_back(row);
    }
    return j;
}

std::string GhostReport::csv() const {
    std::ostringstream csv;
    csv << "rank,ghost,flux_" << unit << ",relative_flux,mc_flux_" << unit
        << ",mc_relative_flux,mc_relative_error,"
        << "focus_mm,footprint_mm,peak_irradiance_" << unit << "_per_mm2,relative_irradiance,"
        << "near_focus,focus_in_glass,baseline_rank,criterion,source\n";
    for (const GhostReportRow& g : rows) {
        csv << g.rank << ",\"" << g.label << "\"," << g.flux << "," << g.relativeFlux << ","
            << (haveMc ? sci(g.mcFlux, 6) : "") << "," << (haveMc ? sci(g.mcRelativeFlux, 6) : "")
            << "," << (haveMc ? sci(g.mcRelativeError, 3) : "") << "," << csvNumber(g.focusMm)
            << "," << csvNumber(g.footprintMm) << "," << g.peakIrradiance << ","
            << g.relativeIrradiance << "," << (g.nearFocus ? 1 : 0) << ",\"" << g.glassFocus
            << "\"," << (g.baselineRank > 0 ? std::to_string(g.baselineRank) : "") << ",\""
            << g.criterion << "\",\"" << g.source << "\"\n";
    }
    return csv.str();
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
    const bool whatIf = !coatingChanges.empty();
    md << "| rank | ghost | flux (" << unit << ") | Monte Carlo (" << unit
       << ") | flux / nominal | focus - detector (mm) | footprint (mm) | peak irradiance (" << unit
       << "/mm²) | peak / nominal peak | flags |" << (whatIf ? " was |" : "")
       << (several ? " source |" : "") << "\n|---|---|---|---|---|---|---|---|---|---|"
       << (whatIf ? "---|" : "") << (several ? "---|" : "") << "\n";
    for (const GhostReportRow& g : rows) {
        md << "| " << g.rank << " | " << g.label << " | " << sci(g.flux) << " | "
           << (haveMc ? mcText(g.mcFlux, g.mcRelativeError, " ± ", " %") : "-") << " | "
           << (nominalFlux > 0 ? sci(g.relativeFlux) : "-") << " | " << fix(g.focusMm, 2) << " | "
           << fix(g.footprintMm, 3) << " | " << sci(g.peakIrradiance) << " | "
           << (nominalPeak > 0 ? sci(g.relativeIrradiance) : "-") << " | " << g.flags()
           << (g.glassFocus.empty() ? "" : " (" + g.glassFocus + ")") << " |";
        if (whatIf)
            md << " " << (g.baselineRank > 0 ? std::to_string(g.baselineRank) : "-") << " |";
        if (several) md << " " << g.source << " |";
        md << "\n";
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
    out << "\n"
        << std::left << std::setw(5) << "rank" << std::setw(30) << "ghost" << std::right
        << std::setw(11) << "flux " + unit << std::setw(20) << "Monte Carlo" << std::setw(10)
        << "flux/nom" << std::setw(10) << "focus mm" << std::setw(9) << "foot mm" << std::setw(11)
        << "peak/mm2" << (several ? "  source  " : "") << "  flags"
        << (coatingChanges.empty() ? "" : "  (was)") << "\n";
    const size_t n = topRows > 0 ? std::min(topRows, rows.size()) : rows.size();
    for (size_t k = 0; k < n; ++k) {
        const GhostReportRow& g = rows[k];
        std::string mc = "-";
        if (haveMc) mc = mcText(g.mcFlux, g.mcRelativeError);
        out << std::left << std::setw(5) << g.rank << std::setw(30) << g.label << std::right
            << std::setw(11) << sci(g.flux) << std::setw(20) << mc << std::setw(10)
            << (nominalFlux > 0 ? sci(g.relativeFlux) : "-") << std::setw(10) << fix(g.focusMm, 1)
            << std::setw(9) << fix(g.footprintMm, 2) << std::setw(11) << sci(g.peakIrradiance);
        if (several) out << "  " << std::left << std::setw(8) << g.source << std::right;
        out << "  " << g.flags();
        if (g.baselineRank > 0) out << "  (" << g.baselineRank << ")";
        out << "\n";
    }
    out << footer;
    return out.str();
}

}  // namespace veil
