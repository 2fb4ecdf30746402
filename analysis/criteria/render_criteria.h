#pragma once
// Path criteria for the renderer (tracer/render/path_judge.h): `veil render --where` splits the
// image by the joined path, photon events first, then the view point's backward events in the order
// light travels them, with the seed's three-state evaluator (analysis/criteria/criteria.h).
//
// Prefixes stream through an EvaluatorBank buffer; a suffix is judged on a copy. Pruning the
// backward branches needs more: whether ANY prefix could complete a suffix to a match. The
// evaluator's state after a prefix depends only on which leaves each event matched, and counts
// stop growing once a leaf is decided, so the states a prefix can reach form a finite set.
// RenderCriteria enumerates it once per criterion (breadth first, over one representative
// event per distinct set of matching leaves among the scene's names), and a suffix may match
// when it takes one of those states to true. A criterion whose reachable states exceed
// kMaxPrefixStates is never pruned backward (it still prunes photons). Verdicts are cached by
// suffix: backward rays share a few specular chains.

#include <cstddef>
#include <cstdint>
#include <map>
#include <shared_mutex>
#include <string>
#include <vector>

#include "analysis/criteria/criteria.h"
#include "tracer/render/path_judge.h"

namespace veil {

class RenderCriteria : public PathJudge {
  public:
    static constexpr size_t kMaxPrefixStates = 4096;

    // At most 64 criteria; `names` is the table they were compiled with.
    RenderCriteria(std::vector<CompiledCriterion> criteria, const NameTable& names);
    RenderCriteria(const RenderCriteria&) = delete;
    RenderCriteria& operator=(const RenderCriteria&) = delete;

    int count() const override { return static_cast<int>(criteria_.size()); }
    size_t stateBytes() const override { return bank_.bufferSize(); }
    void reset(std::byte* state) const override { bank_.reset(state); }
    uint64_t push(std::byte* state, const PathEvent& e) const override;
    uint64_t matches(const std::byte* state, std::span<const PathEvent> suffix,
                     std::byte* scratch) const override;
    uint64_t suffixMayMatch(std::span<const PathEvent> suffix) const override;

    // Whether suffixMayMatch can rule criterion c out: its prefix states were enumerated
    // and no prefix alone makes it true.
    bool prunesBackward(int c) const {
        const Prefixes& p = prefix_[static_cast<size_t>(c)];
        return p.enumerated && !p.anyTrue;
    }
    // Whether criterion c's prefix states were few enough to enumerate.
    bool enumerated(int c) const { return prefix_[static_cast<size_t>(c)].enumerated; }
    // The undecided states a prefix can bring criterion c to (when enumerated).
    size_t prefixStates(int c) const { return prefix_[static_cast<size_t>(c)].states.size(); }

  private:
    struct Prefixes {
        bool enumerated = false;  // false: too many states, every suffix may match
        bool anyTrue = false;     // some prefix alone is already true: every suffix matches
        std::vector<std::vector<std::byte>> states;  // undecided reachable states
    };
    Prefixes enumeratePrefixes(size_t c, const NameTable& names) const;

    std::vector<CompiledCriterion> criteria_;
    EvaluatorBank bank_;                 // over criteria_
    std::vector<EvaluatorBank> single_;  // one bank per criterion, for the enumeration
    std::vector<Prefixes> prefix_;
    mutable std::shared_mutex cacheMutex_;
    mutable std::map<std::string, uint64_t> cache_;  // suffix bytes -> suffixMayMatch
};

}  // namespace veil
