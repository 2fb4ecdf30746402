#include "geometry/frame.h"

#include <algorithm>
#include <cmath>

namespace veil {

std::ostream& operator<<(std::ostream& os, const Frame& f) {
    return os << "Frame{x " << f.rotation[0] << ", y " << f.rotation[1] << ", z " << f.rotation[2]
              << ", t " << f.translation << "}";
}

void Bounds3::extend(const Vec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
}

void Bounds3::extend(const Bounds3& b) {
    if (b.empty()) return;
    extend(b.lo);
    extend(b.hi);
}

bool Bounds3::clip(const Ray& r, double& tMin, double& tMax) const {
    if (empty()) return false;
    for (int a = 0; a < 3; ++a) {
        const double inv = 1.0 / r.direction[a];  // +-inf for axis-parallel rays: fine
        double t0 = (lo[a] - r.origin[a]) * inv;
        double t1 = (hi[a] - r.origin[a]) * inv;
        if (std::isnan(t0) || std::isnan(t1)) {
            // Origin exactly on a slab plane with a parallel ray: inside iff within the slab.
            if (r.origin[a] < lo[a] || r.origin[a] > hi[a]) return false;
            continue;
        }
        if (t0 > t1) std::swap(t0, t1);
        tMin = std::max(tMin, t0);
        tMax = std::min(tMax, t1);
        if (tMin > tMax) return false;
    }
    return true;
}

std::ostream& operator<<(std::ostream& os, const Bounds3& b) {
    return os << "Bounds3{" << b.lo << " .. " << b.hi << "}";
}

Bounds3 transformBounds(const Frame& f, const Bounds3& local) {
    Bounds3 out;
    if (local.empty()) return out;
    for (int i = 0; i < 8; ++i) {
        const Vec3 c((i & 1) ? local.hi.x : local.lo.x, (i & 2) ? local.hi.y : local.lo.y,
                     (i & 4) ? local.hi.z : local.lo.z);
        out.extend(f.toGlobalPoint(c));
    }
    return out;
}

}  // namespace veil
