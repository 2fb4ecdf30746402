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

}  // namespace
}  // namespace veil
