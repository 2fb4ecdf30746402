#include "geometry/surface_frames.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "geometry/qtype.h"
#include "lensdata/prescription.h"

namespace veil {

namespace {

constexpr double kDegree = 3.14159265358979323846 / 180.0;

// Within rounding of the global axis (breaks that cancel): snapped onto it.
void snapOntoAxis(Frame& f, double scaleMm) {
    const glm::dmat3 id(1.0);
    if (!sameRotation(f.rotation, id)) return;
    if (std::abs(f.translation.x) > 1e-12 * scaleMm || std::abs(f.translation.y) > 1e-12 * scaleMm)
        return;
    f.rotation = id;
    f.translation.x = f.translation.y = 0.0;
}

}  // namespace

bool sameRotation(const glm::dmat3& a, const glm::dmat3& b, double tol) {
    for (int c = 0; c < 3; ++c)
        for (int r = 0; r < 3; ++r)
            if (std::abs(a[c][r] - b[c][r]) > tol) return false;
    return true;
}

Frame breakFrame(const Frame& in, const CoordinateBreak& b) {
    // Left-handed about x and y, right-handed about z (CoordinateBreak); the columns are the
    // new axes in the incoming frame.
    const double ax = b.tiltXDeg * kDegree, ay = b.tiltYDeg * kDegree, az = b.tiltZDeg * kDegree;
    const double cx = std::cos(ax), sx = std::sin(ax);
    const double cy = std::cos(ay), sy = std::sin(ay);
    const double cz = std::cos(az), sz = std::sin(az);
    const glm::dmat3 rx(Vec3(1.0, 0.0, 0.0), Vec3(0.0, cx, -sx), Vec3(0.0, sx, cx));
    const glm::dmat3 ry(Vec3(cy, 0.0, sy), Vec3(0.0, 1.0, 0.0), Vec3(-sy, 0.0, cy));
    const glm::dmat3 rz(Vec3(cz, sz, 0.0), Vec3(-sz, cz, 0.0), Vec3(0.0, 0.0, 1.0));
    const Vec3 shift(b.decenterXMm, b.decenterYMm, 0.0);
    Frame out;
    if (b.tiltFirst) {
        out.rotation = in.rotation * rz * ry * rx;
        out.translation = in.translation + out.rotation * shift;
    } else {
        out.rotation = in.rotation * rx * ry * rz;
        out.translation = in.translation + in.rotation * shift;
    }
    return out;
}

std::vector<Frame> surfaceFrames(const Prescription& p) {
    const int n = static_cast<int>(p.surfaces.size());
    std::vector<Frame> out(n);
    if (n == 0) return out;
    double scale = 1.0;  // the system's length scale, for the snap
    for (int i = 1; i + 1 < n; ++i) scale += std::abs(p.surfaces[i].thicknessMm);
    const double t0 = p.surfaces[0].thicknessMm;
    out[0] = Frame::alongAxis(std::isfinite(t0) ? -t0 : -kInfinity);
    Frame frame;  // the coordinate system light arrives in at surface i
    for (int i = 1; i < n; ++i) {
        const Surface& s = p.surfaces[i];
        if (s.coordinateBreak) {
            frame = breakFrame(frame, *s.coordinateBreak);
            snapOntoAxis(frame, scale);
        }
        out[i] = frame;
        frame.translation += frame.rotation * Vec3(0.0, 0.0, s.thicknessMm);
    }
    return out;
}

SurfaceShape surfaceShape(const Surface& s) {
    if (s.anamorphic) {
        const Anamorphic& a = *s.anamorphic;
        if (a.kind == Anamorphic::Kind::Biconic)
            return BiconicShape{a.xCurvature, a.xConic, s.curvature, s.conic};
        return ToroidalShape{s.curvature, s.conic, s.asphere, a.xCurvature};
    }
    std::array<double, 10> even = s.asphere;
    std::array<double, 10> overW{};
    if (s.qAsphere) {
        const QAsphere& q = *s.qAsphere;
        // Index n of the departure multiplies v^n = r^(2n): the arrays' entry n - 1.
        const bool con = q.kind == QAsphere::Kind::Con;
        const std::vector<double> d = con ? qconDeparture(q.normRadiusMm, q.terms)
                                          : qbfsDeparture(q.normRadiusMm, q.terms);
        if (d.size() > even.size() + 1)
            throw std::logic_error("surfaceShape: a Q-type departure of degree " +
                                   std::to_string(d.size() - 1) + " exceeds the asphere arrays");
        for (size_t n = 1; n < d.size(); ++n) (con ? even : overW)[n - 1] += d[n];
    }
    return makeShape(s.curvature, s.conic, even, s.oddAsphere, overW);
}

bool onAxis(const Frame& f) {
    return f.rotation == glm::dmat3(1.0) && f.translation.x == 0.0 && f.translation.y == 0.0;
}

int firstSurfaceOffAxis(const Prescription& p, const std::vector<Frame>& frames) {
    for (size_t i = 1; i < p.surfaces.size(); ++i)
        if (!p.surfaces[i].coordinateBreak && !onAxis(frames[i])) return static_cast<int>(i);
    return -1;
}

}  // namespace veil
