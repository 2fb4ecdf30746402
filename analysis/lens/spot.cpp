#include "analysis/lens/spot.h"

#include <cmath>

#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const SpotResult& s) {
    return os << "SpotResult{field " << s.field << ", wavelength " << s.wavelength << ": "
              << s.raysLanded << "/" << s.raysTraced << " rays, centroid " << s.centroidMm
              << " mm, RMS " << s.rmsRadiusMm << " mm}";
}

std::vector<Vec2> hexapolarPupil(int rings) {
    std::vector<Vec2> pts{Vec2(0.0)};
    for (int k = 1; k <= rings; ++k) {
        const double r = static_cast<double>(k) / rings;
        const int count = 6 * k;
        for (int j = 0; j < count; ++j) {
            const double a = 2.0 * M_PI * j / count;
            pts.emplace_back(r * std::cos(a), r * std::sin(a));
        }
    }
    return pts;
}

SpotResult computeSpot(const SequentialModel& model, const RayAimer& aimer, int field, int w,
                       const SpotOptions& options) {
    SpotResult out;
    out.field = field;
    out.wavelength = w;
    const Field& f = model.prescription().system.fields.at(field);
    SequentialTraceOptions topts;
    topts.clipApertures = options.clipApertures;

    // The chief ray is a reference: traced without apertures, so that a central obscuration
    // (a Cassegrain's hole, which it always falls in) leaves it defined.
    const AimedRay chief = aimer.aim(f, 0.0, 0.0, w);
    if (chief.status == RayStatus::Ok) {
        SequentialTraceOptions chiefOptions = topts;
        chiefOptions.clipApertures = false;
        const SequentialRayResult r = traceSequential(model, w, chief.ray, chiefOptions);
        if (r.ok()) {
            const Vec3 q = model.localPoint(r.surface, r.ray.origin);
            out.chiefMm = Vec2(q.x, q.y);
        }
    }
    for (const Vec2& pp : hexapolarPupil(options.rings)) {
        ++out.raysTraced;
        const AimedRay a = aimer.aim(f, pp.x, pp.y, w);
        if (a.status != RayStatus::Ok) continue;
        const SequentialRayResult r = traceSequential(model, w, a.ray, topts);
        if (!r.ok()) continue;
        const Vec3 q = model.localPoint(r.surface, r.ray.origin);
        out.pointsMm.emplace_back(q.x, q.y);
    }
    out.raysLanded = static_cast<int>(out.pointsMm.size());
    if (out.pointsMm.empty()) return out;
    Vec2 sum(0.0);
    for (const Vec2& q : out.pointsMm) sum += q;
    out.centroidMm = sum / static_cast<double>(out.pointsMm.size());
    double s2 = 0.0, s2c = 0.0;
    for (const Vec2& q : out.pointsMm) {
        const Vec2 d = q - out.centroidMm;
        const Vec2 dc = q - out.chiefMm;
        s2 += glm::dot(d, d);
        s2c += glm::dot(dc, dc);
        out.maxRadiusMm = std::max(out.maxRadiusMm, std::sqrt(glm::dot(d, d)));
    }
    out.rmsRadiusMm = std::sqrt(s2 / out.pointsMm.size());
    out.rmsRadiusChiefMm = std::sqrt(s2c / out.pointsMm.size());
    return out;
}

}  // namespace veil
