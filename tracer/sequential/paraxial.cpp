#include "tracer/sequential/paraxial.h"

#include "geometry/qtype.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

std::ostream& operator<<(std::ostream& os, const ParaxialRay& r) {
    os << "ParaxialRay{";
    for (int i = r.first; i <= r.last; ++i)
        os << (i > r.first ? ", " : "") << "S" << i << ": y=" << r.y[i] << " nu=" << r.nu[i];
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const ParaxialMatrix& m) {
    return os << "[[" << m.a << ", " << m.b << "], [" << m.c << ", " << m.d << "]]";
}

double paraxialCurvature(const Surface& s) {
    // z = (c + 2 a2) r^2 / 2 + O(r^4); a Qbfs departure adds its r^2 coefficient (over w,
    // which is 1 on the axis); Qcon starts at r^4.
    double c = s.curvature + 2.0 * s.asphere[0];
    if (s.qAsphere && s.qAsphere->kind == QAsphere::Kind::Bfs)
        c += 2.0 * qbfsDeparture(s.qAsphere->normRadiusMm, s.qAsphere->terms)[1];
    return c;
}

ParaxialRay traceParaxial(const SequentialModel& model, int w, int first, int last, double y,
                          double nuBefore) {
    const auto& surfaces = model.prescription().surfaces;
    ParaxialRay ray;
    ray.first = first;
    ray.last = last;
    ray.y.assign(model.surfaceCount(), 0.0);
    ray.nu.assign(model.surfaceCount(), 0.0);
    double nu = nuBefore;
    for (int i = first; i <= last; ++i) {
        if (i > first) {
            const double t = model.thicknessMm(i - 1);
            y += t * nu / model.index(i - 1, w);
        }
        const double n = i > 0 ? model.index(i - 1, w) : model.index(0, w);
        const double np = model.index(i, w);
        nu = nu - y * paraxialCurvature(surfaces[i]) * (np - n);
        ray.y[i] = y;
        ray.nu[i] = nu;
    }
    return ray;
}

ParaxialMatrix paraxialMatrix(const SequentialModel& model, int w, int first, int last) {
    // Two independent rays give the columns.
    const ParaxialRay r1 = traceParaxial(model, w, first, last, 1.0, 0.0);
    const ParaxialRay r2 = traceParaxial(model, w, first, last, 0.0, 1.0);
    return {r1.y[last], r2.y[last], r1.nu[last], r2.nu[last]};
}

}  // namespace veil
