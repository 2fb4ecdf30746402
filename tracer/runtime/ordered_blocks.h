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

#include "tracer/runtime/ranks.h"

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

// The same across the ranks of `ranks` (tracer/runtime/ranks.h): block b is produced on rank
// b mod K (by its threads, as above), and rank 0 consumes every block in block order, those of
// the other ranks as they arrive (pack(Result) -> Bytes there, unpack(Bytes) -> Result on rank
// 0). Rank 0's sums are then bitwise those of one process for any K; the other ranks consume
// nothing. A rank posts its blocks and goes on; it waits once `live` of them are under way,
// so each holds at most about 2 `live` results whatever the run's length.
template <class Produce, class Consume, class Pack, class Unpack>
void forBlocksInOrderOnRanks(const Ranks& ranks, uint64_t count, uint64_t blockSize,
                             Produce&& produce, Consume&& consume, Pack&& pack, Unpack&& unpack,
                             size_t live = defaultLiveBlocks()) {
    if (ranks.single()) {
        forBlocksInOrder(count, blockSize, produce, consume, live);
        return;
    }
    blockSize = std::max<uint64_t>(1, blockSize);
    const uint64_t blocks = (count + blockSize - 1) / blockSize;
    const uint64_t k = static_cast<uint64_t>(ranks.size());
    const uint64_t r = static_cast<uint64_t>(ranks.rank());
    const uint64_t mine = ranks.ownedCount(blocks);
    // Local block j is global block j k + r.
    auto produceLocal = [&](uint64_t j, uint64_t) {
        const uint64_t first = (j * k + r) * blockSize;
        return produce(first, std::min(count, first + blockSize));
    };
    using Result = decltype(produce(uint64_t{0}, uint64_t{0}));
    if (!ranks.root()) {
        forBlocksInOrder(
            mine, 1, produceLocal, [&](Result& result) { ranks.post(0, pack(result), live); },
            live);
        ranks.waitPosted();
        return;
    }
    // Rank 0: its block j k, then the blocks j k + 1 .. j k + K - 1 of the others.
    uint64_t j = 0;
    forBlocksInOrder(
        mine, 1, produceLocal,
        [&](Result& result) {
            consume(result);
            for (uint64_t q = 1; q < k && j * k + q < blocks; ++q) {
                Result theirs = unpack(ranks.receive(static_cast<int>(q)));
                consume(theirs);
            }
            ++j;
        },
        live);
}

}  // namespace veil
