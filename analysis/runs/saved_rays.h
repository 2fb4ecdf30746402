#pragma once
// A trace's rays kept in a ray database (veil trace --save-rays, docs/ray-database.md): how
// large the file will be, said and checked against the free disk before tracing, and what the
// file says of the scene.
//
//   PreparedScene + the trace's options --estimateRayDatabase--> bytes per ray (from the
//   run's own first rays: ray i is the same ray in any run with the same seed)
//     --checkFits--> ParseError at --save-rays when the disk would fill
//   PreparedScene --rayDatabaseInfo--> the header RayDatabaseWriter writes

#include <cstdint>
#include <filesystem>
#include <string>

#include "tracer/records/ray_database.h"

namespace veil {

struct PathEncoding;
struct TransportOptions;
struct SceneTransport;
class PreparedScene;

struct RayDatabaseEstimate {
    uint64_t sampleRays = 0, rays = 0;  // all sources
    double bytesPerRay = 0.0, eventsPerRay = 0.0;
    double totalBytes() const { return bytesPerRay * static_cast<double>(rays); }
    // "about 12.3 MB for 20000 rays (617 B per ray, from the first 200 rays; --events-only
    // stores about a quarter) to rays.vrdb"
    std::string note(const std::string& path, const PathEncoding& encoding) const;
    // ParseError at --save-rays when the file would take more than 95 % of the free space of
    // the disk it goes to.
    void checkFits(const std::filesystem::path& path) const;
};

// Traces the run's first min(raysPerSource, 200) rays per source with their histories encoded.
RayDatabaseEstimate estimateRayDatabase(const SceneTransport& transport,
                                        const TransportOptions& options, uint64_t raysPerSource,
                                        const PathEncoding& encoding);

// The database header of a run on this scene: its objects (a detector's own name as an alias
// of its object, so criteria on the saved rays may use it), sources, seed and flux unit.
RayDatabaseInfo rayDatabaseInfo(const PreparedScene& scene, const std::string& sceneName,
                                const PathEncoding& encoding, uint64_t seed);

}  // namespace veil
