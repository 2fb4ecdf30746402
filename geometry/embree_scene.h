#pragma once
// Embree 3 over everything a ray can hit, in two BVHs of one device: the scene's triangle
// meshes (geomID = mesh index) and its exact faces as user geometry. A face is several
// primitives, one per piece of facePieceBounds() (a butt end as 8 sectors, a curved face as a
// central disc and rings of sectors), so the boxes hug the faces; the face's double
// intersection runs once per query whichever of its pieces the traversal meets. Two BVHs, not
// one: on the tracer's own rays a query through the small face BVH and then the triangle BVH,
// cut at the nearest face, is 10 % faster than one mixed BVH (docs/performance.md). RAII owner
// of the device and the scenes; not copyable.
//
// Precision. Embree traverses in float. Triangle hits come back as float candidates, which
// Scene refines in double on the candidate triangle. Exact faces are never intersected in
// float: the user-geometry callback runs the double-precision intersectFace() on the ray as
// the caller gave it (carried in the query context), keeps the nearest exact hit in double
// in the context, and only reports a float t to Embree (rounded up by a relative 1e-5) so
// the traversal can cull what lies behind it. The bounding box of every exact face is padded
// (see kBoundsPadRelative) to cover the difference between the float ray Embree traverses
// and the double ray the face is intersected with.
//
//   query(ray, tMax, startObject)
//     face BVH (float boxes) ----- exact faces: intersectFace() in double, nearest kept in
//                                  the context (t, face, local normal)
//     triangle BVH (float) ------- up to the nearest face (rounded up): nearest triangle
//                                  candidate (float t)
//     -> ExactCandidate (double) + MeshCandidate (float), compared in double by Scene.

#include <optional>
#include <vector>

#include "geometry/exact_face.h"
#include "geometry/triangle_mesh.h"

namespace veil {

// An exact face as the BVH sees it: placement, shape and the scene object it belongs to.
struct ExactFaceEntry {
    int object = -1;
    Frame frame;
    FaceGeometry face;
};

struct MeshCandidate {
    int mesh = -1;
    int triangle = -1;
    float t = 0.0f;
};

struct ExactCandidate {
    int entry = -1;  // index into the exact-face list; -1 = none
    double t = 0.0;
    Vec3 localNormal{0.0};  // in the face's local frame
};

class EmbreeScene {
  public:
    // Meshes only: the benchmarks' raw baseline.
    explicit EmbreeScene(const std::vector<TriangleMesh>& meshes);
    // Meshes and exact faces in one BVH.
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

    // Box padding of the exact faces: relative to the largest coordinate of the scene (plus an
    // absolute 1e-4 mm). A float ray deviates from its double original by about 1e-7 of the
    // coordinates it passes through; 1e-5 leaves a factor of 100. Rays whose origin lies far
    // outside the scene are moved to it before the float traversal (query()).
    static constexpr double kBoundsPadRelative = 1e-5;

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
    std::optional<MeshCandidate> query(const Ray& ray, float tNear, float tFar, int startObject,
                                       const Skip* skips, int skipCount,
                                       ExactCandidate& exact) const;

    bool empty() const { return meshCount_ == 0 && exactFaces_.empty(); }
    const std::vector<ExactFaceEntry>& exactFaces() const { return exactFaces_; }

    // The triangle meshes' Embree scene handle, for benchmarks that call rtcIntersect1
    // directly (the raw baseline).
    void* rawScene() const { return scene_; }

  private:
    void build(const std::vector<TriangleMesh>& meshes);

    void* device_ = nullptr;     // RTCDevice
    void* scene_ = nullptr;      // RTCScene of the triangle meshes
    void* faceScene_ = nullptr;  // RTCScene of the exact faces (user geometry)
    int meshCount_ = 0;
    std::vector<ExactFaceEntry> exactFaces_;
    std::vector<Bounds3> exactBounds_;  // per BVH primitive (face piece): global, padded
    std::vector<int> entryOfPiece_;     // per BVH primitive: its exact face
    Bounds3 sceneBox_;                  // everything, padded: far rays are moved onto it
    double farDistance_ = 0.0;          // origins farther than this from the box are moved
    void* userData_ = nullptr;          // the exact faces' callback data (owned)
};

}  // namespace veil
