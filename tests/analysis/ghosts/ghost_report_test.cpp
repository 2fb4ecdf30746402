// The ghost table is one set of rows: JSON, CSV, Markdown and the terminal show the same
// numbers for the same ghosts, in rank order.

#include "analysis/ghosts/ghost_report.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <sstream>

#include "analysis/lens/default_scene.h"
#include "lensdata/glass_catalog.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_spec.h"

namespace veil {
namespace {

std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> out;
    std::istringstream in(text);
    for (std::string l; std::getline(in, l);) out.push_back(l);
    return out;
}

TEST(GhostReport, EveryFormatShowsTheSameRows) {
    const GlassCatalog& catalog = GlassCatalog::builtIn();
    SceneSpec file = readSceneFile(VEIL_SOURCE_DIR "/examples/lenses/cooke_triplet.toml", catalog);
    double shift = 0.0;
    ASSERT_TRUE(addDefaultGhostScene(file, catalog, &shift));
    const auto prepared = PreparedScene::build(std::move(file), catalog);
    const GhostTracer tracer(prepared->geometry(), prepared->transport(), catalog);
    const GhostAnalysis a = tracer.analyse();
    GhostMonteCarloOptions mo;
    mo.raysPerSource = 64;
    const GhostMonteCarlo mc =
        runGhostMonteCarlo(prepared->geometry(), prepared->transport(), a, mo);
    GhostReportSpec spec;
    spec.scene = "cooke_triplet.toml";
    spec.defaultScene = true;
    spec.imageShiftMm = shift;
    spec.mcRaysPerSource = 64;
    const GhostReport r = makeGhostReport(spec, prepared->geometry(), prepared->transport(), a, &mc,
                                          tracer.detectorIndex());
    ASSERT_EQ(r.rows.size(), a.ghosts.size());
    ASSERT_EQ(r.rows.size(), 15u);  // 6 ghost surfaces: 6 * 5 / 2

    const nlohmann::json j = r.json();
    ASSERT_EQ(j["ghosts"].size(), r.rows.size());
    const std::vector<std::string> csv = lines(r.csv());
    ASSERT_EQ(csv.size(), r.rows.size() + 1);  // the header, then one line per ghost
    const std::string md = r.markdown();
    const std::string term = r.terminal(3, "");
    for (size_t k = 0; k < r.rows.size(); ++k) {
        const GhostReportRow& row = r.rows[k];
        EXPECT_EQ(row.rank, k + 1);
        EXPECT_EQ(row.label, a.ghosts[k].path.label);
        EXPECT_EQ(row.flux, a.ghosts[k].flux());
        EXPECT_EQ(j["ghosts"][k]["ghost"], row.label);
        EXPECT_EQ(j["ghosts"][k]["flux"].get<double>(), row.flux);
        EXPECT_EQ(j["ghosts"][k]["mc_flux"].get<double>(), row.mcFlux);
        EXPECT_EQ(j["ghosts"][k]["mc_flux"].get<double>(), mc.flux(k + 1, tracer.detectorIndex()));
        // CSV: rank, quoted label, the flux at the stream's 6 significant digits.
        std::istringstream fields(csv[k + 1]);
        std::string rank, label, flux;
        std::getline(fields, rank, ',');
        std::getline(fields, label, ',');
        std::getline(fields, flux, ',');
        EXPECT_EQ(std::stoul(rank), row.rank);
        EXPECT_EQ(label, "\"" + row.label + "\"");
        EXPECT_NEAR(std::stod(flux), row.flux, 5e-6 * row.flux);
        EXPECT_NE(md.find("| " + std::to_string(row.rank) + " | " + row.label + " |"),
                  std::string::npos)
            << row.label;
        // The terminal shows the first three only.
        EXPECT_EQ(term.find(row.label) != std::string::npos, k < 3) << row.label;
    }
    EXPECT_EQ(j["nominal"]["flux"].get<double>(), a.nominal.flux());
    EXPECT_EQ(j["all_ghosts"]["flux"].get<double>(), r.allGhostsFlux);

    // Several sources (the triplet's three fields): a row's focus, footprint, flags and peak
    // are all of one source, the one where the ghost peaks, and every format names it.
    ASSERT_EQ(prepared->transport().view.sources.size(), 3u);
    bool sourcesDiffer = false;
    for (size_t k = 0; k < r.rows.size(); ++k) {
        const GhostReportRow& row = r.rows[k];
        const auto it =
            std::find_if(row.perSource.begin(), row.perSource.end(),
                         [&](const GhostSourceResult& s) { return s.source == row.source; });
        ASSERT_NE(it, row.perSource.end()) << row.label;
        for (const GhostSourceResult& s : row.perSource)
            EXPECT_LE(s.peakIrradiance, it->peakIrradiance) << row.label;
        EXPECT_EQ(row.peakIrradiance, it->peakIrradiance);
        EXPECT_EQ(row.footprintMm, it->footprintMm);
        EXPECT_EQ(row.focusMm, it->focusMm);
        EXPECT_EQ(row.nearFocus, it->nearFocus);
        EXPECT_EQ(row.glassFocus, it->glassFocus);
        EXPECT_EQ(j["ghosts"][k]["source"], row.source);
        EXPECT_NE(csv[k + 1].find(",\"" + row.source + "\""), std::string::npos);
        sourcesDiffer |= row.source != r.rows[0].source;
    }
    EXPECT_TRUE(sourcesDiffer);  // the test means something: ghosts peak in different fields
    EXPECT_NE(md.find("sum all 3 sources"), std::string::npos);
    EXPECT_NE(term.find("flux sums all 3 sources"), std::string::npos);
}

// A Monte Carlo flux of exactly zero reads "0 (no hits)", never "+-inf%".
TEST(GhostReport, ZeroMonteCarloFluxSaysNoHits) {
    GhostReport r;
    r.haveMc = true;
    r.unit = "W";
    r.sources = {"sun"};
    GhostReportRow row;
    row.rank = 1;
    row.label = "L2.back > L1.front";
    row.flux = 1e-6;
    row.mcFlux = 0.0;
    row.mcRelativeError = std::numeric_limits<double>::infinity();
    r.rows.push_back(row);
    const std::string term = r.terminal(0, "");
    EXPECT_NE(term.find("0 (no hits)"), std::string::npos) << term;
    EXPECT_EQ(term.find("inf"), std::string::npos) << term;
    EXPECT_NE(r.markdown().find("0 (no hits)"), std::string::npos);
}

// Rows where the Monte Carlo contradicts the sequential estimate are flagged: beyond 3 of its
// sigmas, or no hit where the typical hit's flux says 9 or more were expected (a Poisson
// count of 0 then has p < 1.3e-4); rows within the noise, or with too few hits expected to
// miss, are not. The note says how many and what differs.
TEST(GhostReport, RowsTheMonteCarloContradictsAreFlagged) {
    GhostReport r;
    r.haveMc = true;
    r.unit = "W";
    r.sources = {"sun"};
    auto add = [&](double flux, double mc, double relErr) {
        GhostReportRow row;
        row.rank = r.rows.size() + 1;
        row.label = "ghost " + std::to_string(row.rank);
        row.flux = flux;
        row.mcFlux = mc;
        row.mcRelativeError = relErr;
        r.rows.push_back(row);
    };
    const double inf = std::numeric_limits<double>::infinity();
    add(1.0e-4, 1.02e-4, 0.01);  // z +2 (hits of 1e-8 each: 1e-4 x 0.01^2)
    add(1.0e-4, 0.90e-4, 0.02);  // z -5.6
    add(1.0e-4, 1.20e-4, 0.05);  // z +3.3
    add(1.0e-7, 0.0, inf);       // 10 hits expected at 1e-8 each, none found
    add(5.0e-8, 0.0, inf);       // 5 expected: a miss is no contradiction
    add(0.0, 0.0, inf);          // nothing either way
    for (int k = 0; k < 4; ++k) add(1.0e-4, 1.0e-4, 0.01);  // 1e-8 a hit: the median
    checkAgainstMonteCarlo(r, 0);
    EXPECT_NEAR(r.rows[0].mcZ, 2.0 / 1.02, 1e-9);
    EXPECT_EQ(r.rows[0].mcCheck, "");
    EXPECT_NEAR(r.rows[1].mcZ, -0.1 / 0.018, 1e-9);
    EXPECT_EQ(r.rows[1].mcCheck, "mc-disagrees");
    EXPECT_EQ(r.rows[2].mcCheck, "mc-disagrees");
    EXPECT_NEAR(r.rows[3].mcExpectedHits, 10.0, 1e-6);
    EXPECT_EQ(r.rows[3].mcCheck, "mc-none");
    EXPECT_NEAR(r.rows[4].mcExpectedHits, 5.0, 1e-6);
    EXPECT_EQ(r.rows[4].mcCheck, "");
    EXPECT_EQ(r.rows[5].mcCheck, "");
    for (size_t k = 6; k < 10; ++k) EXPECT_EQ(r.rows[k].mcCheck, "");
    EXPECT_EQ(r.mcFlagged, 3u);
    EXPECT_NE(r.rows[1].flags().find("mc-disagrees"), std::string::npos);
    EXPECT_NE(r.rows[1].mcWhy.find("apertures only"), std::string::npos) << r.rows[1].mcWhy;
    EXPECT_NE(r.rows[2].mcWhy.find("other paths"), std::string::npos) << r.rows[2].mcWhy;
    // With mechanics, light the Monte Carlo lacks is put to them.
    checkAgainstMonteCarlo(r, 7);
    EXPECT_NE(r.rows[3].mcWhy.find("mechanics (7 parts)"), std::string::npos) << r.rows[3].mcWhy;
    // Every format says so.
    EXPECT_NE(r.terminal(0, "").find("3 of 10 ghosts flagged"), std::string::npos);
    EXPECT_NE(r.markdown().find("- 2. ghost 2: mc-disagrees (z -5.6)"), std::string::npos)
        << r.markdown();
    const nlohmann::json j = r.json();
    EXPECT_EQ(j["mc_flagged"], 3);
    EXPECT_EQ(j["ghosts"][1]["mc_check"], "mc-disagrees");
    EXPECT_NEAR(j["ghosts"][1]["mc_z"].get<double>(), -0.1 / 0.018, 1e-9);
    EXPECT_TRUE(j["ghosts"][0]["mc_expected_hits"].is_null());
}

}  // namespace
}  // namespace veil
