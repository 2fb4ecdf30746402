#pragma once
// Embree 3 over the scene's triangle meshes: candidate hits in float, which Scene refines
// in double on the candidate triangle. One Embree geometry per mesh (geomID = mesh index).
// RAII owner of the device and the scene; not copyable.

#include <optional>
#include <vector>

#include "geometry/triangle_mesh.h"

namespace veil {

struct EmbreeHit {
    int mesh = -1;
    int triangle = -1;
    float t = 0.0f;
};

class EmbreeMeshes {
  public:
    explicit EmbreeMeshes(const std::vector<TriangleMesh>& meshes);
    ~EmbreeMeshes();
    EmbreeMeshes(const EmbreeMeshes&) = delete;
    EmbreeMeshes& operator=(const EmbreeMeshes&) = delete;

    // A triangle to skip: the one a ray starts on, or a candidate already refused.
    struct Skip {
        int mesh = -1;
        int triangle = -1;
    };
    static constexpr int kMaxSkips = 4;
    // Closest hit with t in [tNear, tFar], skipping up to kMaxSkips triangles.
    std::optional<EmbreeHit> intersect(const Ray& ray, float tNear, float tFar, const Skip* skips,
                                       int skipCount) const;
    bool empty() const { return meshCount_ == 0; }

    // The raw Embree scene handle, for benchmarks that call rtcIntersect1 directly.
    void* rawScene() const { return scene_; }

  private:
    void* device_ = nullptr;  // RTCDevice
    void* scene_ = nullptr;   // RTCScene
    int meshCount_ = 0;
};

}  // namespace veil
