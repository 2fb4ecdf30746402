#include "tracer/sequential/ray_aiming.h"

#include <cmath>

#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, AimMode m) {
    return os << (m == AimMode::Real ? "real" : "paraxial");
}

RayAimer::RayAimer(const SequentialModel& model, AimMode mode)
    : RayAimer(model, computePupil(model, model.primaryWavelength()), mode) {}

RayAimer::RayAimer(const SequentialModel& model, const PupilData& pupil, AimMode mode)
    : model_(&model),
      pupil_(pupil),
      mode_(mode),
      angleField_(model.prescription().system.fieldKind == SystemData::FieldKind::AngleDeg) {
    const SystemData::FieldKind kind = model.prescription().system.fieldKind;
    if (kind == SystemData::FieldKind::ParaxialImageHeightMm ||
        kind == SystemData::FieldKind::RealImageHeightMm)
        throw ModelError("fields",
                         "image-height fields must be resolved into object space first "
                         "(resolveImageHeightFields, tracer/sequential/image_fields.h)");
    if (!angleField_ && model.objectAtInfinity())
        throw ModelError("fields", "object-height fields need a finite object distance");
}

Ray RayAimer::rayThrough(double fx, double fy, double ex, double ey) const {
    const double zE = std::isfinite(pupil_.entrancePupilZMm) ? pupil_.entrancePupilZMm : 0.0;
    const Vec3 target(ex, ey, zE);
    if (angleField_) {
        const double deg = M_PI / 180.0;
        // Field angles are the ray's direction cosines' slopes: tan(x), tan(y).
        const Vec3 d = glm::normalize(Vec3(std::tan(fx * deg), std::tan(fy * deg), 1.0));
        if (model_->objectAtInfinity()) return {target, d};
        // A finite object seen under a field angle: the chief ray through the pupil centre
        // fixes the object point.
        const double zO = pupil_.objectZMm;
        const Vec3 chiefAtObject = Vec3(0.0, 0.0, zE) + d * ((zO - zE) / d.z);
        return {chiefAtObject, glm::normalize(target - chiefAtObject)};
    }
    const Vec3 objectPoint(fx, fy, pupil_.objectZMm);
    return {objectPoint, glm::normalize(target - objectPoint)};
}

AimedRay RayAimer::aim(double fx, double fy, double px, double py, int w) const {
    AimedRay out;
    const double epr = pupil_.entrancePupilRadiusMm;
    out.ray = rayThrough(fx, fy, px * epr, py * epr);
    if (mode_ == AimMode::Paraxial) return out;

    const int stop = model_->stopIndex();
    SequentialTraceOptions opts;
    opts.lastSurface = stop;
    opts.clipApertures = false;
    const double rs = pupil_.stopRadiusMm;
    const Vec2 target(px * rs, py * rs);
    auto stopPoint = [&](const Vec2& e, Vec2& hit) {
        const SequentialRayResult r =
            traceSequential(*model_, w, rayThrough(fx, fy, e.x, e.y), opts);
        if (!r.ok()) return false;
        const Vec3 q = model_->localPoint(r.surface, r.ray.origin);
        hit = Vec2(q.x, q.y);
        return true;
    };

    // Newton on the entrance-pupil-plane point e so that the stop hit equals the target.
    Vec2 e(px * epr, py * epr);
    const double scale = std::max(epr, 1e-6);
    const double h = 1e-6 * scale;
    const double tol = 1e-12 * std::max(1.0, rs);
    for (int it = 0; it < 50; ++it) {
        out.iterations = it + 1;
        Vec2 s0, sx, sy;
        if (!stopPoint(e, s0)) {
            out.status = RayStatus::Invalid;
            return out;
        }
        const Vec2 r = s0 - target;
        if (std::abs(r.x) <= tol && std::abs(r.y) <= tol) {
            out.ray = rayThrough(fx, fy, e.x, e.y);
            return out;
        }
        if (!stopPoint(e + Vec2(h, 0.0), sx) || !stopPoint(e + Vec2(0.0, h), sy)) {
            // Step from the other side when the forward difference leaves the surface.
            if (!stopPoint(e - Vec2(h, 0.0), sx) || !stopPoint(e - Vec2(0.0, h), sy)) {
                out.status = RayStatus::Invalid;
                return out;
            }
            sx = s0 - (sx - s0);
            sy = s0 - (sy - s0);
        }
        const double j11 = (sx.x - s0.x) / h, j21 = (sx.y - s0.y) / h;
        const double j12 = (sy.x - s0.x) / h, j22 = (sy.y - s0.y) / h;
        const double det = j11 * j22 - j12 * j21;
        if (!(std::abs(det) > 0.0) || !std::isfinite(det)) {
            out.status = RayStatus::Invalid;
            return out;
        }
        const Vec2 step((j22 * r.x - j12 * r.y) / det, (-j21 * r.x + j11 * r.y) / det);
        e -= step;
        if (std::abs(step.x) <= 1e-15 * scale && std::abs(step.y) <= 1e-15 * scale) {
            out.ray = rayThrough(fx, fy, e.x, e.y);
            return out;
        }
    }
    out.status = RayStatus::Invalid;
    return out;
}

}  // namespace veil
