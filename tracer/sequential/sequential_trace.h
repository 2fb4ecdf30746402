#pragma once
// Real-ray sequential trace through a SequentialModel.
//
// Rays are in the global frame (tracer/sequential/sequential_model.h). Each surface is met in its
// own frame by intersectSequential() on the same exact shapes the nonsequential tracer uses
// (coordinate breaks are not met: the ray only passes into their frame; a crossing farther
// than kAsphereSearchRadiusMm from the vertex counts as a miss); refraction
// uses Snell's law in vector form with |n|, reflection mirrors the direction about the
// normal. The outcome of every ray is a RayStatus with the surface where it stopped.

#include <optional>
#include <ostream>
#include <vector>

#include "geometry/vec.h"
#include "tracer/sequential/ray_status.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

struct SequentialTraceOptions {
    int firstSurface = 1;       // the ray is given in the gap before this surface
    int lastSurface = -1;       // -1 = the image surface
    bool clipApertures = true;  // Clipped: outside a vignetting semi-diameter, or in a hole
    bool recordPath = false;    // keep the point and direction at every surface
};

struct SequentialRayResult {
    RayStatus status = RayStatus::Ok;
    int surface = 0;  // last surface reached (Ok) or where the ray failed
    // At the last surface reached: point on it, direction after it, both global (a surface's
    // own coordinates: SequentialModel::localPoint). At a coordinate break, the ray as it
    // left the surface before.
    Ray ray;
    double opticalPathMm = 0.0;  // sum of |n| * length from the start point
    std::vector<Ray> path;       // per surface from firstSurface (recordPath only)
    bool ok() const { return status == RayStatus::Ok; }
};
std::ostream& operator<<(std::ostream& os, const SequentialRayResult& r);

SequentialRayResult traceSequential(const SequentialModel& model, int w, const Ray& ray,
                                    const SequentialTraceOptions& options = {});

// Refraction of unit direction d at a surface with unit normal nrm (either orientation),
// from |n| = n1 into |n| = n2. nullopt on total internal reflection.
std::optional<Vec3> refract(const Vec3& d, const Vec3& nrm, double n1, double n2);
// The same written into `out` (false under total internal reflection, `out` untouched): for
// the transport's hot path, where a returned optional is read back through wider loads than
// it was written with.
bool refractInto(const Vec3& d, const Vec3& nrm, double n1, double n2, Vec3& out);
Vec3 reflect(const Vec3& d, const Vec3& nrm);

}  // namespace veil
