#pragma once

// Ordered Blocks
//
// Deterministic parallel accumulation with bounded memory: work split into fixed blocks
// (block b of a run is the same whatever the thread count), each produced on some thread
// into a result of its own, and every result consumed on one thread in block order. The sums
// a consumer forms are then bitwise the same for every thread count, and at most `live`
// results exist at once (the producers wait for the consumer), so a result may be as big as
// the block's work but never as big as the run: no image per block held until a reduction
// tree closes.

#include <tbb/parallel_pipeline.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cstdint>
#include <memory>

namespace veil {

// Results in flight: two per worker thread keeps every thread busy while the consumer runs.
inline size_t defaultLiveBlocks() {
    return 2 * static_cast<size_t>(std::max(1, tbb::this_task_arena::max_concurrency()));
}

// Items 0 .. count - 1 in blocks of blockSize (the last one shorter): produce(first, last)
// -> Result for each block [first, last), any thread, in parallel; consume(Result&) on one
// thread at a time, in block order. Exceptions from either propagate.
template <class Produce, class Consume>
void forBlocksInOrder(uint64_t count, uint64_t blockSize, Produce&& produce, Consume&& consume,
                      size_t live = defaultLiveBlocks()) {
    using Result = decltype(produce(uint64_t{0}, uint64_t{0}));
    blockSize = std::max<uint64_t>(1, blockSize);
    uint64_t next = 0;  // the next block's first item
    tbb::parallel_pipeline(
        std::max<size_t>(1, live),
        tbb::make_filter<void, uint64_t>(tbb::filter_mode::serial_in_order,
                                         [&](tbb::flow_control& fc) -> uint64_t {
                                             if (next >= count) {
                                                 fc.stop();
                                                 return 0;
                                             }
                                             const uint64_t first = next;
                                             next += std::min(blockSize, count - first);
                                             return first;
                                         }) &
            tbb::make_filter<uint64_t, std::shared_ptr<Result>>(
                tbb::filter_mode::parallel,
                [&](uint64_t first) {
                    const uint64_t last = first + std::min(blockSize, count - first);
                    return std::make_shared<Result>(produce(first, last));
                }) &
            tbb::make_filter<std::shared_ptr<Result>, void>(
                tbb::filter_mode::serial_in_order,
                [&](const std::shared_ptr<Result>& r) { consume(*r); }));
}

}  // namespace veil
