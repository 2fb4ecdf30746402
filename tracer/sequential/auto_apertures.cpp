#include "tracer/sequential/auto_apertures.h"

#include <cmath>

#include "lensdata/errors.h"
#include "lensdata/prescription.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {

std::vector<double> tracedSemiDiameters(const SequentialModel& model, int rimRays) {
    const Prescription& p = model.prescription();
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
                // The beam the file's vignetting factors leave.
                const AimedRay ar =
                    aimer.aim(f, f.vdx + px * (1.0 - f.vcx), f.vdy + py * (1.0 - f.vcy), w);
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
    maxR[model.stopIndex()] = aimer.pupil().stopRadiusMm;
    return maxR;
}

Prescription withAutomaticSemiDiameters(const SequentialModel& model, int rimRays) {
    Prescription p = model.prescription();
    const int n = model.surfaceCount();
    const std::vector<double> maxR = tracedSemiDiameters(model, rimRays);
    for (int i = 1; i < n; ++i) {
        Surface& s = p.surfaces[i];
        if (s.clearSemiDiameterMm > 0.0 || s.coordinateBreak) continue;  // breaks need none
        s.clearSemiDiameterMm = maxR[i];
        s.semiDiameterAutomatic = true;
        // The rays may need more than a mechanical size the file gives (the same number
        // rounded, or a part too small): the part grows to pass them, said where it matters.
        if (s.mechSemiDiameterMm > 0.0 && s.clearSemiDiameterMm > s.mechSemiDiameterMm) {
            if (s.clearSemiDiameterMm > s.mechSemiDiameterMm * (1.0 + 1e-6))
                p.report.push_back({ImportNote::Severity::Warning, s.origin,
                                    "the traced clear semi-diameter " +
                                        messageNumber(s.clearSemiDiameterMm) +
                                        " mm exceeds the mechanical semi-diameter " +
                                        messageNumber(s.mechSemiDiameterMm) +
                                        " mm; the mechanical semi-diameter was raised to match"});
            s.mechSemiDiameterMm = s.clearSemiDiameterMm;
        }
    }
    return p;
}

}  // namespace veil
