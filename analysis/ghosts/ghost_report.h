#pragma once
// The ranked ghost table of `veil ghosts`: one set of rows, built once from the sequential
// estimate and the Monte Carlo check, written as JSON, CSV, Markdown and terminal text.
//
//   GhostAnalysis (+ GhostMonteCarlo, + the baseline ranking of a coating what-if)
//     --makeGhostReport--> GhostReport { what the table is of; nominal and all-ghosts lines;
//                                        rows[rank - 1] }
//     --json() / csv() / markdown() / terminal()--> the files and the screen
//
// The formats differ in what they show (JSON carries every source of every ghost, CSV one
// line per ghost with the worst source's focus and footprint, Markdown and the terminal a
// readable selection), never in the numbers: every value comes from the same row.

#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "analysis/ghosts/ghost_monte_carlo.h"
#include "analysis/reports/report_table.h"

namespace veil {

inline constexpr double kMcDisagreeSigma = 3.0;
inline constexpr double kMcExpectedHits = 9.0;

struct GhostReportRow {
    size_t rank = 0;
    std::string label;  // "L6.back > L5.front"
    std::vector<std::string> surfaces;
    std::string criterion;
    double flux = 0.0;                // sequential, summed over sources
    double relativeFlux = 0.0;        // over the nominal image's flux
    double peakIrradiance = 0.0;      // largest over sources
    double relativeIrradiance = 0.0;  // over the nominal image's peak
    // The source where the peak irradiance is highest (`source`): its focus, footprint,
    // near-focus flag and focus in glass, so that one row never mixes sources. The flux sums
    // all sources; perSource has each.
    std::string source;
    bool nearFocus = false;
    std::string glassFocus;  // where a ghost focuses inside glass, if it does
    double focusMm = 0.0;
    double footprintMm = 0.0;
    std::vector<GhostSourceResult> perSource;
    // Monte Carlo (NaN without it; mcRelativeFlux NaN also when the nominal image is dark).
    double mcFlux = 0.0;
    double mcRelativeFlux = 0.0;
    double mcRelativeError = 0.0;
    // The Monte Carlo against the sequential estimate: z = (mc - sequential) / (mc's sigma),
    // NaN without hits; and, where it found none, the hits it should have found at the
    // sequential flux (the sequential flux over a hit's typical flux, the median of
    // mcFlux * mcRelativeError^2 over the rows with hits). mcCheck: "mc-disagrees" for
    // |z| > kMcDisagreeSigma, "mc-none" for no hits where kMcExpectedHits were expected
    // (Poisson: p < 1.3e-4), else "". mcWhy: what veil can tell of the cause.
    double mcZ = 0.0;
    double mcExpectedHits = 0.0;
    std::string mcCheck;
    std::string mcWhy;
    int baselineRank = 0;  // coating what-if: the rank before the change; 0 = none
    double baselineRelativeFlux = 0.0;
    std::string flags() const;  // "near-focus", "focus-in-glass", mcCheck
};

struct GhostReport {
    // What the table is of.
    std::string scene;  // the file as named on the command line
    std::string title;  // the lens's name, or the file
    std::string lensName;
    bool defaultScene = false;
    double imageShiftMm = 0.0;  // default scene: lens file image -> paraxial image
    int order = 2;
    std::string detector;
    std::string unit;  // "W" or "lm"
    std::vector<std::string> ghostSurfaces;
    size_t ghostSurfaceCount = 0;
    int pruned = 0;
    int gridRays = 0;
    double sequentialSeconds = 0.0;
    std::vector<std::string> coatingOverrides;
    std::vector<std::string> coatingChanges;
    std::vector<std::string> sources;
    // The nominal image and all ghosts together.
    double nominalFlux = 0.0;
    double nominalPeak = 0.0;
    double allGhostsFlux = 0.0;
    // Monte Carlo.
    bool haveMc = false;
    double mcNominalFlux = 0.0, mcNominalError = 0.0;
    double mcAllGhostsFlux = 0.0, mcAllGhostsError = 0.0;
    uint64_t mcRaysPerSource = 0, mcEmittedRays = 0, mcSegments = 0, seed = 0;
    double mcSeconds = 0.0;

    std::vector<GhostReportRow> rows;  // rank order
    // The rows the Monte Carlo contradicts (GhostReportRow::mcCheck), and what differs
    // between the two estimates: said under the table.
    size_t mcFlagged = 0;
    std::string mcNote;

    // One row per ghost (analysis/reports/report_table.h); every format is written from it.
    ReportTable table() const;
    nlohmann::json json() const;
    std::string csv() const;
    std::string markdown() const;
    // The terminal table: a header, the first `topRows` rows (0 = all), then `footer`.
    std::string terminal(size_t topRows, const std::string& footer) const;
};

struct GhostReportSpec {
    std::string scene;
    bool defaultScene = false;
    double imageShiftMm = 0.0;
    int order = 2;
    int gridRays = 64;
    std::vector<std::string> coatingOverrides;
    std::vector<std::string> coatingChanges;
    // Coating what-if: label -> (rank, relative flux) before the change.
    std::map<std::string, std::pair<int, double>> baseline;
    uint64_t mcRaysPerSource = 0;
    uint64_t seed = 0;
};

// Sets every row's mcZ, mcExpectedHits, mcCheck and mcWhy from its sequential and Monte Carlo
// fluxes, and the report's mcFlagged and mcNote (`mechanicalParts`: the scene's, which the
// Monte Carlo meets and the sequential estimate does not). makeGhostReport calls it.
void checkAgainstMonteCarlo(GhostReport& report, size_t mechanicalParts);

// `mc` may be null (no Monte Carlo); `detector` is the detector index the analysis used.
GhostReport makeGhostReport(const GhostReportSpec& spec, const SceneGeometry& geometry,
                            const SceneTransport& transport, const GhostAnalysis& analysis,
                            const GhostMonteCarlo* mc, int detector);

}  // namespace veil
