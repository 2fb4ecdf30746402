#include "geometry/face_index.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>

namespace veil {

namespace {

// Faces join a group when their rotation matches the group's to this much (per matrix entry)
// and their origin lies this close to the group's axis (mm); the difference is added to their
// bands' padding.
constexpr double kSameRotation = 1e-12;
constexpr double kOnAxisMm = 1e-6;
// The enclosing cylinder of a group is padded by this relative amount on top of its bands'
// own padding: a cull only, so generosity costs nothing but a few band tests.
constexpr double kGroupPad = 1e-6;
// Faces remembered as intersected within one query (a face has several bands); beyond this
// a face may be intersected twice, never missed.
constexpr int kMaxTested = 16;

// How far frame f is from group frame g: the largest difference of their rotations' entries,
// and f's origin in g's coordinates.
struct FrameOffset {
    double rotation;
    Vec3 origin;
};
FrameOffset offsetFrom(const Frame& g, const Frame& f) {
    double dr = 0.0;
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r)
            dr = std::max(dr, std::abs(f.rotation[c][r] - g.rotation[c][r]));
    return {dr, g.toLocalPoint(f.translation)};
}

}  // namespace

ExactFaceIndex::ExactFaceIndex(std::vector<ExactFaceEntry> faces) : faces_(std::move(faces)) {
    for (const ExactFaceEntry& e : faces_) {
        shiftOnly_.push_back(e.frame.rotation == glm::dmat3(1.0) ? 1 : 0);
        prepared_.emplace_back(e.face);
    }
    // Group faces by axis; the first face of a group gives its frame.
    std::vector<std::vector<int>> members;
    for (size_t i = 0; i < faces_.size(); ++i) {
        const Frame& f = faces_[i].frame;
        size_t g = 0;
        for (; g < groups_.size(); ++g) {
            const FrameOffset off = offsetFrom(groups_[g].frame, f);
            if (off.rotation <= kSameRotation &&
                std::hypot(off.origin.x, off.origin.y) <= kOnAxisMm)
                break;
        }
        if (g == groups_.size()) {
            Group grp;
            grp.frame = f;
            groups_.push_back(grp);
            members.emplace_back();
        }
        members[g].push_back(static_cast<int>(i));
    }
    // Bands in group coordinates, sorted by zLo within a group.
    for (size_t g = 0; g < groups_.size(); ++g) {
        Group& grp = groups_[g];
        grp.first = static_cast<int>(up_.size());
        double zMin = std::numeric_limits<double>::infinity(), zMax = -zMin, rMax = 0.0;
        for (int i : members[g]) {
            const FrameOffset fo = offsetFrom(grp.frame, faces_[i].frame);
            const double dr = fo.rotation;
            const Vec3& off = fo.origin;
            for (const FaceBand& b : faceBands(faces_[i].face, kBandsPerCurvedFace)) {
                // A point p of the face sits at R_f p + t_f = R_g (R_g^T R_f p + off): in group
                // coordinates off + p + (R_g^T R_f - 1) p, where the last term is at most
                // 3 dr |p| per coordinate.
                const double size = std::max({b.rHi, std::abs(b.zLo), std::abs(b.zHi)});
                const double rot = 3.0 * dr * size * std::sqrt(3.0);
                const double radial = std::hypot(off.x, off.y) + 2.0 * rot;
                const double rLo = std::max(0.0, b.rLo - radial), rHi = b.rHi + radial;
                Band band;
                band.zLo = b.zLo + off.z - rot;
                band.zHi = b.zHi + off.z + rot;
                band.rLoSq = rLo * rLo;
                band.rHiSq = rHi * rHi;
                band.entry = i;
                up_.push_back(band);
                zMin = std::min(zMin, band.zLo);
                zMax = std::max(zMax, band.zHi);
                rMax = std::max(rMax, rHi);
            }
        }
        grp.count = static_cast<int>(up_.size()) - grp.first;
        std::sort(up_.begin() + grp.first, up_.end(),
                  [](const Band& a, const Band& b) { return a.zLo < b.zLo; });
        down_.insert(down_.end(), up_.begin() + grp.first, up_.end());
        std::sort(down_.begin() + grp.first, down_.end(),
                  [](const Band& a, const Band& b) { return a.zHi > b.zHi; });
        double reachUp = -std::numeric_limits<double>::infinity(), reachDown = -reachUp;
        for (int i = grp.first; i < static_cast<int>(up_.size()); ++i) {
            reachUp = std::max(reachUp, up_[i].zHi);
            reachDown = std::min(reachDown, down_[i].zLo);
            upReach_.push_back(reachUp);
            downReach_.push_back(reachDown);
        }
        const double pad = kGroupPad * (1.0 + std::max({rMax, std::abs(zMin), std::abs(zMax)}));
        grp.zMin = zMin - pad;
        grp.zMax = zMax + pad;
        grp.rMaxSq = (rMax + pad) * (rMax + pad);
        grp.identity = grp.frame.rotation == glm::dmat3(1.0);
    }
}

void ExactFaceIndex::nearest(const Ray& ray, int startObject, ExactCandidate& best) const {
    int tested[kMaxTested];
    int testedCount = 0;
    bool normalPending = false;
    Vec3 pendingPoint(0.0);
    auto intersect = [&](int entry) {
        for (int k = 0; k < testedCount; ++k)
            if (tested[k] == entry) return;
        if (testedCount < kMaxTested) tested[testedCount++] = entry;
        const ExactFaceEntry& e = faces_[entry];
        FaceCrossing hit;
        if (!cross(entry, ray, startObject, best.t, hit)) return;
        const bool nearer = hit.t < best.t || best.entry < 0 ||
                            (hit.t == best.t && e.object < faces_[best.entry].object);
        if (!nearer) return;
        best.entry = entry;
        best.t = hit.t;
        // The normal of the face that wins, once, at the end.
        normalPending = !hit.hasNormal;
        if (hit.hasNormal)
            best.localNormal = hit.normal;
        else
            pendingPoint = hit.point;
    };

    for (const Group& g : groups_) {
        const Ray r = g.identity ? Ray{ray.origin - g.frame.translation, ray.direction}
                                 : g.frame.toLocal(ray);
        const Vec3& o = r.origin;
        const Vec3& d = r.direction;
        // The ray's part inside the group's enclosing cylinder: [t0, t1], always finite (a
        // unit direction has d.z != 0 or a radial part).
        double t0 = 0.0, t1 = best.t;
        const double invDz = 1.0 / d.z;  // +-inf when d.z is 0 (used only when it is not)
        if (d.z != 0.0) {
            const double ta = (g.zMin - o.z) * invDz, tb = (g.zMax - o.z) * invDz;
            t0 = std::max(t0, std::min(ta, tb));
            t1 = std::min(t1, std::max(ta, tb));
            if (!(t0 <= t1)) continue;  // beside the group's z slab, or behind the origin
        } else if (o.z < g.zMin || o.z > g.zMax) {
            continue;
        }
        const double a = d.x * d.x + d.y * d.y;
        const double b = o.x * d.x + o.y * d.y;
        const double c = o.x * o.x + o.y * o.y;
        if (a == 0.0) {
            if (c > g.rMaxSq) continue;
        } else {
            const double disc = b * b - a * (c - g.rMaxSq);
            if (disc < 0.0) continue;
            // The roots (-b -+ sqrt(disc)) / a, the reciprocal taken beside the square root
            // (one division, off the square root's path). The cancelling form loses at most
            // 2 eps c in r^2 at the roots (b^2 <= a c), far inside the group's padding: this
            // is a cull. A subnormal a makes a root infinite or NaN, which culls nothing.
            const double invA = 1.0 / a;
            const double root = std::sqrt(disc);
            t0 = std::max(t0, (-b - root) * invA);
            t1 = std::min(t1, (root - b) * invA);
        }
        if (!(t0 <= t1)) continue;
        const double tAxis = a > 0.0 ? -b / a : 0.0;  // where r^2 is smallest
        auto rSqAt = [&](double t) {
            const double x = o.x + t * d.x, y = o.y + t * d.y;
            return x * x + y * y;
        };
        // Does the ray, within [lo, hi] of its z slab, come within the band's radii?
        auto meets = [&](const Band& band, double lo, double hi) {
            if (!(lo <= hi)) return false;
            const double rLo = rSqAt(lo), rHi = rSqAt(hi);
            if (std::max(rLo, rHi) < band.rLoSq) return false;
            const double rMin = tAxis <= lo ? rLo : tAxis >= hi ? rHi : rSqAt(tAxis);
            return rMin <= band.rHiSq;
        };
        // The sweep ends at the first band that starts beyond where the ray is at the nearest
        // hit so far (zEnd, updated after every exact intersection).
        double tEnd = std::min(t1, best.t);
        double zEnd = o.z + tEnd * d.z;
        auto test = [&](const Band& band, double lo, double hi) {
            if (!meets(band, lo, hi)) return;
            intersect(band.entry);
            if (best.t < tEnd) {
                tEnd = best.t;
                zEnd = o.z + tEnd * d.z;
            }
        };
        const double zStart = o.z + t0 * d.z;
        if (d.z > 0.0) {
            // Upward: bands by zLo from the first whose zHi reaches zStart.
            const double* reach = upReach_.data() + g.first;
            const int start =
                static_cast<int>(std::lower_bound(reach, reach + g.count, zStart) - reach);
            for (int i = g.first + start; i < g.first + g.count; ++i) {
                const Band& band = up_[i];
                if (band.zLo > zEnd) break;
                test(band, std::max(t0, (band.zLo - o.z) * invDz),
                     std::min(tEnd, (band.zHi - o.z) * invDz));
            }
        } else if (d.z < 0.0) {
            // Downward: bands by zHi from the first whose zLo reaches zStart.
            const double* reach = downReach_.data() + g.first;
            const int start = static_cast<int>(
                std::lower_bound(reach, reach + g.count, zStart, std::greater<>()) - reach);
            for (int i = g.first + start; i < g.first + g.count; ++i) {
                const Band& band = down_[i];
                if (band.zHi < zEnd) break;
                test(band, std::max(t0, (band.zHi - o.z) * invDz),
                     std::min(tEnd, (band.zLo - o.z) * invDz));
            }
        } else {
            // Across the axis: only the bands whose slab holds the ray's z.
            const double* reach = upReach_.data() + g.first;
            const int start =
                static_cast<int>(std::lower_bound(reach, reach + g.count, o.z) - reach);
            for (int i = g.first + start; i < g.first + g.count; ++i) {
                const Band& band = up_[i];
                if (band.zLo > o.z) break;
                if (band.zHi >= o.z) test(band, t0, tEnd);
            }
        }
    }
    if (normalPending) best.localNormal = faceNormal(faces_[best.entry].face, pendingPoint);
}

}  // namespace veil
