#pragma once
// A forward trace's checkpoint: what `veil trace -o DIR` writes to DIR/trace.checkpoint after a
// block of rays, at most every so many seconds, so that a run killed at any moment (kill -9, a
// machine going down) goes on with `--resume DIR` to the files the run would have written,
// byte for byte.
//
//   traceNonsequential's afterBlock (tracer/transport/nonsequential.h)
//     --writeTraceCheckpoint--> the rays added so far, the budget and the images; the
//       criterion layers with the first ray they lack; the per-ray consumer's mark (the ray
//       database's last whole chunk, tracer/records/ray_database.h)
//     --readTraceCheckpoint--> the same, checked against the run's fingerprint (scene,
//       options, criteria, consumer)
//
// Each part holds the rays below its own mark; a resumed trace starts at the lowest mark (to
// a block boundary) and each part ignores the rays it holds.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "tracer/records/detector.h"
#include "tracer/transport/nonsequential.h"

namespace veil {

class CriterionImages;

// A per-ray consumer's part of a checkpoint: the first ray it lacks, and what it needs to go on
// (its own bytes).
struct ConsumerMark {
    uint64_t nextRay = 0;
    std::string bytes;
};

struct TraceCheckpoint {
    uint64_t added = 0;  // the rays below this are in the budget and the images
    FluxBudget budget;
    std::vector<DetectorImage> images;
    bool hasLayers = false;
    uint64_t layersNextRay = 0;                      // the rays below this are in the layers
    std::vector<std::vector<DetectorImage>> layers;  // [layer][detector]
    bool hasConsumer = false;
    ConsumerMark consumer;
};

// Writes `path` atomically (PATH.tmp, then renamed). `layers` and `consumer` may be null.
// Throws std::runtime_error naming the file and the system's reason when it cannot be written.
void writeTraceCheckpoint(const std::filesystem::path& path, uint64_t fingerprint, uint64_t added,
                          const FluxBudget& budget, const std::vector<DetectorImage>& images,
                          const CriterionImages* layers, const ConsumerMark* consumer);

// Reads `path` back for a run of this fingerprint, whose images have the grids of `templates`
// and `layerCount` criterion layers (0: none). Throws ParseError({"--resume"...}) naming the
// file when it is not a trace checkpoint, is damaged, or belongs to another run.
TraceCheckpoint readTraceCheckpoint(const std::filesystem::path& path, uint64_t fingerprint,
                                    const std::vector<DetectorImage>& templates, size_t layerCount);

}  // namespace veil
