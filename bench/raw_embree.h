#pragma once
// The baseline of the benchmarks: rtcIntersect1 on an Embree scene, one query per ray, with
// nothing of veil around it. Returns the number of rays that hit something.

#include <embree3/rtcore.h>

#include <limits>
#include <vector>

#include "geometry/embree_scene.h"

namespace veil::bench {

inline long long rawEmbreeHits(const EmbreeScene& meshes, const std::vector<Ray>& rays) {
    RTCScene scene = static_cast<RTCScene>(meshes.rawScene());
    long long hits = 0;
    for (const Ray& r : rays) {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRayHit rh{};
        rh.ray.org_x = static_cast<float>(r.origin.x);
        rh.ray.org_y = static_cast<float>(r.origin.y);
        rh.ray.org_z = static_cast<float>(r.origin.z);
        rh.ray.dir_x = static_cast<float>(r.direction.x);
        rh.ray.dir_y = static_cast<float>(r.direction.y);
        rh.ray.dir_z = static_cast<float>(r.direction.z);
        rh.ray.tnear = 0.0f;
        rh.ray.tfar = std::numeric_limits<float>::infinity();
        rh.ray.mask = ~0u;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &ctx, &rh);
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    return hits;
}

}  // namespace veil::bench
