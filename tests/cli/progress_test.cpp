// Progress reports in a log (cli/progress.h): runVeil sends standard error to a file, which is
// no terminal, so veil must write a few whole lines there and never the terminal's '\r'.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "analysis/reports/format.h"
#include "run_veil.h"

namespace {

std::string outDir(const std::string& name) {
    const std::filesystem::path p = std::filesystem::path(::testing::TempDir()) / name;
    std::filesystem::remove_all(p);
    return p.string();
}

// The lines of standard error that start with `label` followed by ':'.
std::vector<std::string> reportLines(const std::string& err, const std::string& label) {
    std::vector<std::string> lines;
    std::istringstream in(err);
    for (std::string line; std::getline(in, line);)
        if (line.rfind(label + ":", 0) == 0) lines.push_back(line);
    return lines;
}

// An ETA far away is said as such, not as an hour count past an int ("-2147483648h").
TEST(VeilProgress, DurationsAreBounded) {
    EXPECT_EQ(veil::duration(90.0), "1m30s");
    EXPECT_EQ(veil::duration(3.0 * 3600.0 + 61.0), "3h1m1s");
    EXPECT_EQ(veil::duration(98.0 * 86400.0), "2352h0m0s");
    EXPECT_EQ(veil::duration(99.0 * 86400.0), "more than 99 days");
    EXPECT_EQ(veil::duration(1e300), "more than 99 days");
    EXPECT_EQ(veil::duration(std::numeric_limits<double>::infinity()), "more than 99 days");
    EXPECT_EQ(veil::duration(std::numeric_limits<double>::quiet_NaN()), "0s");
    EXPECT_EQ(veil::duration(-5.0), "0s");
}

// 3000 rays take about a second on one thread: the tracer asks for a report every 200 ms,
// so a reporter that wrote a line per call would exceed the five allowed here.
TEST(VeilProgress, TraceLogGetsAFewWholeLinesAndNoCarriageReturn) {
    const std::string dir = outDir("veil_progress_trace");
    const VeilRun r = runVeil(
        "trace examples/scenes/longfocus_360mm_sun.toml -n 3000 "
        "--threads 1 -o " +
        dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.err.find('\r'), std::string::npos) << r.err;
    const std::vector<std::string> lines = reportLines(r.err, "trace");
    ASSERT_GE(lines.size(), 1u) << r.err;
    EXPECT_LE(lines.size(), 5u) << r.err;
    // Every line is whole and carries the rate; the last one says done with the ray count
    // and the elapsed time, the others their share and elapsed time.
    for (const std::string& l : lines) EXPECT_NE(l.find(" rays/s"), std::string::npos) << l;
    EXPECT_EQ(lines.back().rfind("trace: done, 3000 rays in ", 0), 0u) << lines.back();
    for (size_t i = 0; i + 1 < lines.size(); ++i) {
        EXPECT_NE(lines[i].find(" of 3000 rays)"), std::string::npos) << lines[i];
        EXPECT_NE(lines[i].find(" elapsed"), std::string::npos) << lines[i];
    }
    EXPECT_EQ(std::count_if(lines.begin(), lines.end(),
                            [](const std::string& l) { return l.find("done") != l.npos; }),
              1);
}

TEST(VeilProgress, QuietSilencesTheTraceReport) {
    const std::string dir = outDir("veil_progress_quiet");
    const VeilRun r = runVeil(
        "trace examples/scenes/longfocus_360mm_sun.toml -n 300 --threads 1 --quiet -o " + dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_TRUE(reportLines(r.err, "trace").empty()) << r.err;
    EXPECT_EQ(r.err.find("rays/s"), std::string::npos) << r.err;
}

// veil ghosts' Monte Carlo uses the same reporter: 3 fields x 300 rays.
TEST(VeilProgress, GhostsMonteCarloLogGetsWholeLines) {
    const std::string out = outDir("veil_progress_ghosts");
    const VeilRun r = runVeil(
        "ghosts tests/data/zmx/US00583336-2-scaled.zmx -n 300 --top 1 --paths 5 "
        "--no-images -o " +
        out);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.err.find('\r'), std::string::npos) << r.err;
    const std::vector<std::string> lines = reportLines(r.err, "Monte Carlo");
    ASSERT_GE(lines.size(), 1u) << r.err;
    EXPECT_LE(lines.size(), 5u) << r.err;
    EXPECT_EQ(lines.back().rfind("Monte Carlo: done, 900 rays in ", 0), 0u) << lines.back();
}

}  // namespace

namespace {

// paths reports by batch, and a run that finds its paths early says how many rays it took.
TEST(VeilProgress, PathsReportsItsBatchesAndTheRaysItTook) {
    const std::string dir = outDir("veil_progress_paths");
    const VeilRun r = runVeil(
        "paths examples/scenes/longfocus_360mm_sun.toml --where 'emit(sun)' --first 5 -n 10k "
        "--batch 100 -o " +
        dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.err.find('\r'), std::string::npos) << r.err;
    const std::vector<std::string> lines = reportLines(r.err, "paths");
    ASSERT_GE(lines.size(), 1u) << r.err;
    // Five paths are in the first batch of 100 rays: done after 100, not the 10k budget.
    EXPECT_EQ(lines.back().rfind("paths: done, 100 rays in ", 0), 0u) << lines.back();
}

}  // namespace

namespace {

// A render reports its set-up as a phase of its own, then its passes from the first one's
// start: the whole run is accounted for (the set-up used to be silent, and the pass clock
// started at the first pass's end).
TEST(VeilProgress, RenderReportsItsSetUpAndTimesItsPassesFromTheStart) {
    const std::string out = outDir("progress_render");
    const VeilRun r = runVeil(
        "render examples/scenes/longfocus_360mm_sun.toml --passes 1 --photons 5000 "
        "--rays-per-pixel 1 --threads 1 -o " +
        out);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    // The set-up line says the memory the render will take.
    std::vector<std::string> prep;
    std::istringstream lines(r.err);
    for (std::string line; std::getline(lines, line);)
        if (line.rfind("render: preparing (the lens connections, the lit parts' pilots; memory "
                       "about ",
                       0) == 0)
            prep.push_back(line);
    ASSERT_EQ(prep.size(), 2u) << r.err;
    EXPECT_NE(prep[0].find(" GB): "), std::string::npos) << prep[0];
    EXPECT_NE(prep[1].find(": done in "), std::string::npos) << prep[1];
    std::vector<std::string> passes;
    for (const std::string& l : reportLines(r.err, "render"))
        if (l.find("preparing") == std::string::npos) passes.push_back(l);
    ASSERT_FALSE(passes.empty()) << r.err;
    EXPECT_NE(passes.front().find("0.0 % (0 of 1 passes)"), std::string::npos) << r.err;
    EXPECT_EQ(passes.back().rfind("render: done, 1 passes in ", 0), 0u) << r.err;
    EXPECT_LT(r.err.find("render: preparing"), r.err.find("render: 0.0 %")) << r.err;
    EXPECT_EQ(r.err.find('\r'), std::string::npos);
}

}  // namespace

namespace {

// glare reports every phase of a position, the ghost prediction between the fields and the
// point source included (a double Gauss's 2.7 s were silent), and the point source's phase
// from before its scene is built.
TEST(VeilProgress, GlareReportsTheGhostPredictionAndThePointSourceFromTheirStart) {
    const std::string dir = outDir("progress_glare");
    const VeilRun r = runVeil(
        "glare examples/lenses/singlet.toml --field 0,0 --passes 2 --photons 5k "
        "--rays-per-pixel 16 --threads 1 -o " +
        dir);
    ASSERT_EQ(r.exitCode, 0) << r.err;
    EXPECT_EQ(r.err.find('\r'), std::string::npos);
    const std::vector<std::string> ghosts =
        reportLines(r.err, "glare: position 1, ghost prediction");
    ASSERT_FALSE(ghosts.empty()) << r.err;
    EXPECT_EQ(ghosts.back().rfind("glare: position 1, ghost prediction: done, ", 0), 0u)
        << ghosts.back();
    EXPECT_NE(ghosts.back().find(" ghost paths in "), std::string::npos) << ghosts.back();
    const std::vector<std::string> point = reportLines(r.err, "glare: position 1, point source");
    ASSERT_FALSE(point.empty()) << r.err;
    EXPECT_NE(point.front().find("0.0 % (0 of 4 passes)"), std::string::npos) << r.err;
    EXPECT_LT(r.err.find("glare: position 1, white field: done"),
              r.err.find("glare: position 1, ghost prediction"))
        << r.err;
    EXPECT_LT(r.err.find("glare: position 1, ghost prediction: done"),
              r.err.find("glare: position 1, point source"))
        << r.err;
}

}  // namespace
