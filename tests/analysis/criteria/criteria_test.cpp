// Ray path criteria: the parsers, name resolution, hand-made paths (the seed's figure 3), the
// streaming evaluator against the direct recursive oracle on random criteria and paths, and
// the PathSummary prefilter against the oracle.

#include "analysis/criteria/criteria.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <random>

#include "tests/analysis/criteria/random_criteria.h"
#include "tracer/records/path_history.h"

namespace veil {
namespace {

using K = Criterion::Kind;
using S = CriterionState;
using test::RandomCriteria;
using test::randomNames;

// A small lens: ids 0..7.
NameTable lensNames() {
    NameTable t;
    t.objects = {{"L4.front", {}, "ar_coat", false}, {"L4.back", {"L5.front"}, "ar_coat", false},
                 {"L4.edge", {}, "black", false},    {"spacer1", {}, "black", false},
                 {"spacer2", {}, "black", false},    {"barrel", {}, "black_anodized", false},
                 {"stop", {}, "black", false},       {"sensor", {}, "", true}};
    t.media = {"air", "N-BK7", "N-SF6"};
    t.sources = {"sun", "lamp"};
    return t;
}

PathEvent ev(EventType t, int object, int before = 0, int after = 0) {
    PathEvent e;
    e.type = t;
    e.object = object;
    e.mediumBefore = static_cast<int16_t>(before);
    e.mediumAfter = static_cast<int16_t>(after);
    return e;
}

bool run(const std::string& text, const std::vector<PathEvent>& path) {
    const CompiledCriterion c = compile(parseCriterion(text), lensNames());
    const bool streaming = matches(c, path);
    EXPECT_EQ(streaming, evaluateDirect(c, path).value) << text;
    return streaming;
}

int errorColumn(const std::string& text) {
    try {
        parseCriterion(text);
    } catch (const ParseError& e) {
        return e.loc().column;
    }
    return -1;
}

std::string errorMessage(const std::string& text) {
    try {
        parseCriterion(text);
    } catch (const ParseError& e) {
        return e.what();
    }
    return "";
}

// Parser
TEST(CriteriaParser, ReadsTheIssueExamples) {
    Criterion c = parseCriterion("seq(reflect(L4.back), reflect(L4.front), hit(sensor))");
    ASSERT_EQ(c.kind, K::Seq);
    ASSERT_EQ(c.children.size(), 3u);
    EXPECT_EQ(c.children[0].leaf, LeafKind::Reflect);
    EXPECT_EQ(c.children[0].patterns[0].text, "L4.back");
    EXPECT_EQ(c.children[0].patterns[0].column, 13);
    EXPECT_EQ(c.children[2].leaf, LeafKind::Hit);

    c = parseCriterion("scatter(spacer* | barrel) and hit(sensor)");
    ASSERT_EQ(c.kind, K::And);
    ASSERT_EQ(c.children[0].patterns.size(), 2u);
    EXPECT_EQ(c.children[0].patterns[1].text, "barrel");
    EXPECT_EQ(c.children[0].patterns[1].column, 19);

    c = parseCriterion("reflect(*){2,}");
    EXPECT_EQ(c.count, (CountRange{2, CountRange::kUnbounded}));
    EXPECT_EQ(parseCriterion("reflect{3}").count, (CountRange{3, 3}));
    EXPECT_EQ(parseCriterion("reflect{,2}").count, (CountRange{0, 2}));
    EXPECT_EQ(parseCriterion("reflect { 1 , 4 }").count, (CountRange{1, 4}));
}

TEST(CriteriaParser, PrecedenceNotAndOr) {
    // not binds tighter than and, and tighter than or.
    const Criterion c = parseCriterion("hit(a) or not hit(b) and exit");
    ASSERT_EQ(c.kind, K::Or);
    ASSERT_EQ(c.children[1].kind, K::And);
    EXPECT_EQ(c.children[1].children[0].kind, K::Not);
    const Criterion d = parseCriterion("(hit(a) or hit(b)) and exit");
    EXPECT_EQ(d.kind, K::And);
    // Keywords are whole words: "hit(andy)" is a leaf with pattern "andy".
    EXPECT_EQ(parseCriterion("hit(andy)").patterns[0].text, "andy");
    EXPECT_EQ(errorColumn("hit(a) andexit"), 8);
}

TEST(CriteriaParser, PrintsAndReadsBack) {
    for (const char* text :
         {"seq(reflect(L4.back), reflect(L4.front), hit(sensor))",
          "not (scatter(spacer* | barrel){2,5}) or (emit(sun) and medium(N-*){1})",
          "seq(tir, fresnel{,3}, not (absorb), exit(#3))", "property(black*){2,}"}) {
        const Criterion c = parseCriterion(text);
        EXPECT_EQ(parseCriterion(toString(c)), c) << toString(c);
    }
}

TEST(CriteriaParser, ErrorsPointAtTheColumn) {
    EXPECT_EQ(errorColumn("hit(sensor) and"), 16);
    EXPECT_NE(errorMessage("hit(sensor) and").find("expected a criterion"), std::string::npos);
    EXPECT_EQ(errorColumn("reflec(L4.back)"), 1);
    EXPECT_NE(errorMessage("reflec(L4.back)").find("unknown criterion 'reflec'"),
              std::string::npos);
    EXPECT_EQ(errorColumn("hit(sensor"), 11);
    EXPECT_NE(errorMessage("hit(sensor").find("expected '|' or ')'"), std::string::npos);
    EXPECT_EQ(errorColumn("hit(a | )"), 9);
    EXPECT_EQ(errorColumn("seq(hit(a) hit(b))"), 12);
    EXPECT_EQ(errorColumn("reflect{2,1}"), 8);
    EXPECT_EQ(errorColumn("reflect{0,}"), 8);
    EXPECT_EQ(errorColumn("reflect{x}"), 9);
    EXPECT_EQ(errorColumn("(hit(a)){2}"), 9);
    EXPECT_EQ(errorColumn("hit(a) hit(b)"), 8);
    EXPECT_EQ(errorColumn("not"), 4);
    try {
        parseCriterion("exit or", "scene.toml");
        FAIL();
    } catch (const ParseError& e) {
        EXPECT_EQ(e.loc().file, "scene.toml");
        EXPECT_EQ(e.loc().line, 1);
    }
}

// OpticStudio filters
TEST(CriteriaZemax, MapsLettersAndPrecedence) {
    const Criterion c = parseZemaxFilter("H7 & !R6 | S3");
    ASSERT_EQ(c.kind, K::Or);
    ASSERT_EQ(c.children[0].kind, K::And);
    EXPECT_EQ(c.children[0].children[0].leaf, LeafKind::Hit);
    EXPECT_EQ(c.children[0].children[0].patterns[0].text, "#7");
    ASSERT_EQ(c.children[0].children[1].kind, K::Not);
    EXPECT_EQ(c.children[0].children[1].children[0].leaf, LeafKind::Reflect);
    EXPECT_EQ(c.children[1].leaf, LeafKind::Scatter);
    EXPECT_EQ(parseZemaxFilter("t2").leaf, LeafKind::Refract);
    EXPECT_EQ(parseZemaxFilter("H7 & (R6 | S3)").kind, K::And);

    // Same answers as the text syntax on a path: refract at 0, reflect at 1, detector 7.
    const NameTable names = lensNames();
    const std::vector<PathEvent> path = {ev(EventType::Emit, 0), ev(EventType::Refract, 0),
                                         ev(EventType::FresnelReflect, 1),
                                         ev(EventType::DetectorHit, 7)};
    EXPECT_TRUE(matches(compile(parseZemaxFilter("H7 & R1"), names), path));
    EXPECT_FALSE(matches(compile(parseZemaxFilter("H7 & !R1"), names), path));
    EXPECT_TRUE(matches(compile(parseZemaxFilter("H7 & !R1 | T0"), names), path));
    EXPECT_FALSE(matches(compile(parseZemaxFilter("S3 | H5"), names), path));
}

TEST(CriteriaZemax, ErrorsPointAtTheColumn) {
    auto column = [](const char* text) {
        try {
            parseZemaxFilter(text);
        } catch (const ParseError& e) {
            return e.loc().column;
        }
        return -1;
    };
    EXPECT_EQ(column("H7 & "), 6);
    EXPECT_EQ(column("H7 & X2"), 6);
    EXPECT_EQ(column("H & R2"), 2);
    EXPECT_EQ(column("(H7 | R2"), 9);
    EXPECT_EQ(column("H7 R2"), 4);
}

// Name resolution
TEST(CriteriaNames, GlobsAliasesAndErrors) {
    const NameTable names = lensNames();
    const CompiledCriterion c = compile(parseCriterion("scatter(spacer* | barrel)"), names);
    ASSERT_EQ(c.leaves.size(), 1u);
    EXPECT_EQ(c.leaves[0].set[0], (1u << 3) | (1u << 4) | (1u << 5));
    EXPECT_EQ(compile(parseCriterion("hit(L5.front)"), names).leaves[0].set[0], 1u << 1);
    EXPECT_EQ(compile(parseCriterion("hit(L4.?\?\?\?)"), names).leaves[0].set[0], 0b110u);
    EXPECT_EQ(compile(parseCriterion("property(black*)"), names).leaves[0].set[0], 0b1111100u);
    EXPECT_EQ(compile(parseCriterion("detector"), names).leaves[0].set[0], 1u << 7);
    EXPECT_EQ(compile(parseCriterion("medium(N-*)"), names).leaves[0].set[0], 0b110u);
    EXPECT_EQ(compile(parseCriterion("emit(lamp)"), names).leaves[0].set[0], 0b10u);
    EXPECT_TRUE(compile(parseCriterion("exit"), names).leaves[0].anyObject);

    auto error = [&](const char* text) -> std::pair<int, std::string> {
        try {
            compile(parseCriterion(text), names);
        } catch (const ParseError& e) {
            return {e.loc().column, e.message()};
        }
        return {-1, ""};
    };
    // An unknown name lists what the scene has.
    EXPECT_EQ(
        error("hit(sensor) and scatter(spacer9 | baffle*)"),
        std::make_pair(
            25,
            std::string("object pattern 'spacer9' matches no object (did you mean 'spacer1'?); the "
                        "scene's objects are L4.front, L4.back, L4.edge, "
                        "spacer1, spacer2, barrel, stop, sensor")));
    EXPECT_EQ(error("detector(barrel)"),
              std::make_pair(10, std::string("detector pattern 'barrel' matches no detector; "
                                             "the scene's detector is sensor")));
    EXPECT_EQ(error("medium(air) or medium(CaF2)").first, 23);
    EXPECT_EQ(error("emit(moon)").second,
              "source pattern 'moon' matches no source; the scene's sources are sun, lamp");
    EXPECT_EQ(error("property(gold)").first, 10);
    EXPECT_EQ(error("hit(#8)").first, 5);
    EXPECT_EQ(error("hit(#7)").first, -1);
    // An id past size_t (once a raw "stoul" from the number conversion) matches nothing.
    EXPECT_EQ(error("hit(#18446744073709551617)"),
              std::make_pair(5, std::string("object pattern '#18446744073709551617' matches no "
                                            "object; the scene's objects are L4.front, L4.back, "
                                            "L4.edge, spacer1, spacer2, barrel, stop, sensor")));
}

// Nesting is bounded (every walk of the tree recurses once per level): thousands of '(',
// seq( or not stop at the level past the limit, as an error at that column, not a crash.
TEST(CriteriaParser, NestingIsBounded) {
    auto nested = [](const std::string& open, const std::string& close, int n) {
        std::string text;
        for (int i = 0; i < n; ++i) text += open;
        text += "hit(sensor)";
        for (int i = 0; i < n; ++i) text += close;
        return text;
    };
    for (const auto& [open, close] :
         {std::pair<std::string, std::string>{"(", ")"}, {"seq(", ")"}, {"not ", ""}}) {
        SCOPED_TRACE(open);
        EXPECT_NO_THROW(parseCriterion(nested(open, close, kMaxCriterionNesting)));
        const int column = static_cast<int>(open.size()) * kMaxCriterionNesting + 1;
        EXPECT_EQ(errorColumn(nested(open, close, kMaxCriterionNesting + 1)), column);
        EXPECT_NE(errorMessage(nested(open, close, 6000)).find("deeper than 200 levels"),
                  std::string::npos);
    }
    for (const char* open : {"(", "!"}) {
        std::string text(6000, open[0]);
        text += "H1";
        if (open[0] == '(') text += std::string(6000, ')');
        try {
            parseZemaxFilter(text);
            ADD_FAILURE() << "no error";
        } catch (const ParseError& e) {
            EXPECT_EQ(e.loc().column, kMaxCriterionNesting + 1);
        }
    }
}

// Hand-made paths
TEST(CriteriaEval, SeedFigure3) {
    // "Before hitting the lens surface the ray either specularly refracts or enters glass":
    // seq(refract or medium(N-BK7), hit(L4.back)).
    const std::string crit = "seq(refract(L4.front) or medium(N-BK7), hit(L4.back))";
    // First sequence: the ray hits L4.back directly, then refracts: does not qualify.
    EXPECT_FALSE(run(crit, {ev(EventType::Emit, 0), ev(EventType::Refract, 1, 0, 2),
                            ev(EventType::Refract, 0, 2, 0), ev(EventType::Exit, -1)}));
    // Second sequence: refracts at L4.front into glass, then meets L4.back: qualifies.
    EXPECT_TRUE(run(crit, {ev(EventType::Emit, 0), ev(EventType::Refract, 0, 0, 1),
                           ev(EventType::Refract, 1, 1, 0), ev(EventType::DetectorHit, 7)}));
}

// The L4 back/front ghost: in through L4.front (object 0) into glass (medium 1), Fresnel
// reflections at L4.back (1) and L4.front, out through L4.back, onto the sensor (7).
std::vector<PathEvent> l4Ghost() {
    return {ev(EventType::Emit, 0),
            ev(EventType::Refract, 0, 0, 1),
            ev(EventType::FresnelReflect, 1, 1, 1),
            ev(EventType::FresnelReflect, 0, 1, 1),
            ev(EventType::Refract, 1, 1, 0),
            ev(EventType::DetectorHit, 7)};
}

TEST(CriteriaEval, GhostsCountsAndEarlyDecision) {
    const std::vector<PathEvent> ghost = l4Ghost();
    EXPECT_TRUE(run("seq(reflect(L4.back), reflect(L4.front), hit(sensor))", ghost));
    EXPECT_FALSE(run("seq(reflect(L4.front), reflect(L4.back), hit(sensor))", ghost));
    EXPECT_TRUE(run("reflect(*){2}", ghost));
    EXPECT_FALSE(run("reflect(*){3,}", ghost));
    EXPECT_TRUE(run("reflect{,2} and fresnel{2,2}", ghost));
    EXPECT_FALSE(run("reflect{1}", ghost));
    EXPECT_FALSE(run("scatter(spacer* | barrel) and hit(sensor)", ghost));
    EXPECT_TRUE(run("not scatter and detector(sensor)", ghost));
    // One event advances a seq by one step only.
    EXPECT_FALSE(run("seq(reflect, reflect, reflect)", ghost));
    EXPECT_TRUE(run("seq(reflect, reflect)", ghost));
    // not inside seq: nothing of B after A; a child after a not never fires.
    EXPECT_TRUE(run("seq(reflect(L4.front), not refract(L4.front))", ghost));
    EXPECT_FALSE(run("seq(refract(L4.front), not reflect(L4.front))", ghost));
    EXPECT_FALSE(run("seq(emit, not scatter, hit(sensor))", ghost));
    // Counts inside seq are counted only while their step is open.
    EXPECT_TRUE(run("seq(reflect(L4.back), reflect{1,})", ghost));
    EXPECT_TRUE(run("seq(reflect(L4.front), reflect{,0})", ghost));

    // Early decision: {2,} is true at the second reflection, {1} false there.
    const CompiledCriterion c = compile(parseCriterion("reflect{2,}"), lensNames());
    StreamingEvaluator s(c);
    EXPECT_EQ(s.push(ghost[0]), S::Undefined);
    EXPECT_EQ(s.push(ghost[1]), S::Undefined);
    EXPECT_EQ(s.push(ghost[2]), S::Undefined);
    EXPECT_EQ(s.push(ghost[3]), S::True);
    EXPECT_TRUE(s.decided());
    EXPECT_EQ(evaluateDirect(c, ghost).decidedAt, 3u);
    const CompiledCriterion one = compile(parseCriterion("reflect{1}"), lensNames());
    StreamingEvaluator s1(one);
    for (int i = 0; i < 3; ++i) s1.push(ghost[i]);
    EXPECT_FALSE(s1.decided());
    EXPECT_EQ(s1.push(ghost[3]), S::False);
    s1.reset();
    EXPECT_FALSE(s1.decided());
    EXPECT_EQ(s1.finish(), S::False);
}

// Prefilter
std::vector<int32_t> requiredOf(const std::string& text) {
    return compile(parseCriterion(text), lensNames()).required;
}

bool mayMatch(const std::string& text, const std::vector<PathEvent>& path) {
    PathSummary summary;
    summary.reset();
    for (const PathEvent& e : path) summary.add(e);
    return summary.mayMatch(compile(parseCriterion(text), lensNames()));
}

TEST(CriteriaPrefilter, RequiredLeaves) {
    // Leaves in preorder: fresnel(L4.back), fresnel(L4.front), fresnel{2}, scatter, detector.
    EXPECT_EQ(requiredOf("seq(fresnel(L4.back), fresnel(L4.front)) and fresnel{2} and not "
                         "scatter and detector(sensor)"),
              (std::vector<int32_t>{0, 1, 2, 4}));
    EXPECT_TRUE(requiredOf("hit(L4.front) or exit").empty());
    EXPECT_TRUE(requiredOf("not exit").empty());
    EXPECT_TRUE(requiredOf("reflect{,2}").empty());
    EXPECT_EQ(requiredOf("exit"), (std::vector<int32_t>{0}));
    EXPECT_EQ(requiredOf("reflect{,2} and seq(emit, medium(N-BK7){1,2})"),
              (std::vector<int32_t>{1, 2}));
    EXPECT_EQ(requiredOf("seq(exit or tir, not fresnel, refract) and hit(sensor)"),
              (std::vector<int32_t>{3, 4}));
}

TEST(CriteriaPrefilter, MayMatchTestsRequiredLeavesOnly) {
    const std::vector<PathEvent> ghost = l4Ghost();
    const std::string pair =
        "seq(fresnel(L4.back), fresnel(L4.front)) and fresnel{2} and not scatter and "
        "detector(sensor)";
    EXPECT_TRUE(run(pair, ghost));
    EXPECT_TRUE(mayMatch(pair, ghost));
    // The summary ignores order and counts: true says nothing.
    EXPECT_FALSE(run("seq(fresnel(L4.front), fresnel(L4.back)) and fresnel{3}", ghost));
    EXPECT_TRUE(mayMatch("seq(fresnel(L4.front), fresnel(L4.back)) and fresnel{3}", ghost));
    EXPECT_FALSE(mayMatch("fresnel(L4.edge) and detector", ghost));
    EXPECT_FALSE(mayMatch("seq(emit(lamp), hit(sensor))", ghost));
    EXPECT_TRUE(mayMatch("emit(sun)", ghost));
    // Types and objects are paired: there is a Refract at L4.front but no reflection.
    EXPECT_TRUE(mayMatch("refract(L4.front) and fresnel(L4.back)", ghost));
    EXPECT_FALSE(mayMatch("reflect(L4.back | L4.edge) and refract(sensor)", ghost));
    // Media: entered N-BK7 (id 1) from air, never N-SF6; a reflection keeps the medium.
    EXPECT_TRUE(mayMatch("medium(N-BK7)", ghost));
    EXPECT_TRUE(mayMatch("medium(air)", ghost));
    EXPECT_FALSE(mayMatch("medium(N-SF6)", ghost));
    EXPECT_TRUE(mayMatch("fresnel(L4.front)", {ghost[3]}));
    EXPECT_FALSE(mayMatch("medium", {ghost[3]}));
    EXPECT_TRUE(mayMatch("medium", {ghost[1]}));
    // Not required: under or, not, or with count min 0.
    EXPECT_TRUE(mayMatch("tir or exit", ghost));
    EXPECT_TRUE(mayMatch("not tir and not scatter{,1} and scatter{,1}", ghost));

    // An event without object (-1) matches only leaves that accept any object.
    const std::vector<PathEvent> lost = {ev(EventType::Emit, 1), ev(EventType::Exit, -1)};
    EXPECT_TRUE(mayMatch("exit and emit(#1)", lost));
    EXPECT_TRUE(mayMatch("hit and hit(*)", lost));
    EXPECT_FALSE(mayMatch("hit(#0 | #1 | #2 | #3 | #4 | #5 | #6 | #7)", lost));
    EXPECT_FALSE(mayMatch("emit(#0)", lost));
}

TEST(CriteriaPrefilter, ResetForgetsThePreviousPath) {
    // Ids beyond the first 64-bit word, and a summary reused across paths.
    NameTable names;
    for (int i = 0; i < 200; ++i) {
        std::string name = std::to_string(i);
        name.insert(name.begin(), 'o');  // not "o" + ...: GCC 12 warns falsely (-Wrestrict)
        names.objects.push_back({name, {}, "", false});
    }
    names.media = {"m0", "m1"};
    names.sources = {"s0"};
    const CompiledCriterion far = compile(parseCriterion("scatter(o150) and hit(o3)"), names);
    const CompiledCriterion near = compile(parseCriterion("scatter(o3)"), names);
    PathSummary summary;
    summary.reset();
    for (const PathEvent& e :
         {ev(EventType::Emit, 0), ev(EventType::ScatterReflect, 150), ev(EventType::Refract, 3)})
        summary.add(e);
    EXPECT_TRUE(summary.mayMatch(far));
    EXPECT_FALSE(summary.mayMatch(near));
    summary.reset();
    for (const PathEvent& e : {ev(EventType::Emit, 0), ev(EventType::ScatterReflect, 3)})
        summary.add(e);
    EXPECT_FALSE(summary.mayMatch(far));
    EXPECT_TRUE(summary.mayMatch(near));
    summary.reset();
    EXPECT_FALSE(summary.mayMatch(near));
    EXPECT_TRUE(summary.mayMatch(compile(parseCriterion("not exit"), names)));
}

// Property test: streaming against the oracle

TEST(CriteriaProperty, StreamingAgreesWithTheOracle) {
    const auto start = std::chrono::steady_clock::now();
    RandomCriteria gen(20261122);
    const NameTable names = randomNames();
    constexpr int kCriteria = 100000;
    constexpr int kPathsPerCriterion = 8;
    int trueCount = 0, early = 0, maxNodes = 0;
    bool kinds[5] = {};
    for (int i = 0; i < kCriteria; ++i) {
        const Criterion crit = gen.criterion(gen.uniform(1, 30));
        ASSERT_LE(crit.nodeCount(), 30u);
        maxNodes = std::max(maxNodes, static_cast<int>(crit.nodeCount()));
        kinds[static_cast<int>(crit.kind)] = true;
        const CompiledCriterion c = compile(crit, names);
        StreamingEvaluator s(c);
        for (int j = 0; j < kPathsPerCriterion; ++j) {
            const std::vector<PathEvent> path = gen.path();
            const DirectResult oracle = evaluateDirect(c, path);
            s.reset();
            size_t decidedAt = path.size();
            S first = S::Undefined;
            for (size_t k = 0; k < path.size(); ++k) {
                const S st = s.push(path[k]);
                if (first == S::Undefined && st != S::Undefined) {
                    first = st;
                    decidedAt = k;
                }
                // Once decided, the answer does not change with more events.
                if (first != S::Undefined) {
                    ASSERT_EQ(st, first);
                }
            }
            const S final = s.finish();
            ASSERT_NE(final, S::Undefined);
            if (first != S::Undefined) {
                ASSERT_EQ(final, first);
            }
            ASSERT_EQ(final == S::True, oracle.value)
                << "criterion " << crit << "\npath " << ::testing::PrintToString(path);
            ASSERT_EQ(decidedAt, oracle.decidedAt)
                << "criterion " << crit << "\npath " << ::testing::PrintToString(path);
            trueCount += oracle.value;
            early += decidedAt < path.size();
        }
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const int total = kCriteria * kPathsPerCriterion;
    // The test must exercise both answers and early decisions, with big trees.
    EXPECT_GT(trueCount, total / 10);
    EXPECT_LT(trueCount, total * 9 / 10);
    EXPECT_GT(early, total / 10);
    EXPECT_EQ(maxNodes, 30);
    for (int k = 0; k < 5; ++k) EXPECT_TRUE(kinds[k]) << k;
    RecordProperty("cases", total);
    std::cout << "[criteria] " << kCriteria << " criteria x " << kPathsPerCriterion
              << " paths: true " << trueCount << ", decided early " << early << ", " << seconds
              << " s\n";
}

// What a StreamingEvaluator-like run reports: the answer and the index of the event that
// decided it (path size = at the end).
struct Outcome {
    S value = S::Undefined;
    size_t decidedAt = 0;
    bool operator==(const Outcome&) const = default;
};

// Continues criterion c's evaluator in `buffer` (already fed `done` events) with `events`.
Outcome runBank(const EvaluatorBank& bank, size_t c, std::vector<std::byte>& buffer,
                std::span<const PathEvent> events, size_t done, Outcome sofar,
                StreamingEvaluator::Scratch& scratch) {
    Outcome out = sofar;
    for (size_t k = 0; k < events.size(); ++k) {
        const S st = bank.push(c, buffer.data(), events[k], scratch);
        if (out.value == S::Undefined && st != S::Undefined) out = {st, done + k};
    }
    const S final = bank.finish(c, buffer.data(), scratch);
    if (out.value == S::Undefined) out = {final, done + events.size()};
    EXPECT_EQ(final, out.value);
    return out;
}

Outcome runEvaluator(const CompiledCriterion& c, std::span<const PathEvent> events) {
    StreamingEvaluator s(c);
    Outcome out{S::Undefined, events.size()};
    for (size_t k = 0; k < events.size(); ++k) {
        const S st = s.push(events[k]);
        if (out.value == S::Undefined && st != S::Undefined) out = {st, k};
    }
    const S final = s.finish();
    if (out.value == S::Undefined) out.value = final;
    return out;
}

// The flat-buffer evaluators of an EvaluatorBank (the online filter's branch state) agree
// with StreamingEvaluator, also when the buffer is copied in the middle of a path (a split)
// and the copies go on with the same or another suffix.
TEST(CriteriaProperty, BankAgreesWithStreamingEvaluatorAcrossCopies) {
    RandomCriteria gen(20261124);
    const NameTable names = randomNames();
    constexpr int kGroups = 3000;
    constexpr int kPerGroup = 8;
    constexpr int kPathsPerGroup = 6;
    StreamingEvaluator::Scratch scratch;
    int copiedUndecided = 0;
    for (int g = 0; g < kGroups; ++g) {
        std::vector<CompiledCriterion> criteria;
        for (int i = 0; i < kPerGroup; ++i)
            criteria.push_back(compile(gen.criterion(gen.uniform(1, 30)), names));
        const EvaluatorBank bank(criteria);
        ASSERT_EQ(bank.size(), criteria.size());
        std::vector<std::byte> buffer(bank.bufferSize());
        for (int j = 0; j < kPathsPerGroup; ++j) {
            const std::vector<PathEvent> path = gen.path();
            const size_t split = static_cast<size_t>(gen.uniform(0, static_cast<int>(path.size())));
            std::vector<PathEvent> other(path.begin(), path.begin() + split);
            const std::vector<PathEvent> tail = gen.path();
            other.insert(other.end(), tail.begin(), tail.end());
            const std::span<const PathEvent> prefix(path.data(), split);
            const std::span<const PathEvent> suffix(path.data() + split, path.size() - split);
            const std::span<const PathEvent> otherSuffix(other.data() + split,
                                                         other.size() - split);

            // Every criterion fed the prefix in the same buffer, interleaved as in push.
            bank.reset(buffer.data());
            std::vector<Outcome> sofar(criteria.size(), Outcome{S::Undefined, 0});
            for (size_t k = 0; k < prefix.size(); ++k)
                for (size_t c = 0; c < criteria.size(); ++c) {
                    const S st = bank.push(c, buffer.data(), prefix[k], scratch);
                    if (sofar[c].value == S::Undefined && st != S::Undefined) sofar[c] = {st, k};
                }
            std::vector<std::byte> same = buffer;
            std::vector<std::byte> diverging = buffer;
            for (size_t c = 0; c < criteria.size(); ++c) {
                copiedUndecided += bank.state(c, buffer.data()) == S::Undefined;
                const Outcome expected = runEvaluator(criteria[c], path);
                const Outcome expectedOther = runEvaluator(criteria[c], other);
                ASSERT_EQ(runBank(bank, c, buffer, suffix, split, sofar[c], scratch), expected)
                    << "criterion " << c << " of group " << g;
                ASSERT_EQ(runBank(bank, c, same, suffix, split, sofar[c], scratch), expected)
                    << "criterion " << c << " of group " << g;
                ASSERT_EQ(runBank(bank, c, diverging, otherSuffix, split, sofar[c], scratch),
                          expectedOther)
                    << "criterion " << c << " of group " << g;
                const DirectResult oracle = evaluateDirect(criteria[c], path);
                ASSERT_EQ(expected.value == S::True, oracle.value);
                ASSERT_EQ(expected.decidedAt, oracle.decidedAt);
            }
        }
    }
    // The copies must often carry undecided evaluators, or the test proves little.
    EXPECT_GT(copiedUndecided, kGroups * kPerGroup * kPathsPerGroup / 10);
}

// The leaves compile() must mark required, read off the tree (leaves numbered in preorder).
void requiredLeaves(const Criterion& c, bool conjunctive, int32_t& leaf,
                    std::vector<int32_t>& out) {
    if (c.kind == K::Leaf) {
        if (conjunctive && c.count.min >= 1) out.push_back(leaf);
        ++leaf;
        return;
    }
    for (const Criterion& ch : c.children)
        requiredLeaves(ch, conjunctive && (c.kind == K::And || c.kind == K::Seq), leaf, out);
}

TEST(CriteriaProperty, PrefilterIsSound) {
    const auto start = std::chrono::steady_clock::now();
    RandomCriteria gen(20261123);
    const NameTable names = randomNames();
    constexpr int kCriteria = 20000;
    constexpr int kPathsPerCriterion = 8;
    PathSummary summary;  // one for all paths, as in CriterionImages::collect
    int trueCount = 0, pruned = 0;
    for (int i = 0; i < kCriteria; ++i) {
        const Criterion crit = gen.criterion(gen.uniform(1, 30));
        const CompiledCriterion c = compile(crit, names);
        std::vector<int32_t> required;
        int32_t leaves = 0;
        requiredLeaves(crit, true, leaves, required);
        ASSERT_EQ(c.required, required) << "criterion " << crit;
        for (int j = 0; j < kPathsPerCriterion; ++j) {
            const std::vector<PathEvent> path = gen.path();
            summary.reset();
            for (const PathEvent& e : path) summary.add(e);
            const bool may = summary.mayMatch(c);
            // Exactly "every required leaf matches some event", by Leaf::matches itself.
            const bool allSeen = std::all_of(required.begin(), required.end(), [&](int32_t r) {
                return std::any_of(path.begin(), path.end(),
                                   [&](const PathEvent& e) { return c.leaves[r].matches(e); });
            });
            ASSERT_EQ(may, allSeen)
                << "criterion " << crit << "\npath " << ::testing::PrintToString(path);
            const bool value = evaluateDirect(c, path).value;
            ASSERT_TRUE(may || !value)
                << "criterion " << crit << "\npath " << ::testing::PrintToString(path);
            trueCount += value;
            pruned += !may;
        }
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const int total = kCriteria * kPathsPerCriterion;
    // Both answers occur, and the prefilter rejects a good share of the false cases.
    EXPECT_GT(trueCount, total / 10);
    EXPECT_GT(pruned, (total - trueCount) / 3);
    RecordProperty("cases", total);
    std::cout << "[criteria] prefilter, " << kCriteria << " criteria x " << kPathsPerCriterion
              << " paths: true " << trueCount << ", pruned " << pruned << " of "
              << total - trueCount << " false, " << seconds << " s\n";
}

// Hand Cases for Every Leaf Kind and Count Form
// Leaf::matches and compile() serve both evaluators, so the property tests above cannot see
// their mistakes. Every expectation below is worked out by hand from docs/criteria.md on the
// lens of lensNames(): objects 0 L4.front, 1 L4.back (alias L5.front), 2 L4.edge, 3 spacer1,
// 4 spacer2, 5 barrel, 6 stop, 7 sensor (a detector); properties ar_coat (0, 1), black
// (2, 3, 4, 6), black_anodized (5), none (7); media 0 air, 1 N-BK7, 2 N-SF6; sources 0 sun,
// 1 lamp.

// Every leaf kind against one event of every type. The events carry object 1 (source 1 for
// Emit, object 7 for the detector row) and change the medium from air to N-BK7, so only the
// event type decides. Columns: emit, refract, specular_reflect, fresnel_reflect, tir,
// scatter_reflect, scatter_transmit, surface_absorb, volume_absorb, exit, detector_hit, culled.
TEST(CriteriaLeaves, EveryKindMatchesExactlyItsEventTypes) {
    struct Row {
        const char* leaf;
        int object;
        const char* types;  // '1' where the event type matches
    };
    const Row rows[] = {
        {"emit(lamp)", 1, "100000000000"},
        {"hit(L4.back)", 1, "011111111111"},  // anything at the object, detector hit included
        {"detector(sensor)", 7, "000000000010"},
        {"property(ar_coat)", 1, "011111111111"},
        {"medium(N-BK7)", 1, "011111111111"},  // any event that enters N-BK7
        {"reflect(L4.back)", 1, "001100000000"},
        {"fresnel(L4.back)", 1, "000100000000"},
        {"tir(L4.back)", 1, "000010000000"},
        {"refract(L4.back)", 1, "010000000000"},
        {"scatter(L4.back)", 1, "000001100000"},
        {"scatter_reflect(L4.back)", 1, "000001000000"},
        {"scatter_transmit(L4.back)", 1, "000000100000"},
        {"absorb(L4.back)", 1, "000000011000"},
        {"exit", 1, "000000000100"},
    };
    static_assert(kLeafKindCount == 14 && kEventTypeCount == 12, "a new kind needs its row");
    bool kindSeen[kLeafKindCount] = {};
    for (const Row& row : rows) {
        const Criterion c = parseCriterion(row.leaf);
        kindSeen[static_cast<int>(c.leaf)] = true;
        const CompiledCriterion cc = compile(c, lensNames());
        ASSERT_EQ(cc.leaves.size(), 1u);
        for (int t = 0; t < kEventTypeCount; ++t) {
            const PathEvent e = ev(static_cast<EventType>(t), row.object, 0, 1);
            EXPECT_EQ(cc.leaves[0].matches(e), row.types[t] == '1')
                << row.leaf << " on " << static_cast<EventType>(t);
        }
    }
    for (int k = 0; k < kLeafKindCount; ++k) EXPECT_TRUE(kindSeen[k]) << static_cast<LeafKind>(k);
}

// The object (source, medium, property) test of every kind: the right event type at the
// right and at the wrong object, aliases, globs, ids and events without an object (-1).
TEST(CriteriaLeaves, EveryKindSelectsItsObjects) {
    struct Case {
        const char* leaf;
        PathEvent event;
        bool expected;
    };
    using E = EventType;
    const Case cases[] = {
        // emit: the object of an Emit event is the source index.
        {"emit(sun)", ev(E::Emit, 0), true},
        {"emit(sun)", ev(E::Emit, 1), false},
        {"emit(#1)", ev(E::Emit, 1), true},
        {"emit(s*)", ev(E::Emit, 1), false},  // lamp
        {"emit", ev(E::Emit, 1), true},
        // hit: names, aliases, globs (* spans dots, ? is one character), ids.
        {"hit(L4.back)", ev(E::Refract, 0), false},
        {"hit(L5.front)", ev(E::Refract, 1), true},  // L4.back's alias
        {"hit(L4.*)", ev(E::ScatterReflect, 2), true},
        {"hit(L4.*)", ev(E::ScatterReflect, 3), false},
        {"hit(L?.front)", ev(E::FresnelReflect, 1), true},  // through the alias L5.front
        {"hit(L?.front)", ev(E::FresnelReflect, 2), false},
        {"hit(spacer?)", ev(E::SurfaceAbsorb, 4), true},
        {"hit(spacer?)", ev(E::SurfaceAbsorb, 5), false},
        {"hit(#7)", ev(E::DetectorHit, 7), true},
        {"hit(#3 | #5)", ev(E::ScatterReflect, 5), true},
        {"hit(#3 | #5)", ev(E::ScatterReflect, 4), false},
        {"hit(*)", ev(E::Exit, -1), true},  // "any object" includes none
        {"hit", ev(E::VolumeAbsorb, -1), true},
        {"hit(L4.*)", ev(E::Exit, -1), false},
        // detector: detector objects only.
        {"detector(sensor)", ev(E::DetectorHit, 7), true},
        {"detector", ev(E::DetectorHit, 7), true},
        {"detector(#7)", ev(E::DetectorHit, 7), true},
        {"detector", ev(E::DetectorHit, 1), false},  // object 1 is not a detector
        // property: the object's optical property name; objects without one never match.
        {"property(black)", ev(E::ScatterReflect, 2), true},
        {"property(black)", ev(E::ScatterReflect, 5), false},  // black_anodized
        {"property(black*)", ev(E::ScatterReflect, 5), true},
        {"property(ar_coat)", ev(E::Refract, 1), true},
        {"property(*)", ev(E::DetectorHit, 7), false},  // the sensor has no property
        {"property", ev(E::Exit, -1), false},
        // medium: the medium entered, and only when the event changes it.
        {"medium(N-BK7)", ev(E::Refract, 0, 0, 1), true},
        {"medium(N-BK7)", ev(E::Refract, 1, 1, 0), false},
        {"medium(N-BK7)", ev(E::FresnelReflect, 1, 1, 1), false},
        {"medium(N-BK7)", ev(E::Refract, 1, 2, 1), true},
        {"medium(air)", ev(E::Refract, 1, 1, 0), true},
        {"medium(N-*)", ev(E::ScatterTransmit, 0, 0, 2), true},
        {"medium(#2)", ev(E::Refract, 0, 1, 2), true},
        {"medium", ev(E::Refract, 0, 1, 2), true},
        {"medium", ev(E::Refract, 0, 2, 2), false},
        // The event kinds at the right and the wrong object.
        {"reflect(L4.back | L4.front)", ev(E::SpecularReflect, 0), true},
        {"reflect(L4.back | L4.front)", ev(E::FresnelReflect, 1), true},
        {"reflect(L4.back | L4.front)", ev(E::FresnelReflect, 2), false},
        {"fresnel(L4.?ront)", ev(E::FresnelReflect, 0), true},
        {"fresnel(L4.?ront)", ev(E::FresnelReflect, 1), false},  // L4.back is not L4.?ront
        {"tir(L4.edge)", ev(E::TotalInternalReflection, 2), true},
        {"tir(L4.edge)", ev(E::TotalInternalReflection, 1), false},
        {"refract(#0)", ev(E::Refract, 0), true},
        {"refract(#0)", ev(E::Refract, 1), false},
        {"scatter(spacer* | barrel)", ev(E::ScatterReflect, 3), true},
        {"scatter(spacer* | barrel)", ev(E::ScatterTransmit, 5), true},
        {"scatter(spacer* | barrel)", ev(E::ScatterReflect, 6), false},
        {"scatter_reflect(stop)", ev(E::ScatterReflect, 6), true},
        {"scatter_reflect(stop)", ev(E::ScatterReflect, 5), false},
        {"scatter_transmit(stop)", ev(E::ScatterTransmit, 6), true},
        {"scatter_transmit(stop)", ev(E::ScatterTransmit, 3), false},
        {"absorb", ev(E::VolumeAbsorb, -1), true},
        {"absorb(L4.*)", ev(E::VolumeAbsorb, -1), false},
        {"absorb(spacer?)", ev(E::SurfaceAbsorb, 4), true},
        {"absorb(spacer?)", ev(E::SurfaceAbsorb, 5), false},
        {"exit", ev(E::Exit, -1), true},
        {"exit(*)", ev(E::Exit, -1), true},
        {"exit(#3)", ev(E::Exit, -1), false},
    };
    for (const Case& c : cases) {
        const CompiledCriterion cc = compile(parseCriterion(c.leaf), lensNames());
        ASSERT_EQ(cc.leaves.size(), 1u);
        EXPECT_EQ(cc.leaves[0].matches(c.event), c.expected) << c.leaf << " on " << c.event;
    }
    // Names are case-sensitive: no object is called l4.front.
    EXPECT_THROW(compile(parseCriterion("hit(l4.front)"), lensNames()), ParseError);
    EXPECT_THROW(compile(parseCriterion("property(Black)"), lensNames()), ParseError);
}

// Every count form on a path for every leaf kind. Each path was written to hold exactly the
// listed matching events among near misses (the right type at another object, another type
// at the right object, the same source id in an Emit); the answers for 0, 1 and 2 matches
// and the event that decides them follow from docs/criteria.md's rules 3 and 5: {n,} is
// true at its n-th match, a finite maximum is false at the match that exceeds it, everything
// else waits for the end of the path.
enum class When { First, Second, End };  // the first or second match, or the end of the path
struct Expected {
    bool value;
    When when;
};
struct CountForm {
    const char* suffix;
    Expected byMatches[3];  // for paths with 0, 1, 2 matching events
};
const CountForm kCountForms[] = {
    {"", {{false, When::End}, {true, When::First}, {true, When::First}}},  // {1,}
    {"{1}", {{false, When::End}, {true, When::End}, {false, When::Second}}},
    {"{2}", {{false, When::End}, {false, When::End}, {true, When::End}}},
    {"{3}", {{false, When::End}, {false, When::End}, {false, When::End}}},
    {"{2,}", {{false, When::End}, {false, When::End}, {true, When::Second}}},
    {"{3,}", {{false, When::End}, {false, When::End}, {false, When::End}}},
    {"{,0}", {{true, When::End}, {false, When::First}, {false, When::First}}},
    {"{,1}", {{true, When::End}, {true, When::End}, {false, When::Second}}},
    {"{,2}", {{true, When::End}, {true, When::End}, {true, When::End}}},
    {"{1,2}", {{false, When::End}, {true, When::End}, {true, When::End}}},
    {"{2,3}", {{false, When::End}, {false, When::End}, {true, When::End}}},
    {"{3,4}", {{false, When::End}, {false, When::End}, {false, When::End}}},
};

TEST(CriteriaLeaves, EveryCountFormOnEveryKind) {
    using E = EventType;
    struct Case {
        const char* leaf;
        std::vector<PathEvent> path;
        std::vector<size_t> matchAt;  // hand-counted
    };
    // The L4 ghost emitted by the lamp (source 1, the same number as L4.back).
    std::vector<PathEvent> lampGhost = l4Ghost();
    lampGhost[0].object = 1;
    const std::vector<PathEvent> barrelScatter = {ev(E::Emit, 0), ev(E::ScatterReflect, 5),
                                                  ev(E::ScatterTransmit, 5),
                                                  ev(E::ScatterReflect, 5), ev(E::Exit, -1)};
    const Case cases[] = {
        {"emit(lamp)", lampGhost, {0}},
        {"emit(sun)", lampGhost, {}},
        {"hit(L4.back)", lampGhost, {2, 4}},
        {"hit(spacer*)", lampGhost, {}},
        {"detector(sensor)",
         {ev(E::Emit, 0), ev(E::Refract, 0, 0, 1), ev(E::Refract, 1, 1, 0),
          ev(E::ScatterReflect, 7), ev(E::DetectorHit, 7)},
         {4}},
        {"property(black)",
         {ev(E::Emit, 0), ev(E::ScatterReflect, 5), ev(E::ScatterReflect, 3), ev(E::Refract, 1),
          ev(E::SurfaceAbsorb, 6)},
         {2, 4}},
        {"medium(N-BK7)",
         {ev(E::Emit, 0), ev(E::Refract, 0, 0, 1), ev(E::FresnelReflect, 1, 1, 1),
          ev(E::Refract, 0, 1, 0), ev(E::ScatterTransmit, 2, 0, 1), ev(E::VolumeAbsorb, -1, 1, 1)},
         {1, 4}},
        {"reflect(L4.*)",
         {ev(E::Emit, 0), ev(E::Refract, 0, 0, 1), ev(E::SpecularReflect, 1),
          ev(E::TotalInternalReflection, 2), ev(E::FresnelReflect, 0), ev(E::ScatterReflect, 1),
          ev(E::Exit, -1)},
         {2, 4}},
        {"fresnel(L4.back)",
         {ev(E::Emit, 0), ev(E::Refract, 0, 0, 1), ev(E::SpecularReflect, 1),
          ev(E::FresnelReflect, 1), ev(E::FresnelReflect, 0), ev(E::FresnelReflect, 1),
          ev(E::DetectorHit, 7)},
         {3, 5}},
        {"tir(L4.edge)",
         {ev(E::Emit, 0), ev(E::Refract, 0, 0, 1), ev(E::TotalInternalReflection, 2),
          ev(E::FresnelReflect, 2), ev(E::TotalInternalReflection, 1),
          ev(E::TotalInternalReflection, 2), ev(E::Refract, 1, 1, 0)},
         {2, 5}},
        {"refract(L4.front)",
         {ev(E::Emit, 0), ev(E::Refract, 0, 0, 1), ev(E::Refract, 1, 1, 0),
          ev(E::ScatterTransmit, 0), ev(E::Refract, 0, 0, 1), ev(E::FresnelReflect, 0)},
         {1, 4}},
        {"scatter(barrel)",
         {ev(E::Emit, 0), ev(E::ScatterReflect, 5), ev(E::ScatterReflect, 3),
          ev(E::SpecularReflect, 5), ev(E::ScatterTransmit, 5), ev(E::SurfaceAbsorb, 5)},
         {1, 4}},
        {"scatter_reflect(barrel)", barrelScatter, {1, 3}},
        {"scatter_transmit(barrel)", barrelScatter, {2}},
        {"absorb", {ev(E::Emit, 0), ev(E::Refract, 0, 0, 1), ev(E::VolumeAbsorb, -1, 1, 1)}, {2}},
        {"absorb(stop)", {ev(E::Emit, 0), ev(E::ScatterReflect, 6), ev(E::SurfaceAbsorb, 6)}, {2}},
        {"exit",
         {ev(E::Emit, 0), ev(E::Refract, 0, 0, 1), ev(E::Refract, 1, 1, 0), ev(E::Exit, -1)},
         {3}},
        {"exit", lampGhost, {}},
    };
    bool kindSeen[kLeafKindCount] = {};
    for (const Case& c : cases) {
        // The leaf alone: matches exactly at the hand-counted events.
        const CompiledCriterion bare = compile(parseCriterion(c.leaf), lensNames());
        kindSeen[static_cast<int>(parseCriterion(c.leaf).leaf)] = true;
        for (size_t i = 0; i < c.path.size(); ++i) {
            const bool listed = std::find(c.matchAt.begin(), c.matchAt.end(), i) != c.matchAt.end();
            EXPECT_EQ(bare.leaves[0].matches(c.path[i]), listed) << c.leaf << " event " << i;
        }
        ASSERT_LE(c.matchAt.size(), 2u);
        for (const CountForm& f : kCountForms) {
            const std::string text = std::string(c.leaf) + f.suffix;
            const Expected want = f.byMatches[c.matchAt.size()];
            const size_t at = want.when == When::First    ? c.matchAt.at(0)
                              : want.when == When::Second ? c.matchAt.at(1)
                                                          : c.path.size();
            const CompiledCriterion cc = compile(parseCriterion(text), lensNames());
            const Outcome streaming = runEvaluator(cc, c.path);
            EXPECT_EQ(streaming.value, want.value ? S::True : S::False) << text;
            EXPECT_EQ(streaming.decidedAt, at) << text;
            const DirectResult direct = evaluateDirect(cc, c.path);
            EXPECT_EQ(direct.value, want.value) << text;
            EXPECT_EQ(direct.decidedAt, at) << text;
        }
    }
    for (int k = 0; k < kLeafKindCount; ++k) EXPECT_TRUE(kindSeen[k]) << static_cast<LeafKind>(k);
}

// Globs, aliases and ids counted along the L4 ghost: emitted by the sun, in at L4.front (0)
// into N-BK7, Fresnel at L4.back (1, alias L5.front) and L4.front, out at L4.back, sensor (7).
TEST(CriteriaLeaves, GlobsAliasesAndIdsCountAlongAPath) {
    const std::vector<PathEvent> g = l4Ghost();
    EXPECT_TRUE(run("hit(L4.?ront){2}", g));  // object 0 at events 1 and 3
    EXPECT_TRUE(run("hit(L?.front){4}", g));  // objects 0 and 1 (alias): events 1 to 4
    EXPECT_FALSE(run("hit(L?.front){2}", g));
    EXPECT_TRUE(run("hit(*.back){2}", g));  // object 1 at events 2 and 4
    EXPECT_TRUE(run("hit(L4*){4}", g));     // * spans the dot
    EXPECT_TRUE(run("hit(#0 | #7){3}", g));
    EXPECT_TRUE(run("reflect(L5.front){1}", g));
    EXPECT_TRUE(run("emit(#0) and not emit(#1)", g));
    EXPECT_TRUE(run("emit(s?n)", g));
    EXPECT_FALSE(run("emit(l*)", g));
    EXPECT_TRUE(run("medium(#1){1} and medium(air){1}", g));  // into N-BK7, back into air
    EXPECT_FALSE(run("medium(N-SF6)", g));
    EXPECT_TRUE(run("property(ar_*){4}", g));  // L4.front and L4.back are both ar_coat
    EXPECT_FALSE(run("property(ar_coat){5}", g));
    EXPECT_TRUE(run("detector(s*){1}", g));
    EXPECT_FALSE(run("property(black*)", g));
}

// OpticStudio filter strings, letter by letter, on one path: emitted by the sun, refract at
// L4.front (0), Fresnel at L4.back (1), TIR at L4.edge (2), scatter through spacer1 (3),
// refract at L4.back, detector hit at the sensor (7).
TEST(CriteriaZemax, EveryLetterAndOperatorOnAHandPath) {
    using E = EventType;
    const std::vector<PathEvent> path = {ev(E::Emit, 0),
                                         ev(E::Refract, 0, 0, 1),
                                         ev(E::FresnelReflect, 1, 1, 1),
                                         ev(E::TotalInternalReflection, 2, 1, 1),
                                         ev(E::ScatterTransmit, 3, 1, 1),
                                         ev(E::Refract, 1, 1, 0),
                                         ev(E::DetectorHit, 7)};
    const NameTable names = lensNames();
    auto filter = [&](const char* text) {
        const CompiledCriterion c = compile(parseZemaxFilter(text), names);
        const bool value = matches(c, path);
        EXPECT_EQ(value, evaluateDirect(c, path).value) << text;
        return value;
    };
    EXPECT_TRUE(filter("H2"));  // TIR at 2 is an event at 2
    EXPECT_TRUE(filter("h7"));  // the detector hit too; letters are case-insensitive
    EXPECT_FALSE(filter("H4"));
    EXPECT_TRUE(filter("R1"));   // Fresnel reflection
    EXPECT_FALSE(filter("R2"));  // TIR is not R
    EXPECT_FALSE(filter("r0"));  // refraction is not R
    EXPECT_TRUE(filter("T0"));
    EXPECT_TRUE(filter("t1"));
    EXPECT_FALSE(filter("T3"));  // scatter through is S, not T
    EXPECT_TRUE(filter("S3"));
    EXPECT_FALSE(filter("s2"));
    EXPECT_FALSE(filter("!S3"));
    EXPECT_TRUE(filter("!R2"));
    EXPECT_TRUE(filter("H7 & R1"));
    EXPECT_FALSE(filter("H7 & R2"));
    EXPECT_TRUE(filter("R2 | S3"));
    EXPECT_FALSE(filter("R2 | S2"));
    // Precedence: & before |, ! before both; the other grouping gives the other answer.
    EXPECT_TRUE(filter("R2 & S2 | T0"));
    EXPECT_FALSE(filter("R2 & (S2 | T0)"));
    EXPECT_TRUE(filter("!R1 | T0"));
    EXPECT_FALSE(filter("!(R1 | T0)"));
    // H is never the Emit event: the lamp (source 1) emitting does not hit object 1.
    const std::vector<PathEvent> lamp = {ev(E::Emit, 1), ev(E::Refract, 0, 0, 1), ev(E::Exit, -1)};
    EXPECT_FALSE(matches(compile(parseZemaxFilter("H1"), names), lamp));
    EXPECT_TRUE(matches(compile(parseZemaxFilter("H0"), names), lamp));
}

}  // namespace
}  // namespace veil

namespace veil {
namespace {

// The one-step reader every command uses: the same tree as parse + compile, and both kinds of
// error name the source and the column.
TEST(CompileCriterion, ParsesAndResolvesInOneStepWithErrorsAtTheSource) {
    const NameTable names = lensNames();
    const std::string text = "seq(fresnel(L4.back), fresnel(L4.front)) and not scatter";
    const CompiledCriterion one = compileCriterion(text, names, "--where 1");
    const CompiledCriterion two = compile(parseCriterion(text), names);
    ASSERT_EQ(one.nodes.size(), two.nodes.size());
    ASSERT_EQ(one.leaves.size(), two.leaves.size());
    for (size_t i = 0; i < one.leaves.size(); ++i) {
        EXPECT_EQ(one.leaves[i].set, two.leaves[i].set) << i;
        EXPECT_EQ(one.leaves[i].typeMask, two.leaves[i].typeMask) << i;
    }
    EXPECT_EQ(one.required, two.required);
    try {
        compileCriterion("hit(L9.front)", names, "--where 2");
        FAIL() << "an unknown object must be an error";
    } catch (const ParseError& e) {
        EXPECT_EQ(e.loc().file, "--where 2");
        EXPECT_EQ(e.loc().column, 5);  // the pattern, after "hit("
    }
    try {
        compileCriterion("hit(L1.front", names, "--where 3");
        FAIL() << "a missing parenthesis must be an error";
    } catch (const ParseError& e) {
        EXPECT_EQ(e.loc().file, "--where 3");
        EXPECT_GT(e.loc().column, 1);
    }
}

}  // namespace
}  // namespace veil
