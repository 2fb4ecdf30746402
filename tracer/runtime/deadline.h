#pragma once

// Deadline
//
// A moment after which long work stops at its next block. The work calls check() once per
// block (a clock read, tens of nanoseconds against a block's milliseconds); once the moment has
// passed, check() throws DeadlinePassed, which leaves the parallel loop (TBB cancels the other
// blocks and rethrows in the caller) and unwinds the work without a result. The caller that set
// the deadline catches it and keeps what it had before: a render drops the pass under way, so
// its images are those of the passes that finished, bitwise those of a run stopped after them.
// A default Deadline never passes.

#include <chrono>
#include <stdexcept>

namespace veil {

class DeadlinePassed : public std::runtime_error {
  public:
    DeadlinePassed() : std::runtime_error("the time limit passed during the work") {}
};

class Deadline {
  public:
    using Clock = std::chrono::steady_clock;

    Deadline() = default;  // never
    explicit Deadline(Clock::time_point at) : at_(at), set_(true) {}

    bool set() const { return set_; }
    bool passed() const { return set_ && Clock::now() >= at_; }
    void check() const {
        if (passed()) throw DeadlinePassed();
    }

  private:
    Clock::time_point at_{};
    bool set_ = false;
};

}  // namespace veil
