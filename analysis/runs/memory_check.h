#pragma once
// What a run will hold at its peak, estimated and checked before the work: a run that would
// not fit stops at once with a message naming the options that shrink it, instead of growing
// until the machine refuses (render at 1e9 rays per pixel had allocated 16 GB at 1.5 GB/s, a
// 16384 x 16384 trace with criteria would need tens of GB).
//
//   estimate (renderMemoryBytes, traceMemoryBytes, ...)
//     --checkMemory--> nothing, or ModelError("SCENE", "the trace needs about 38.7 GB
//       (...), more than this machine's 25.2 GB: lower ...")
//
// The limit is the machine's physical memory, or its container's (cgroup v2) when lower, or
// the user's --max-memory.

#include <cstdint>
#include <string>

namespace veil {

// The machine's physical memory, or its container's limit when that is lower (cgroup v2).
double machineMemoryBytes();
// What the process holds now (the scene, its meshes and Embree's trees, the glass tables): a
// run's own memory comes on top of it.
double residentBytes();
// "0.52 GB", "38.7 GB".
std::string gigabytes(double bytes);

// A detector image's sums: flux, squared flux and ray count per pixel (tracer/records/detector.h).
constexpr double kImageBytesPerPixel = 2.0 * sizeof(double) + sizeof(uint64_t);

// Throws ModelError(object, ...) when `bytes` exceed maxBytes (when > 0) or else the machine's
// memory: "the WHAT needs about X (DETAIL), more than this machine's Y: ADVICE" (", or raise
// --max-memory" added when maxBytes set the limit).
void checkMemory(const std::string& object, const std::string& what, double bytes,
                 const std::string& detail, const std::string& advice, double maxBytes);

}  // namespace veil
