#pragma once
// The nearest exact face along a ray, found in double precision without a BVH.
//
// Every exact face is a piece of a solid of revolution about its local z axis (surface
// patches, flats, annuli, butt-end cylinders). Faces that share an axis (in a lens scene,
// nearly all of them) form one group, and each face is a few bands of that group:
// rLo <= r <= rHi, zLo <= z <= zHi in the group's frame (faceBands()). A query transforms the
// ray once per group, clips it to the group's enclosing cylinder (a ray that passes beside
// the lens costs one quadratic), then tests each band: the ray's interval inside the band's
// z slab, and whether r^2 along it (a convex quadratic in t) reaches the band's radial range.
// Bands are visited in the order the ray moves along the axis (sorted by zLo for a ray going
// toward +z, by zHi for one going toward -z), starting at the first band that reaches the
// ray's start, and the faces whose bands the ray meets are intersected exactly at once
// (intersectFace(), in their own frames). The sweep ends at the first band that starts beyond
// the nearest hit found: inside a lens, usually right after the face the ray hits.
//
// Conservative by construction: bands are padded (faceBands()), plus the offset and rotation
// difference between a face's frame and its group's, so every hit intersectFace() would
// report lies inside a band the query tests; the closest-hit oracle test compares against a
// loop over all faces. A face on no shared axis is a group of its own.
//
// Replaced the exact faces as Embree user geometry (docs/performance.md): on the tracer's
// segment rays Embree's user-geometry traversal alone cost more than this whole query.

#include <vector>

#include "geometry/exact_face.h"

namespace veil {

// An exact face as the index sees it: placement, shape and the scene object it belongs to.
struct ExactFaceEntry {
    int object = -1;
    Frame frame;
    FaceGeometry face;
};

// The nearest exact hit of a query.
struct ExactCandidate {
    int entry = -1;  // index into the exact-face list; -1 = none
    double t = 0.0;
    Vec3 localNormal{0.0};  // in the face's local frame
};

class ExactFaceIndex {
  public:
    // Radial bands per curved face (faceBands()): more bands hug a curved face more tightly
    // (fewer exact intersections of rays passing inside a lens) at more tests per query. Since
    // the faces are prepared (PreparedFace: a crossing costs little more than a band test),
    // one band per face is fastest (docs/performance.md: 1, 2, 3, 4 bands measured).
    static constexpr int kBandsPerCurvedFace = 1;

    ExactFaceIndex() = default;
    explicit ExactFaceIndex(std::vector<ExactFaceEntry> faces);

    // The nearest exact-face hit with t in (0, best.t]; on entry best.t is the limit (tMax)
    // and best.entry -1 or an earlier find. A tie keeps the face with the lower object id.
    // startObject: the scene object the ray starts on (its own root at t ~ 0 is skipped by
    // intersectFace()).
    void nearest(const Ray& ray, int startObject, ExactCandidate& best) const;
    // Where the ray (global) crosses one entry's face with t in (0, tMax], whatever lies
    // before it; `hit` in the face's local frame. The same crossing nearest() computes for
    // that face (its prepared form): bit for bit where nearest() finds the face first, except
    // on root-searched shapes, whose search depends on the interval (geometry/scene.h).
    // Inlined: nearest() calls it for every face a ray's bands reach.
    [[gnu::always_inline]] bool cross(int entry, const Ray& ray, int startObject, double tMax,
                                      FaceCrossing& hit) const {
        const ExactFaceEntry& e = faces_[static_cast<size_t>(entry)];
        // A face on the z axis (every lens face) is reached by a shift alone: the same local
        // ray as the rotation by the identity, without its 18 products.
        const Ray local = shiftOnly_[static_cast<size_t>(entry)]
                              ? Ray{ray.origin - e.frame.translation, ray.direction}
                              : e.frame.toLocal(ray);
        return prepared_[static_cast<size_t>(entry)].cross(e.face, local, 0.0, tMax,
                                                           e.object == startObject, hit);
    }

    const std::vector<ExactFaceEntry>& faces() const { return faces_; }
    bool empty() const { return faces_.empty(); }
    int groupCount() const { return static_cast<int>(groups_.size()); }

  private:
    struct Group {
        Frame frame;            // the first member's frame; bands are in its coordinates
        bool identity = false;  // frame.rotation is the identity (a lens on the z axis)
        double zMin = 0.0;      // enclosing cylinder of all bands, padded
        double zMax = 0.0;
        double rMaxSq = 0.0;
        int first = 0, count = 0;  // bands [first, first + count) of up_ and down_
    };
    struct Band {
        double zLo, zHi, rLoSq, rHiSq;
        int entry;
    };
    // Per group, its bands twice: up_ sorted by zLo with reach = the largest zHi so far (the
    // first band that reaches a z is found by binary search), down_ sorted by zHi downward
    // with reach = the smallest zLo so far.
    std::vector<ExactFaceEntry> faces_;
    std::vector<unsigned char> shiftOnly_;  // per face: its rotation is the identity
    std::vector<PreparedFace> prepared_;    // per face
    std::vector<Group> groups_;
    std::vector<Band> up_, down_;
    std::vector<double> upReach_, downReach_;
};

}  // namespace veil
