#pragma once
// Online pruning hook of the nonsequential transport: every branch carries a state that sees
// its events as they happen; once the state says the branch can never be wanted (its path
// criterion is already false), the tracer culls it (CullReason::Criterion). The criteria
// module (analysis/criteria) provides the implementation; the tracer knows only this
// interface.

#include <memory>

namespace veil {

struct PathEvent;

class BranchState {
  public:
    virtual ~BranchState() = default;
    // A copy for a child branch at a split.
    virtual std::unique_ptr<BranchState> clone() const = 0;
    // The branch's next event; false when no continuation of this path can be wanted.
    virtual bool push(const PathEvent& e) = 0;
};

class BranchFilter {
  public:
    virtual ~BranchFilter() = default;
    // The state of a new ray, before its Emit event is pushed.
    virtual std::unique_ptr<BranchState> start() const = 0;
};

}  // namespace veil
