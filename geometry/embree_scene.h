#pragma once
// Closest-hit candidates over everything a ray can hit: the scene's triangle meshes in one
// Embree 3 BVH (geomID = mesh index) and its exact faces in an ExactFaceIndex
// (geometry/face_index.h). RAII owner of the device and the scene; not copyable.
//
// Precision. Embree traverses in float and its triangle hits come back as float candidates,
// which Scene refines in double on the candidate triangle. Exact faces are never intersected
// in float: the index runs the double-precision intersectFace() on the ray as the caller gave
// it, and the triangle traversal then runs only up to the nearest exact hit, rounded up by a
// relative 1e-5 (floatBeyond()) so a triangle at a near tie still reaches Scene's double
// comparison.
//
//   query(ray, tMax, startObject)
//     exact faces (double) ------- the nearest one: t, face, local normal
//     triangle BVH (float) ------- up to the nearest face (rounded up): nearest triangle
//                                  candidate (float t)
//     -> ExactCandidate (double) + MeshCandidate (float), compared in double by Scene.

#include <vector>

#include "geometry/face_index.h"
#include "geometry/triangle_mesh.h"

namespace veil {

struct MeshCandidate {
    int mesh = -1;
    int triangle = -1;
    float t = 0.0f;
};

class EmbreeScene {
  public:
    // Meshes only: the benchmarks' raw baseline.
    explicit EmbreeScene(const std::vector<TriangleMesh>& meshes);
    // Meshes and exact faces.
    EmbreeScene(const std::vector<TriangleMesh>& meshes, std::vector<ExactFaceEntry> exactFaces);
    ~EmbreeScene();
    EmbreeScene(const EmbreeScene&) = delete;
    EmbreeScene& operator=(const EmbreeScene&) = delete;

    // A triangle to skip: the one a ray starts on and its neighbours (which Scene tests in
    // double), or a candidate already refused.
    // No default member values: a query keeps an array of kMaxSkips on the stack, and
    // zeroing it on every call costs more than the rest of the bookkeeping.
    struct Skip {
        int mesh;
        int triangle;
    };
    static constexpr int kMaxSkips = 32;

    // A double distance as a float bound for Embree, rounded up by a relative 1e-5 (plus
    // 1e-5 mm): Embree then culls only what lies certainly beyond it, and a triangle at a near
    // tie still reaches the double comparison. `shift`: how far the float ray's origin was
    // moved along the ray (query()).
    static float floatBeyond(double t, double shift = 0.0) {
        return static_cast<float>(t * (1.0 + 1e-5) + 1e-5 - shift);
    }

    // The nearest exact-face hit with t in (0, exact->t] (pass t = tMax, entry = -1; a tie
    // keeps the face with the lower object id) and the nearest triangle candidate with float
    // t in [tNear, tFar], skipping up to kMaxSkips triangles. startObject: the scene object
    // the ray starts on (its own root at t ~ 0 is skipped by intersectFace). `exact` is
    // updated in place so repeated queries (beyond a refused triangle) keep what they found.
    // Returns whether a triangle candidate was found, written to `mesh` (left as it was
    // otherwise; written in place, not returned in an optional: a small struct assembled in
    // the callee and read back whole in the caller stalls store forwarding on every query).
    bool query(const Ray& ray, float tNear, float tFar, int startObject, const Skip* skips,
               int skipCount, ExactCandidate& exact, MeshCandidate& mesh) const;

    // The exact faces alone (the first half of query()): for a ray that provably meets no
    // triangle before its nearest face (Scene's sealed media).
    void nearestExact(const Ray& ray, int startObject, ExactCandidate& exact) const {
        faces_.nearest(ray, startObject, exact);
    }
    // One exact face alone (ExactFaceIndex::cross()): entry indexes exactFaces().
    bool crossExact(int entry, const Ray& ray, int startObject, double tMax,
                    FaceCrossing& hit) const {
        return faces_.cross(entry, ray, startObject, tMax, hit);
    }
    bool empty() const { return meshCount_ == 0 && faces_.empty(); }
    const std::vector<ExactFaceEntry>& exactFaces() const { return faces_.faces(); }

    // The triangle meshes' Embree scene handle, for benchmarks that call rtcIntersect1
    // directly (the raw baseline).
    void* rawScene() const { return scene_; }

  private:
    void build(const std::vector<TriangleMesh>& meshes);

    void* device_ = nullptr;  // RTCDevice
    void* scene_ = nullptr;   // RTCScene of the triangle meshes
    int meshCount_ = 0;
    ExactFaceIndex faces_;
    Bounds3 sceneBox_;          // the meshes, padded: far rays are moved onto it
    double farDistance_ = 0.0;  // origins farther than this from the box are moved
};

}  // namespace veil
