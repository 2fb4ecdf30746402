#include "tracer/sequential/auto_apertures.h"

#include <cmath>

#include "lensdata/prescription.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {

Prescription withAutomaticSemiDiameters(const SequentialModel& model, int rimRays) {
    Prescription p = model.prescription();
    const int n = model.surfaceCount();
    std::vector<double> maxR(n, 0.0);
    const RayAimer aimer(model, AimMode::Real);
    SequentialTraceOptions opts;
    opts.clipApertures = false;
    opts.recordPath = true;
    std::vector<Field> fields = p.system.fields;
    if (fields.empty()) fields.push_back({});
    for (const Field& f : fields) {
        for (int w = 0; w < model.wavelengthCount(); ++w) {
            for (int k = -1; k < rimRays; ++k) {
                const double a = 2.0 * M_PI * k / rimRays;
                const double px = k < 0 ? 0.0 : std::cos(a), py = k < 0 ? 0.0 : std::sin(a);
                const AimedRay ar = aimer.aim(f, px, py, w);
                if (ar.status != RayStatus::Ok) continue;
                const SequentialRayResult r = traceSequential(model, w, ar.ray, opts);
                for (size_t i = 0; i < r.path.size(); ++i) {
                    const int s = opts.firstSurface + static_cast<int>(i);
                    const Vec3 q = model.localPoint(s, r.path[i].origin);
                    maxR[s] = std::max(maxR[s], std::hypot(q.x, q.y));
                }
            }
        }
    }
    const int stop = model.stopIndex();
    const PupilData& pupil = aimer.pupil();
    for (int i = 1; i < n; ++i) {
        Surface& s = p.surfaces[i];
        if (s.clearSemiDiameterMm > 0.0 || s.coordinateBreak) continue;  // breaks need none
        s.clearSemiDiameterMm = i == stop ? pupil.stopRadiusMm : maxR[i];
        s.semiDiameterAutomatic = true;
    }
    return p;
}

}  // namespace veil
