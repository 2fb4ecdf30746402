// RenderCriteria (analysis/criteria/render_criteria.h) against the direct evaluator on whole paths:
// a path cut anywhere into a streamed prefix and a judged suffix gets the whole path's verdict;
// a prefix the judge calls dead never matches; a suffix the judge rules out never matches
// with any prefix, and the ruling-out happens (the pruning is not vacuous).

#include "analysis/criteria/render_criteria.h"

#include <gtest/gtest.h>

#include <iostream>

#include "tests/analysis/criteria/random_criteria.h"
#include "tracer/records/path_history.h"

namespace veil {
namespace {

using test::RandomCriteria;
using test::randomNames;

PathEvent ev(EventType t, int object, int before = 0, int after = 0) {
    return pathEvent(t, object, 0, before, after);
}

TEST(RenderCriteria, JoinedPathsGetTheWholePathsVerdict) {
    RandomCriteria gen(20261126);
    const NameTable names = randomNames();
    constexpr int kJudges = 3000, kPaths = 16, kPerJudge = 3;
    int cases = 0, trueCases = 0, deadPrefixes = 0, ruledOut = 0, notEnumerated = 0;
    for (int j = 0; j < kJudges; ++j) {
        std::vector<Criterion> crits;
        std::vector<CompiledCriterion> compiled;
        for (int c = 0; c < kPerJudge; ++c) {
            crits.push_back(gen.criterion(gen.uniform(1, 10)));
            compiled.push_back(compile(crits.back(), names));
        }
        const RenderCriteria judge(compiled, names);
        for (int c = 0; c < kPerJudge; ++c) notEnumerated += !judge.enumerated(c);
        std::vector<std::byte> state(judge.stateBytes()), scratch(judge.stateBytes());
        for (int k = 0; k < kPaths; ++k) {
            std::vector<PathEvent> path = gen.path();
            if (path.empty()) continue;
            const size_t cut = static_cast<size_t>(gen.uniform(1, static_cast<int>(path.size())));
            // A photon's events before the view point: no second emission, nothing that ends
            // a path (absorption, exit, cull, a detector hit).
            for (size_t i = 1; i < cut; ++i) {
                const EventType t = path[i].type;
                if (t == EventType::Emit || t == EventType::DetectorHit || isTerminal(t))
                    path[i].type =
                        path[i].object % 2 ? EventType::Refract : EventType::ScatterReflect;
            }
            judge.reset(state.data());
            uint64_t alive = ~uint64_t{0};
            for (size_t i = 0; i < cut; ++i) alive = judge.push(state.data(), path[i]);
            const std::span<const PathEvent> suffix(path.data() + cut, path.size() - cut);
            const uint64_t got = judge.matches(state.data(), suffix, scratch.data());
            const uint64_t may = judge.suffixMayMatch(suffix);
            for (int c = 0; c < kPerJudge; ++c) {
                const bool value = evaluateDirect(compiled[c], path).value;
                const uint64_t bit = uint64_t{1} << c;
                ASSERT_EQ((got & bit) != 0, value)
                    << "criterion " << crits[c] << "\npath " << ::testing::PrintToString(path)
                    << "\ncut at " << cut;
                if (!(alive & bit)) {
                    ASSERT_FALSE(value) << "a dead prefix matched: " << crits[c];
                    ++deadPrefixes;
                }
                if (!(may & bit)) {
                    ASSERT_FALSE(value) << "a ruled-out suffix matched: " << crits[c] << "\npath "
                                        << ::testing::PrintToString(path) << "\ncut at " << cut;
                    ++ruledOut;
                }
                ++cases;
                trueCases += value;
            }
        }
    }
    std::cout << "[render criteria] " << cases << " cases, " << trueCases << " true, "
              << deadPrefixes << " dead prefixes, " << ruledOut << " ruled-out suffixes, "
              << notEnumerated << " of " << kJudges * kPerJudge << " criteria not enumerated\n";
    // Both verdicts, and both kinds of pruning, occur often enough to have been tested.
    EXPECT_GT(trueCases, cases / 10);
    EXPECT_GT(deadPrefixes, cases / 40);
    EXPECT_GT(ruledOut, cases / 20);
    EXPECT_LT(notEnumerated, kJudges * kPerJudge / 20);
}

// Hand cases on randomNames(): objects o0..o2, detectors d3 and d4; media m0..m2; sources s0,
// s1. The suffix is the part a backward ray finds, ending at the detector.
TEST(RenderCriteria, RulesOutSuffixesByHand) {
    const NameTable names = randomNames();
    std::vector<CompiledCriterion> c;
    for (const char* text :
         {"fresnel{,0} and scatter",  // no ghost reflection anywhere
          "seq(scatter(o0), refract(o1), detector(d3))", "scatter{1}", "emit(s1)"})
        c.push_back(compileCriterion(text, names));
    const RenderCriteria judge(c, names);
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(judge.prunesBackward(k)) << k;
    EXPECT_FALSE(judge.prunesBackward(3));  // a prefix alone makes it true
    const PathEvent hit3 = ev(EventType::DetectorHit, 3), hit4 = ev(EventType::DetectorHit, 4);
    const PathEvent fresnel = ev(EventType::FresnelReflect, 1);
    const PathEvent refract = ev(EventType::Refract, 1, 0, 1);
    const PathEvent scatter0 = ev(EventType::ScatterReflect, 0);
    const PathEvent scatter2 = ev(EventType::ScatterReflect, 2);
    auto may = [&](std::vector<PathEvent> s) { return judge.suffixMayMatch(s); };
    // Criterion 0 dies on any Fresnel reflection; 1 needs its refraction at o1 then d3, with
    // nothing of its own kind between (a later refraction at o1 is allowed: seq waits); 2
    // dies on a second scatter; 3 is decided by the emission alone, so any suffix may match.
    EXPECT_EQ(may({hit3}), 0b1111u);
    EXPECT_EQ(may({fresnel, hit3}), 0b1110u);
    EXPECT_EQ(may({refract, hit4}), 0b1101u);
    EXPECT_EQ(may({scatter0, scatter2, hit3}), 0b1011u);
    EXPECT_EQ(may({scatter2, fresnel, hit4}), 0b1100u);
    // Asked again, the cache gives the same answers.
    EXPECT_EQ(may({fresnel, hit3}), 0b1110u);
    // A prefix: emitted by s0, scattered twice: criterion 2 is dead; 3 is decided only at the
    // end of the path (a count leaf waits for more events), so it stays alive.
    std::vector<std::byte> state(judge.stateBytes()), scratch(judge.stateBytes());
    judge.reset(state.data());
    judge.push(state.data(), ev(EventType::Emit, 0));
    judge.push(state.data(), scatter2);
    EXPECT_EQ(judge.push(state.data(), scatter0), 0b1011u);
    const std::vector<PathEvent> suffix{refract, hit3};
    EXPECT_EQ(judge.matches(state.data(), suffix, scratch.data()), 0b0011u);
}

}  // namespace
}  // namespace veil
