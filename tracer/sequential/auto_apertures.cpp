#include "tracer/sequential/auto_apertures.h"

#include <cmath>
#include <functional>

#include "lensdata/errors.h"
#include "lensdata/prescription.h"
#include "tracer/sequential/ray_aiming.h"
#include "tracer/sequential/sequential_model.h"
#include "tracer/sequential/sequential_trace.h"

namespace veil {

namespace {

// Samples along a segment when looking for where it crosses a mirror's surface.
constexpr int kCrossingSamples = 16;
constexpr int kCrossingBisections = 60;
// A hole opened for returning light is this much wider than the widest crossing.
constexpr double kHoleMargin = 1.05;

// Every ray of the bundle (the chief ray and rimRays around the rim of the pupil the fields'
// vignetting factors leave, per field and wavelength), traced without clipping, with its
// path; `first` is the surface of path[0].
void forEachBundleRay(const SequentialModel& model, const RayAimer& aimer, int rimRays,
                      const std::function<void(const SequentialRayResult&, int first)>& use,
                      int* aimFailures = nullptr) {
    const Prescription& p = model.prescription();
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
                const AimedRay ar =
                    aimer.aim(f, f.vdx + px * (1.0 - f.vcx), f.vdy + py * (1.0 - f.vcy), w);
                if (ar.status != RayStatus::Ok) {
                    if (aimFailures) ++*aimFailures;
                    continue;
                }
                use(traceSequential(model, w, ar.ray, opts), opts.firstSurface);
            }
        }
    }
}

// The largest radius at which the segment a -> b (global) crosses surface s within
// `within` mm of its axis; -1 when it does not.
double crossingRadius(const SequentialModel& model, int s, const Vec3& a, const Vec3& b,
                      double within) {
    const SurfaceShape& shape = model.surface(s).shape;
    auto f = [&](double t) {
        const Vec3 q = model.localPoint(s, a + t * (b - a));
        return std::make_pair(q.z - sagAt(shape, q.x, q.y), std::hypot(q.x, q.y));
    };
    double best = -1.0;
    double t0 = 0.0;
    double f0 = f(t0).first;
    for (int k = 1; k <= kCrossingSamples; ++k) {
        const double t1 = static_cast<double>(k) / kCrossingSamples;
        const double f1 = f(t1).first;
        if (std::isfinite(f0) && std::isfinite(f1) && (f0 < 0.0) != (f1 < 0.0)) {
            double lo = t0, hi = t1, flo = f0;
            for (int i = 0; i < kCrossingBisections; ++i) {
                const double mid = 0.5 * (lo + hi);
                const double fm = f(mid).first;
                if ((fm < 0.0) == (flo < 0.0)) {
                    lo = mid;
                    flo = fm;
                } else {
                    hi = mid;
                }
            }
            const double r = f(0.5 * (lo + hi)).second;
            if (r <= within) best = std::max(best, r);
        }
        t0 = t1;
        f0 = f1;
    }
    return best;
}

}  // namespace

std::vector<double> tracedSemiDiameters(const SequentialModel& model, int rimRays,
                                        BundleFailures* failures) {
    const int n = model.surfaceCount();
    std::vector<double> maxR(n, 0.0);
    if (failures) {
        failures->count.assign(n, 0);
        failures->last.assign(n, RayStatus::Ok);
        failures->aim = 0;
    }
    const RayAimer aimer(model, AimMode::Real);
    forEachBundleRay(
        model, aimer, rimRays,
        [&](const SequentialRayResult& r, int first) {
            for (size_t i = 0; i < r.path.size(); ++i) {
                const int s = first + static_cast<int>(i);
                const Vec3 q = model.localPoint(s, r.path[i].origin);
                maxR[s] = std::max(maxR[s], std::hypot(q.x, q.y));
            }
            if (failures && !r.ok() && r.surface >= 0 && r.surface < n) {
                ++failures->count[r.surface];
                failures->last[r.surface] = r.status;
            }
        },
        failures ? &failures->aim : nullptr);
    maxR[model.stopIndex()] = aimer.pupil().stopRadiusMm;
    return maxR;
}

std::vector<double> returningLightHoles(const SequentialModel& model, int rimRays) {
    const Prescription& p = model.prescription();
    const int n = model.surfaceCount();
    std::vector<int> mirrors;
    for (int i = 1; i + 1 < n; ++i) {
        const Surface& s = p.surfaces[i];
        if (s.mirror && p.surfaces[i - 1].material.isAir() && s.innerSemiDiameterMm == 0.0 &&
            s.clearSemiDiameterMm > 0.0)
            mirrors.push_back(i);
    }
    std::vector<double> cross(n, -1.0);
    if (mirrors.empty()) return cross;
    const RayAimer aimer(model, AimMode::Real);
    forEachBundleRay(model, aimer, rimRays, [&](const SequentialRayResult& r, int first) {
        // The real points of the path: a coordinate break repeats the point before it.
        std::vector<std::pair<int, Vec3>> points;
        for (size_t i = 0; i < r.path.size(); ++i) {
            const int s = first + static_cast<int>(i);
            if (!p.surfaces[s].coordinateBreak) points.push_back({s, r.path[i].origin});
        }
        for (int m : mirrors) {
            // Segments after the light has left the mirror, between later surfaces.
            for (size_t i = 0; i + 1 < points.size(); ++i) {
                if (points[i].first <= m) continue;
                cross[m] = std::max(cross[m],
                                    crossingRadius(model, m, points[i].second, points[i + 1].second,
                                                   p.surfaces[m].clearSemiDiameterMm));
            }
        }
    });
    std::vector<double> holes(n, 0.0);
    for (int m : mirrors)
        if (cross[m] >= 0.0) holes[m] = std::max(kHoleMargin * cross[m], cross[m] + 1e-3);
    return holes;
}

Prescription withAutomaticSemiDiameters(const SequentialModel& model, int rimRays) {
    Prescription p = model.prescription();
    const int n = model.surfaceCount();
    BundleFailures failures;
    const std::vector<double> maxR = tracedSemiDiameters(model, rimRays, &failures);
    for (int i = 1; i < n; ++i) {
        Surface& s = p.surfaces[i];
        if (s.clearSemiDiameterMm > 0.0 || s.coordinateBreak) continue;  // breaks need none
        const bool optical = s.mirror || !s.material.isAir() || !p.surfaces[i - 1].material.isAir();
        if (maxR[i] == 0.0 && optical && i + 1 < n) {
            // No ray crossed it: say where the bundle died, the first surface where rays failed.
            int where = -1;
            for (int j = 1; j <= i && where < 0; ++j)
                if (failures.count[j] > 0) where = j;
            std::string why;
            if (where < 0 && failures.aim > 0)
                why = ": ray aiming found no real ray for " + std::to_string(failures.aim) +
                      " of the bundle's rays (an aperture the lens cannot pass: its entrance "
                      "pupil wider than its front faces?)";
            if (where >= 0) {
                const Surface& w = p.surfaces[where];
                why = ": " + std::to_string(failures.count[where]) + " of the bundle's rays " +
                      (failures.last[where] == RayStatus::Missed
                           ? "miss " + w.name +
                                 (w.curvature != 0.0
                                      ? " (radius " + messageNumber(1.0 / w.curvature) +
                                            " mm: a sphere narrower than the beam?)"
                                      : "")
                           : "fail at " + w.name + " (" +
                                 std::string(toString(failures.last[where])) + ")");
            }
            p.report.push_back({ImportNote::Severity::Warning, s.origin,
                                "no ray of the file's beam reaches " + s.name +
                                    " off the axis, so it gets no clear semi-diameter" + why +
                                    "; check the radii (curvatures read as radii?) and the "
                                    "aperture, or give sd"});
        }
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
