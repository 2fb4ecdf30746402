#pragma once
// What a long run says about itself as it goes: one event type for every run and study, so
// that one reporter (cli/progress.h on standard error, a callable in Python) shows them all.
//
//   trace, paths, ghosts' Monte Carlo   {"trace", 50000 of 100000 rays}
//   render                              {"render", pass 3, total 0 (a stop rule decides),
//                                        "error 12.3 %, radius 1.2 mm, 81234 photons/s", ETA}
//   sweep                               {"sweep: variant 2 of 5 (reflectance=0.01)",
//                                        batch 3 of 16}
//   pst                                 {"pst: angle 2 of 9 (10 deg)", batch 3 of 16}
//
// A run sends its events from one thread at a time, in order; a new `task` text means the
// previous task is done.

#include <cstdint>
#include <functional>
#include <limits>
#include <string>
#include <utility>

namespace veil {

struct ProgressEvent {
    ProgressEvent() = default;
    ProgressEvent(std::string task_, uint64_t done_, uint64_t total_, std::string unit_ = "rays")
        : task(std::move(task_)), done(done_), total(total_), unit(std::move(unit_)) {}

    std::string task;           // what runs: "trace", "render", "sweep: variant 2 of 5 (...)"
    uint64_t done = 0;          // units done so far
    uint64_t total = 0;         // units in all; 0 = not known ahead (a render's stop rules)
    // Plural: "rays", "passes", "batches"; empty for a phase that counts nothing (its name and
    // time are shown: "render: preparing, 4.2 s").
    std::string unit = "rays";
    std::string state;          // what the run knows besides the count ("error 12.3 %")
    // Seconds left when the run can tell better than done / total can (a render's error
    // falling as the passes go); NaN otherwise.
    double etaSeconds = std::numeric_limits<double>::quiet_NaN();
};

using ProgressSink = std::function<void(const ProgressEvent&)>;

}  // namespace veil
