// Ray path pictures: the selection keeps exactly the first rays with a matching path, each with
// all its matching paths in leaf order (checked against a brute-force trace of the same rays),
// every kept path satisfies the criterion by the direct evaluator, the thread count changes
// nothing, and the picture files are written.

#include "analysis/pictures/path_picture.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <mutex>
#include <regex>
#include <utility>

#include "analysis/criteria/criterion_names.h"
#include "analysis/pictures/layout.h"
#include "tests/analysis/prepared_scene.h"
#include "tracer/records/path_history.h"

namespace veil {
namespace {

using test::prepare;
using test::Prepared;

const std::string kSunScene = VEIL_SOURCE_DIR "/examples/scenes/longfocus_360mm_sun.toml";
const std::string kGhosts = "reflect{1,} and hit(sensor)";

PathSelectionOptions ghostOptions() {
    PathSelectionOptions o;
    o.where = kGhosts;
    o.count = 40;
    o.batchRays = 200;
    o.maxRays = 2000;
    o.transport.seed = 11;
    return o;
}

TEST(PathSelection, KeepsTheFirstRaysWithAMatchAndAllTheirMatchingPaths) {
    const Prepared r = prepare(kSunScene);
    const PathSelectionOptions o = ghostOptions();
    const PathSelection sel = selectPaths(r.trace.view, r.trace.images, o);
    ASSERT_EQ(sel.rays.size(), o.count) << sel;
    const std::vector<SelectedPath> paths = sel.paths();
    EXPECT_GT(paths.size(), o.count) << "split rays have several ghost branches";
    EXPECT_GE(sel.pathsMatched, paths.size());

    // Oracle: trace the same batches, record every matching (ray, leaf) with the direct
    // evaluator, sort, take the first `count`.
    const CompiledCriterion c =
        compile(parseCriterion(kGhosts), criterionNames(r.setup->scene, r.trace.view));
    std::vector<std::pair<uint64_t, NodeIndex>> all;
    std::mutex m;
    uint64_t traced = 0;
    for (uint64_t b = 0; traced < sel.raysTraced; ++b) {
        TransportOptions to = o.transport;
        to.recordHistories = true;
        to.seed = o.transport.seed + b;
        const uint64_t offset = traced;
        traceNonsequential(r.trace.view, r.trace.images, o.batchRays, to, {},
                           [&](uint64_t i, const PathHistory& h) {
                               h.forEachPath([&](const PathView& p) {
                                   const std::vector<PathEvent> ev(p.begin(), p.end());
                                   if (!evaluateDirect(c, ev).value) return;
                                   std::lock_guard lock(m);
                                   all.emplace_back(offset + i, p.leaf());
                               });
                           });
        traced += o.batchRays * r.trace.view.sources.size();
    }
    std::sort(all.begin(), all.end());
    // The oracle's matches of its first `count` distinct rays.
    std::vector<std::pair<uint64_t, NodeIndex>> want;
    size_t rays = 0;
    for (size_t k = 0; k < all.size(); ++k) {
        if (k == 0 || all[k].first != all[k - 1].first) ++rays;
        if (rays > o.count) break;
        want.push_back(all[k]);
    }
    ASSERT_EQ(paths.size(), want.size());
    for (size_t k = 0; k < want.size(); ++k) {
        EXPECT_EQ(paths[k].ray, want[k].first) << k;
        EXPECT_EQ(paths[k].leaf, want[k].second) << k;
    }
    // A kept ray stores each node once: its tree has fewer nodes than its paths have in all.
    size_t nodes = 0, pathNodes = 0;
    for (const SelectedRay& ray : sel.rays) {
        nodes += ray.points.size();
        for (size_t k = 0; k < ray.leaves.size(); ++k) pathNodes += ray.path(k).points.size();
    }
    EXPECT_LT(nodes, pathNodes);
}

TEST(PathSelection, EveryKeptPathSatisfiesTheCriterion) {
    const Prepared r = prepare(kSunScene);
    const PathSelection sel = selectPaths(r.trace.view, r.trace.images, ghostOptions());
    const CompiledCriterion c =
        compile(parseCriterion(kGhosts), criterionNames(r.setup->scene, r.trace.view));
    ASSERT_FALSE(sel.rays.empty());
    for (const SelectedPath& p : sel.paths()) {
        EXPECT_TRUE(evaluateDirect(c, p.events).value) << p;
        ASSERT_EQ(p.points.size(), p.events.size());
        ASSERT_EQ(p.flux.size(), p.events.size());
        EXPECT_EQ(p.events.front().type, EventType::Emit);
        // A reflection somewhere, and a sensor event.
        EXPECT_TRUE(std::any_of(p.events.begin(), p.events.end(), [](const PathEvent& e) {
            return e.type == EventType::FresnelReflect || e.type == EventType::SpecularReflect;
        })) << p;
    }
}

TEST(PathSelection, OneAndTwoThreadsSelectTheSamePaths) {
    const Prepared r = prepare(kSunScene);
    auto run = [&](size_t threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        return selectPaths(r.trace.view, r.trace.images, ghostOptions());
    };
    const PathSelection one = run(1), two = run(2);
    const std::vector<SelectedPath> a = one.paths(), b = two.paths();
    ASSERT_EQ(a.size(), b.size());
    EXPECT_EQ(one.pathsMatched, two.pathsMatched);
    for (size_t k = 0; k < a.size(); ++k) {
        EXPECT_EQ(a[k].ray, b[k].ray);
        EXPECT_EQ(a[k].leaf, b[k].leaf);
        EXPECT_EQ(a[k].events, b[k].events);
        EXPECT_EQ(a[k].points, b[k].points);
    }
}

TEST(PathSelection, ABadCriterionNamesItsColumn) {
    const Prepared r = prepare(kSunScene);
    PathSelectionOptions o = ghostOptions();
    o.where = "reflect and hit(nosuchpart)";
    try {
        selectPaths(r.trace.view, r.trace.images, o);
        FAIL() << "no error";
    } catch (const ParseError& e) {
        EXPECT_NE(std::string(e.what()).find(":1:17"), std::string::npos) << e.what();
    }
}

TEST(PathPicture, WritesSvgAndPng) {
    const Prepared r = prepare(kSunScene);
    PathSelectionOptions o = ghostOptions();
    o.count = 10;
    const PathSelection sel = selectPaths(r.trace.view, r.trace.images, o);
    const Picture base = drawLayout(r.setup->scene, {});
    const std::filesystem::path dir = ::testing::TempDir();
    for (PathColouring colouring : {PathColouring::LogFlux, PathColouring::EventType}) {
        PathPictureOptions po;
        po.colouring = colouring;
        const Picture pic = drawPaths(base, sel, po);
        const std::filesystem::path svg = dir / "paths_test.svg", png = dir / "paths_test.png";
        pic.writeSvg(svg);
        pic.writePng(png, 600);
        std::ifstream s(svg);
        const std::string text((std::istreambuf_iterator<char>(s)), {});
        EXPECT_NE(text.find("<svg"), std::string::npos) << colouring;
        // The criterion as text; the flux key names its unit.
        EXPECT_NE(text.find(">" + xmlEscape(kGhosts) + " "), std::string::npos) << colouring;
        const std::string key = colouring == PathColouring::LogFlux
                                    ? ">segment flux, W per traced ray (log):</text>"
                                    : ">TIR</text>";
        EXPECT_NE(text.find(key), std::string::npos) << colouring;
        std::ifstream p(png, std::ios::binary);
        char sig[8] = {};
        p.read(sig, 8);
        EXPECT_EQ(std::string(sig, 8), std::string("\x89PNG\r\n\x1a\n", 8)) << colouring;
    }
}

TEST(PathPicture, TheFluxKeyIsInTheSourcesUnitAndSpansTheSegmentsDrawn) {
    const Prepared r = prepare(VEIL_SOURCE_DIR "/examples/scenes/catadioptric_2000mm_window.toml");
    PathSelectionOptions o;
    o.where = "emit(window)";
    o.count = 5;
    o.batchRays = 50;
    o.maxRays = 50;
    const PathSelection sel = selectPaths(r.trace.view, r.trace.images, o);
    EXPECT_EQ(sel.fluxUnit, "lm");
    ASSERT_FALSE(sel.rays.empty());
    double maxFlux = 0.0;
    for (const SelectedPath& p : sel.paths())
        for (size_t k = 1; k < p.flux.size(); ++k) maxFlux = std::max(maxFlux, p.flux[k]);
    const Picture pic = drawPaths(drawLayout(r.setup->scene, {}), sel, {});
    const std::string svg = pic.svg();
    EXPECT_NE(svg.find(">segment flux, lm per traced ray (log):</text>"), std::string::npos);
    // Ends of the bar: the brightest segment and 6 decades below, in lm.
    char hi[32], lo[32];
    std::snprintf(hi, sizeof hi, ">%.1e lm</text>", maxFlux);
    std::snprintf(lo, sizeof lo, ">%.1e lm</text>", maxFlux * 1e-6);
    EXPECT_NE(svg.find(hi), std::string::npos) << hi;
    EXPECT_NE(svg.find(lo), std::string::npos) << lo;
}

TEST(PathPicture, SegmentsStayInsideTheLayoutFrame) {
    const Prepared r = prepare(kSunScene);
    PathSelectionOptions o = ghostOptions();
    o.where = "exit";  // every exit segment runs past the scene's bounds
    o.count = 20;
    const PathSelection sel = selectPaths(r.trace.view, r.trace.images, o);
    ASSERT_FALSE(sel.rays.empty());
    const Picture base = drawLayout(r.setup->scene, {});
    PathPictureOptions po;
    po.lineWidthPt = 0.37;  // a width nothing else in the picture uses
    const std::string svg = drawPaths(base, sel, po).svg();
    const Vec2 topLeft = base.pagePoint(Vec2(base.zMin(), base.yMax()));
    const Vec2 bottomRight = base.pagePoint(Vec2(base.zMax(), base.yMin()));
    const std::regex path("<path d=\"([^\"]*)\"[^>]*stroke-width=\"0.37\"");
    const std::regex number("-?[0-9.]+");
    size_t points = 0;
    for (auto it = std::sregex_iterator(svg.begin(), svg.end(), path); it != std::sregex_iterator();
         ++it) {
        const std::string d = (*it)[1];
        std::vector<double> xy;
        for (auto n = std::sregex_iterator(d.begin(), d.end(), number); n != std::sregex_iterator();
             ++n)
            xy.push_back(std::stod(n->str()));
        ASSERT_EQ(xy.size() % 2, 0u);
        for (size_t k = 0; k < xy.size(); k += 2, ++points) {
            EXPECT_GE(xy[k], topLeft.x - 0.01);
            EXPECT_LE(xy[k], bottomRight.x + 0.01);
            EXPECT_GE(xy[k + 1], topLeft.y - 0.01);
            EXPECT_LE(xy[k + 1], bottomRight.y + 0.01);
        }
    }
    EXPECT_GT(points, 20u);
}

TEST(PathPicture, EventPaletteFollowsTheLegend) {
    EXPECT_EQ(eventColour(EventType::Refract).b, Color::hex(0x1f5fd0).b);
    EXPECT_GT(eventColour(EventType::FresnelReflect).r, 0.8);
    EXPECT_GT(eventColour(EventType::ScatterReflect).g, 0.5);
    EXPECT_EQ(eventColour(EventType::DetectorHit).r, 0.0);
}

}  // namespace
}  // namespace veil
