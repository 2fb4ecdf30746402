#pragma once
// Random criteria, paths and names for the criteria property tests (criteria_test.cpp,
// render_criteria_test.cpp): criteria of every node and leaf kind and count form over a small
// name table, paths that start with an emission.

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "analysis/criteria/criteria.h"
#include "tracer/records/path_history.h"

namespace veil::test {

class RandomCriteria {
  public:
    explicit RandomCriteria(uint32_t seed) : rng_(seed) {}

    int uniform(int lo, int hi) { return std::uniform_int_distribution<int>(lo, hi)(rng_); }

    Criterion criterion(int budget) {
        Criterion c;
        if (budget <= 1 || uniform(0, 3) == 0) return leaf();
        const int k = uniform(0, 3);
        if (k == 0) {
            c.kind = Criterion::Kind::Not;
            c.children.push_back(criterion(budget - 1));
            return c;
        }
        c.kind = k == 1   ? Criterion::Kind::And
                 : k == 2 ? Criterion::Kind::Or
                          : Criterion::Kind::Seq;
        int left = budget - 1;
        const int n = uniform(1, std::min(4, left));
        for (int i = 0; i < n && left > 0; ++i) {
            const int share = i == n - 1 ? left : uniform(1, std::max(1, left - (n - 1 - i)));
            Criterion ch = criterion(share);
            left -= static_cast<int>(ch.nodeCount());
            c.children.push_back(std::move(ch));
        }
        return c;
    }

    Criterion leaf() {
        Criterion c;
        c.leaf = static_cast<LeafKind>(uniform(0, kLeafKindCount - 1));
        const int universe = c.leaf == LeafKind::Emit ? 2 : c.leaf == LeafKind::Medium ? 3 : 5;
        const int np = uniform(0, 2);
        for (int i = 0; i < np; ++i) {
            if (c.leaf == LeafKind::Detector) {
                c.patterns.push_back(
                    {uniform(0, 1) ? "d*"
                                   : std::string("#").append(std::to_string(uniform(3, 4)))});
            } else if (c.leaf == LeafKind::Property) {
                c.patterns.push_back({uniform(0, 1) ? "p?" : "p1"});
            } else {
                c.patterns.push_back(
                    {std::string("#").append(std::to_string(uniform(0, universe - 1)))});
            }
        }
        switch (uniform(0, 5)) {
            case 0:
                c.count = {uniform(1, 3), uniform(3, 4)};
                break;
            case 1:
                c.count = {uniform(0, 2), uniform(0, 2)};
                break;
            case 2:
                c.count = {uniform(2, 3), CountRange::kUnbounded};
                break;
            default:
                break;
        }
        if (c.count.min > c.count.max) std::swap(c.count.min, c.count.max);
        if (c.count.min == 0 && c.count.max == CountRange::kUnbounded) c.count.min = 1;
        return c;
    }

    std::vector<PathEvent> path() {
        std::vector<PathEvent> p;
        const int n = uniform(0, 14);
        int medium = 0;
        for (int i = 0; i < n; ++i) {
            PathEvent e;
            e.type =
                i == 0 ? EventType::Emit : static_cast<EventType>(uniform(0, kEventTypeCount - 1));
            e.object = e.type == EventType::Emit ? uniform(0, 1) : uniform(-1, 4);
            e.mediumBefore = static_cast<int16_t>(medium);
            if (uniform(0, 2) == 0) medium = uniform(0, 2);
            e.mediumAfter = static_cast<int16_t>(medium);
            p.push_back(e);
        }
        return p;
    }

  private:
    std::mt19937 rng_;
};

inline NameTable randomNames() {
    NameTable t;
    t.objects = {{"o0", {}, "p1", false},
                 {"o1", {"a1"}, "p2", false},
                 {"o2", {}, "", false},
                 {"d3", {}, "p1", true},
                 {"d4", {}, "", true}};
    t.media = {"m0", "m1", "m2"};
    t.sources = {"s0", "s1"};
    return t;
}

}  // namespace veil::test
