#include "tracer/sequential/sequential_trace.h"

#include <cmath>

#include "tracer/sequential/sequential_model.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const SequentialRayResult& r) {
    return os << "SequentialRayResult{" << r.status << " at surface " << r.surface << ", " << r.ray
              << "}";
}

std::optional<Vec3> refract(const Vec3& d, const Vec3& nrm, double n1, double n2) {
    Vec3 out;
    if (!refractInto(d, nrm, n1, n2, out)) return std::nullopt;
    return out;
}

bool refractInto(const Vec3& d, const Vec3& nrm, double n1, double n2, Vec3& result) {
    // Orient the normal against the incoming ray so cosI >= 0.
    Vec3 nn = nrm;
    double cosI = -glm::dot(d, nn);
    if (cosI < 0.0) {
        nn = -nn;
        cosI = -cosI;
    }
    const double mu = n1 / n2;
    const double sin2T = mu * mu * std::max(0.0, 1.0 - cosI * cosI);
    if (sin2T > 1.0) return false;
    const double cosT = std::sqrt(1.0 - sin2T);
    const Vec3 out = mu * d + (mu * cosI - cosT) * nn;
    result = glm::normalize(out);
    return true;
}

Vec3 reflect(const Vec3& d, const Vec3& nrm) { return d - 2.0 * glm::dot(d, nrm) * nrm; }

SequentialRayResult traceSequential(const SequentialModel& model, int w, const Ray& start,
                                    const SequentialTraceOptions& options) {
    SequentialRayResult result;
    const int last = options.lastSurface < 0 ? model.imageIndex() : options.lastSurface;
    Vec3 p = start.origin;
    Vec3 d = start.direction;
    result.ray = start;
    result.surface = options.firstSurface - 1;
    const double len = glm::length(d);
    if (!(len > 0.0) || !std::isfinite(len) || !std::isfinite(p.x + p.y + p.z)) {
        result.status = RayStatus::Invalid;
        return result;
    }
    d /= len;
    for (int i = options.firstSurface; i <= last; ++i) {
        const SequentialSurface& s = model.surface(i);
        if (s.coordinateBreak) {
            // Only the frame changes: the ray goes on in the same medium to the next surface.
            result.surface = i;
            if (options.recordPath) result.path.push_back(result.ray);
            continue;
        }
        const Ray local = s.toLocal(p, d);
        const std::optional<double> t = intersectSequential(s.shape, local);
        const Vec3 localHit = t ? local.origin + *t * local.direction : Vec3(0.0);
        // A crossing farther than any lens reaches (a ray all but parallel to a plane that a
        // coordinate break turned along the beam) is no crossing: the ray misses.
        const double rSq = localHit.x * localHit.x + localHit.y * localHit.y;
        if (!t || !(rSq <= kAsphereSearchRadiusMm * kAsphereSearchRadiusMm)) {
            result.status = RayStatus::Missed;
            result.surface = i;
            return result;
        }
        const double nBefore = std::abs(model.index(i - 1, w));
        result.opticalPathMm += nBefore * *t;
        p = s.toGlobalPoint(localHit);
        result.ray = {p, d};
        result.surface = i;
        if (options.clipApertures) {
            // The clear aperture is the annulus inner <= r <= clear; either edge clips.
            const double r = std::hypot(localHit.x, localHit.y);
            if ((s.vignettes && r > s.clearSemiDiameterMm) || r < s.innerSemiDiameterMm) {
                result.status = RayStatus::Clipped;
                return result;
            }
        }
        const Vec3 nrm = surfaceNormal(s.shape, localHit);
        Vec3 dl = local.direction;
        if (s.mirror) {
            dl = reflect(dl, nrm);
        } else {
            const double nAfter = std::abs(model.index(i, w));
            if (nAfter != nBefore) {
                const std::optional<Vec3> r = refract(dl, nrm, nBefore, nAfter);
                if (!r) {
                    result.status = RayStatus::TotalInternalReflection;
                    return result;
                }
                dl = *r;
            }
        }
        d = s.toGlobalDirection(dl);
        result.ray.direction = d;
        if (options.recordPath) result.path.push_back(result.ray);
    }
    result.status = RayStatus::Ok;
    return result;
}

}  // namespace veil
