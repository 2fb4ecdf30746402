#include "tracer/light/source.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <map>
#include <optional>
#include <sstream>

#include "geometry/exact_face.h"
#include "geometry/numerics.h"
#include "geometry/surface_frames.h"
#include "lensdata/prescription.h"
#include "lensdata/toml_document.h"
#include "tracer/light/spectrum.h"
#include "tracer/runtime/rng.h"
#include "tracer/sequential/sequential_model.h"

namespace veil {

namespace {

constexpr double kDegree = kPi / 180.0;

// Samples of a surface profile for z ranges: enough that the sag of any practical even
// asphere between two samples moves by far less than a margin anyone would set.
constexpr int kProfileSamples = 512;

// Default gap between the window source and the front-most point of the lens (mm).
constexpr double kWindowGapMm = 0.1;

// Sun: mean angular diameter of the solar disk seen from the Earth.
constexpr double kSunAngularDiameterDeg = 0.533;

// Unit vectors u, v with (u, v, d) right-handed and orthonormal; u is global x projected
// onto the plane perpendicular to d (global y when d is near x), so an on-axis source has
// u = x, v = y.
void perpendicularBasis(const Vec3& d, Vec3& u, Vec3& v) {
    const Vec3 ref = std::abs(d.x) < 0.9 ? Vec3(1.0, 0.0, 0.0) : Vec3(0.0, 1.0, 0.0);
    u = glm::normalize(ref - glm::dot(ref, d) * d);
    v = glm::cross(d, u);
}

// A direction at polar angle theta about `axis` with 1 - cos(theta) = oneMinusCos, azimuth
// phi measured from u toward v. Written with 1 - cos so that the solar disk (1 - cos =
// 1.1e-5) keeps full precision.
Vec3 coneDirection(const Vec3& axis, const Vec3& u, const Vec3& v, double oneMinusCos, double phi) {
    const double cosT = 1.0 - oneMinusCos;
    const double sinT = std::sqrt(std::max(0.0, oneMinusCos * (2.0 - oneMinusCos)));
    return glm::normalize(sinT * std::cos(phi) * u + sinT * std::sin(phi) * v + cosT * axis);
}

// 1 - cos(a) without cancellation.
double oneMinusCos(double a) {
    const double s = std::sin(0.5 * a);
    return 2.0 * s * s;
}

// z range of a surface profile over radial distances 0..r (global z).
std::pair<double, double> profileZRange(const SurfaceShape& shape, double vertexZMm, double r) {
    r = std::min(r, maxRadius(shape));
    double lo = vertexZMm, hi = vertexZMm;
    if (!(r > 0.0)) return {lo, hi};
    if (!isRotational(shape)) {
        // No profile to sample: the enclosure of the sag over the disc.
        double zLo = 0.0, zHi = 0.0;
        sagRange(shape, 0.0, r * r, zLo, zHi);
        return {std::min(lo, vertexZMm + zLo), std::max(hi, vertexZMm + zHi)};
    }
    for (int i = 1; i <= kProfileSamples; ++i) {
        const double ri = r * i / kProfileSamples;
        const double z = sag(shape, ri * ri);
        if (!std::isfinite(z)) continue;
        lo = std::min(lo, vertexZMm + z);
        hi = std::max(hi, vertexZMm + z);
    }
    return {lo, hi};
}

std::string describe(const Vec3& v) {
    std::ostringstream os;
    os << v;
    return os.str();
}

}  // namespace

// Entrance Aperture

std::pair<double, double> EntranceAperture::zRange(double rMm) const {
    return profileZRange(shape, vertexZMm, rMm);
}

std::ostream& operator<<(std::ostream& os, const EntranceAperture& a) {
    return os << "EntranceAperture{surface " << a.surface << " " << a.surfaceName << ", z "
              << a.vertexZMm << " mm, radius " << a.radiusMm << " mm, clear " << a.clearRadiusMm
              << " mm, lens front z " << a.frontZMm << " mm}";
}

EntranceAperture entranceAperture(const Prescription& p, const SequentialModel& model) {
    if (model.surfaceCount() < 3) throw ModelError("lens", "no surface between object and image");
    // Semi-diameters from `p` (which may hold the automatic ones), falling back to the model.
    auto radii = [&](int i) {
        double clear = model.surface(i).clearSemiDiameterMm, mech = 0.0;
        if (i < static_cast<int>(p.surfaces.size())) {
            if (p.surfaces[i].clearSemiDiameterMm > 0.0) clear = p.surfaces[i].clearSemiDiameterMm;
            mech = p.surfaces[i].mechSemiDiameterMm;
        }
        return std::pair(clear, mech);
    };
    // The first surface light meets (coordinate breaks are not met).
    int first = 1;
    while (first + 1 < model.surfaceCount() && model.surface(first).coordinateBreak) ++first;
    EntranceAperture a;
    a.surface = first;
    const SequentialSurface& s = model.surface(first);
    a.surfaceName = s.name;
    if (!onAxis(s.frame))
        throw ModelError(s.name,
                         "is tilted or decentered by a coordinate break in front of it; sources "
                         "fill the first surface about the object-space axis: start the lens "
                         "with a surface on that axis (a dummy plane) before the break");
    a.shape = s.shape;
    a.vertexZMm = s.frame.translation.z;
    const auto [clear, mech] = radii(first);
    a.radiusMm = mech > 0.0 ? mech : clear;
    a.clearRadiusMm = clear > 0.0 ? clear : mech;
    a.frontZMm = kInfinity;
    for (int i = first; i < model.surfaceCount(); ++i) {
        const auto [c, m] = radii(i);
        const SequentialSurface& si = model.surface(i);
        if (si.coordinateBreak) continue;
        const double r = m > 0.0 ? m : c;
        const auto [zLo, zHi] = profileZRange(si.shape, 0.0, r);
        if (onAxis(si.frame)) {
            a.frontZMm = std::min(a.frontZMm, si.frame.translation.z + zLo);
        } else {
            // Tilted or decentered: the lowest global z of the box holding its profile.
            Bounds3 box;
            box.extend(Vec3(-r, -r, zLo));
            box.extend(Vec3(r, r, zHi));
            a.frontZMm = std::min(a.frontZMm, transformBounds(si.frame, box).lo.z);
        }
    }
    return a;
}

void checkFieldAngles(double xDeg, double yDeg, const std::string& where) {
    if (!(std::abs(xDeg) < 90.0 && std::abs(yDeg) < 90.0)) {
        std::ostringstream os;
        os << "a field angle of an object at infinity lies strictly between -90 and 90 degrees, "
              "got "
           << xDeg << "," << yDeg;
        throw ModelError(where, os.str());
    }
}

Vec3 fieldDirection(double xDeg, double yDeg) {
    return glm::normalize(Vec3(std::tan(xDeg * kDegree), std::tan(yDeg * kDegree), 1.0));
}

// Beams

double Beam::areaMm2() const { return kPi * radiusMm * radiusMm; }

std::ostream& operator<<(std::ostream& os, const Beam& b) {
    return os << "Beam{direction " << b.direction << ", start " << b.startCenterMm << ", radius "
              << b.radiusMm << " mm (aperture " << b.apertureRadiusMm << " + margin " << b.marginMm
              << "), half-angle " << b.halfAngleRad / kDegree << " deg}";
}

Beam beamFillingAperture(const EntranceAperture& a, const Vec3& direction, const BeamOptions& o) {
    const double aperture = o.radiusMm > 0.0 ? o.radiusMm : a.radiusMm;
    if (!(aperture > 0.0))
        throw ModelError(a.surfaceName,
                         "has no semi-diameter (sd or mech_sd) for the beam to fill; give the "
                         "source a radius_mm");
    const double len = glm::length(direction);
    const Vec3 d = direction / len;
    if (!(len > 0.0) || !(d.z > 0.0))
        throw ModelError(a.surfaceName,
                         "a beam must travel toward +z, not along " + describe(direction));
    Beam b;
    b.direction = d;
    perpendicularBasis(d, b.axisU, b.axisV);
    b.apertureRadiusMm = aperture;
    b.marginMm = o.marginMm;
    b.halfAngleRad = o.halfAngleRad;

    // The lit part of the first surface lies within radius r of the axis and between zLo and
    // zHi. Seen along d, from the line through (0, 0, zMid): a point (x, y, z) of it lies at
    // most r + h sin(theta) off that line (h = half the z range, theta = angle of d to the
    // axis), so a cylinder of that radius about the line holds it all.
    const double r = aperture + o.marginMm;
    const auto [zLo, zHi] = a.zRange(r);
    const double zMid = 0.5 * (zLo + zHi), h = 0.5 * (zHi - zLo);
    const double cosT = d.z, sinT = std::sqrt(std::max(0.0, 1.0 - cosT * cosT));
    const double tanT = sinT / cosT;
    const double r0 = r + h * sinT;
    // The start disk, perpendicular to d at distance t0 before the line's point at zMid,
    // reaches up to z = zMid - t0 cos(theta) + R sin(theta): place it startGap below frontZ.
    const double k = zMid - a.frontZMm + o.startGapMm;
    // A ray of the cone drifts sideways by up to tan(halfAngle) per unit of travel along d,
    // and travels at most t0 + r + h from the start disk to any point of the surface: widen
    // R by that drift, with t0 itself depending on R (t0 = (k + R sin) / cos).
    const double tanA = std::tan(o.halfAngleRad);
    if (!(tanA * tanT < 1.0))
        throw ModelError(a.surfaceName, "the beam's cone reaches 90 degrees from the axis");
    b.radiusMm = (r0 + tanA * (k / cosT + r + h)) / (1.0 - tanA * tanT);
    const double t0 = (k + b.radiusMm * sinT) / cosT;
    b.startCenterMm = Vec3(0.0, 0.0, zMid) - t0 * d;
    return b;
}

// Point Sources

double PointSource::solidAngleSr() const { return 2.0 * kPi * oneMinusCos(halfAngleRad); }

std::ostream& operator<<(std::ostream& os, const PointSource& s) {
    return os << "PointSource{at " << s.positionMm << " mm, axis " << s.axis << ", half-angle "
              << s.halfAngleRad / kDegree << " deg}";
}

PointSource pointSourceCoveringAperture(const EntranceAperture& a, const Vec3& position,
                                        double marginMm, double radiusMm) {
    const double r = (radiusMm > 0.0 ? radiusMm : a.radiusMm) + marginMm;
    if (!(r > 0.0))
        throw ModelError(a.surfaceName,
                         "has no semi-diameter (sd or mech_sd) for the point source to cover; "
                         "give the source a radius_mm");
    const double rUse = std::min(r, maxRadius(a.shape));
    // Samples of the surface: its rim finely (it bounds the cone for every surface that is a
    // height field seen from in front), the inside on a grid (the silhouette of a strongly
    // curved surface seen from close by). Between samples the angle seen from the point is
    // smooth, and where it is largest either its derivative vanishes (inside) or it runs
    // along the rim (where the rim samples lie): each sample's angle is padded by a bound on
    // how far the true maximum can exceed it (below), so the cone covers the surface.
    struct Sample {
        Vec3 point;
        double deltaSq;    // squared distance of an unsampled point to this sample
        double curvature;  // |sag''| near this sample (1 / rim radius on the rim)
        double slopeSq;    // (d sag / dr)^2 near this sample
    };
    std::vector<Sample> samples;
    constexpr int kRim = 4096, kRings = 64, kSpokes = 512;
    const double rimDelta = kPi * rUse / kRim;
    if (!isRotational(a.shape)) {
        // An anamorphic surface lies in the cylinder r <= rUse between its sag enclosure's
        // ends; a cone that holds the cylinder's two rim circles holds the cylinder (a convex
        // set lies in a convex cone when its extreme points do), and so the surface.
        double zLo = 0.0, zHi = 0.0;
        sagRange(a.shape, 0.0, rUse * rUse, zLo, zHi);
        for (double z : {a.vertexZMm + zLo, a.vertexZMm + zHi})
            for (int j = 0; j < kRim; ++j) {
                const double phi = 2.0 * kPi * j / kRim;
                samples.push_back({Vec3(rUse * std::cos(phi), rUse * std::sin(phi), z),
                                   rimDelta * rimDelta, 1.0 / rUse, 0.0});
            }
    }
    if (isRotational(a.shape)) {
        auto sagAt = [&](double rr) { return sag(a.shape, rr * rr); };
        const double dr = rUse / kRings;
        auto slopeAt = [&](double rr) {
            const double lo = std::max(0.0, rr - 0.5 * dr), hi = std::min(rUse, rr + 0.5 * dr);
            return hi > lo ? (sagAt(hi) - sagAt(lo)) / (hi - lo) : 0.0;
        };
        double sagCurvature = 0.0, slopeSq = 0.0;  // largest over the surface
        for (int i = 0; i <= kRings; ++i) {
            const double ri = std::min(rUse, i * dr);
            const double lo = std::max(0.0, ri - dr), hi = std::min(rUse, ri + dr);
            if (hi - lo > 0.0 && i > 0 && i < kRings)
                sagCurvature =
                    std::max(sagCurvature, std::abs(sagAt(hi) - 2.0 * sagAt(ri) + sagAt(lo)) /
                                               ((hi - ri) * (ri - lo)));
            slopeSq = std::max(slopeSq, slopeAt(ri) * slopeAt(ri));
        }
        sagCurvature = std::max(sagCurvature, std::abs(2.0 * sagAt(dr) / (dr * dr)));  // vertex
        const double rimZ = a.vertexZMm + sagAt(rUse);
        for (int j = 0; j < kRim; ++j) {
            const double phi = 2.0 * kPi * j / kRim;
            samples.push_back({Vec3(rUse * std::cos(phi), rUse * std::sin(phi), rimZ),
                               rimDelta * rimDelta, std::max(sagCurvature, 1.0 / rUse), slopeSq});
        }
        const double cellDeltaSq =
            0.25 * (dr * dr + std::pow(rUse * 2.0 * kPi / kSpokes, 2) + slopeSq * dr * dr);
        for (int i = 0; i < kRings; ++i) {
            const double ri = i * dr;
            const double zi = a.vertexZMm + sagAt(ri);
            const int spokes = i == 0 ? 1 : kSpokes;
            for (int j = 0; j < spokes; ++j) {
                const double phi = 2.0 * kPi * j / kSpokes;
                samples.push_back({Vec3(ri * std::cos(phi), ri * std::sin(phi), zi), cellDeltaSq,
                                   sagCurvature, slopeSq});
            }
        }
    }
    // The point must see the surface's front: in front of it where it lies within the
    // surface's reach (inside a deep concave bowl is in front, and the cone then opens past
    // 90 degrees), in front of all of it elsewhere.
    double minZ = kInfinity;
    for (const Sample& s : samples) minZ = std::min(minZ, s.point.z);
    const double rPoint = std::hypot(position.x, position.y);
    double sagLo = 0.0, sagHi = 0.0;
    if (rPoint < rUse) sagRange(a.shape, rPoint * rPoint, rPoint * rPoint, sagLo, sagHi);
    const double limitZ = rPoint < rUse ? a.vertexZMm + sagLo : minZ;
    if (!(position.z < limitZ)) {
        std::ostringstream m;
        m << "the point source at " << position << " mm is not in front of the surface "
          << "(z < " << limitZ << " mm" << (rPoint < rUse ? " at its radius" : "")
          << "); give it a half_angle_deg";
        throw ModelError(a.surfaceName, m.str());
    }

    // By symmetry the best axis lies in the meridional plane of the point: search its angle
    // psi from +z toward the point's radial direction e (golden section on the largest
    // angle to any sample, which is unimodal in psi).
    Vec3 e(position.x, position.y, 0.0);
    e = glm::length(e) > 0.0 ? glm::normalize(e) : Vec3(1.0, 0.0, 0.0);
    std::vector<Vec3> dirs;
    dirs.reserve(samples.size());
    double psiLo = kPi, psiHi = -kPi;
    for (const Sample& s : samples) {
        const Vec3 w = s.point - position;
        dirs.push_back(glm::normalize(w));
        const double psi = std::atan2(glm::dot(dirs.back(), e), dirs.back().z);
        psiLo = std::min(psiLo, psi);
        psiHi = std::max(psiHi, psi);
    }
    auto axisAt = [&](double psi) { return std::cos(psi) * Vec3(0, 0, 1) + std::sin(psi) * e; };
    auto minCos = [&](const Vec3& axis) {
        double m = 1.0;
        for (const Vec3& w : dirs) m = std::min(m, glm::dot(w, axis));
        return m;
    };
    const double g = 0.5 * (std::sqrt(5.0) - 1.0);
    double lo = psiLo, hi = psiHi;
    for (int it = 0; it < 60 && hi - lo > 1e-12; ++it) {
        const double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
        if (minCos(axisAt(x1)) > minCos(axisAt(x2)))
            hi = x2;
        else
            lo = x1;
    }
    PointSource ps;
    ps.positionMm = position;
    ps.axis = glm::normalize(axisAt(0.5 * (lo + hi)));
    perpendicularBasis(ps.axis, ps.axisU, ps.axisV);
    double half = 0.0;
    for (size_t j = 0; j < samples.size(); ++j) {
        const double angle = std::acos(std::clamp(glm::dot(dirs[j], ps.axis), -1.0, 1.0));
        const Sample& sj = samples[j];
        const double d = glm::length(sj.point - position);
        // Two bounds on how much larger the angle can be at an unsampled point near this
        // sample: first order, the angle changes by at most sqrt(1 + slope^2) / d per mm on
        // the surface; second order (at the true maximum, where the derivative along the
        // surface vanishes), its second derivative in space is at most about
        // (1 + 1 / tan(angle)) / d^2 (circles about the axis curve by 1 / (d sin(angle))).
        const double delta = std::sqrt(sj.deltaSq);
        const double firstOrder = delta * std::sqrt(1.0 + sj.slopeSq) / std::max(d - delta, 0.0);
        const double spatial = (1.0 + 1.0 / std::tan(std::max(angle, 1e-9))) / (d * d);
        const double secondOrder = sj.deltaSq * ((1.0 + sj.slopeSq) * spatial + sj.curvature / d);
        // Past 90 degrees (a point inside a concave bowl) the second-order bound's circle
        // term turns negative and bounds nothing: the first-order one holds.
        const double pad = secondOrder >= 0.0 ? std::min(firstOrder, secondOrder) : firstOrder;
        half = std::max(half, angle + pad);
    }
    ps.halfAngleRad = std::min(half, kPi);
    return ps;
}

// Area Emitters

double AreaEmitter::areaMm2() const {
    return shape == Shape::Disk ? kPi * radiusMm * radiusMm : sizeMm.x * sizeMm.y;
}

double AreaEmitter::projectedSolidAngleSr() const {
    const double s = std::sin(coneHalfAngleRad);
    return kPi * s * s;
}

bool AreaEmitter::inBlackSpot(const Vec3& w) const {
    if (!(blackSpotHalfAngleRad > 0.0)) return false;
    const Vec3 d = w - blackSpotAxis;
    return 0.5 * glm::dot(d, d) < oneMinusCos(blackSpotHalfAngleRad);
}

std::ostream& operator<<(std::ostream& os, const AreaEmitter& e) {
    os << "AreaEmitter{";
    if (e.shape == AreaEmitter::Shape::Disk)
        os << "disk radius " << e.radiusMm << " mm";
    else
        os << "rectangle " << e.sizeMm.x << " x " << e.sizeMm.y << " mm";
    return os << ", centre " << e.frame.translation << ", normal "
              << e.frame.toGlobalDirection(Vec3(0, 0, 1)) << ", cone "
              << e.coneHalfAngleRad / kDegree << " deg}";
}

// Source Kinds

const char* kindName(const SourceShape& s) {
    static constexpr const char* kNames[] = {"collimated", "sun", "point", "window", "lambertian"};
    return kNames[s.index()];
}

std::ostream& operator<<(std::ostream& os, const SourceShape& s) {
    os << kindName(s) << " ";
    std::visit(
        [&](const auto& k) {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, CollimatedSource> || std::is_same_v<T, SunSource>)
                os << k.beam;
            else if constexpr (std::is_same_v<T, PointSource>)
                os << k;
            else
                os << k.area;
        },
        s);
    return os;
}

std::ostream& operator<<(std::ostream& os, const EmittedRay& r) {
    return os << "EmittedRay{" << r.ray << ", wavelength " << r.wavelength << " (" << r.wavelengthNm
              << " nm), flux " << r.flux << "}";
}

// Source Method Definitions

Source::Source(std::string name, SourceShape shape, double totalFlux, SpectralSampler spectrum,
               FileLoc loc)
    : name_(std::move(name)),
      shape_(std::move(shape)),
      totalFlux_(totalFlux),
      spectrum_(std::move(spectrum)),
      loc_(std::move(loc)) {}

namespace {

Vec3 beamOrigin(const Beam& b, double u1, double u2) {
    const double rho = b.radiusMm * std::sqrt(u1), phi = 2.0 * kPi * u2;
    return b.startCenterMm + rho * std::cos(phi) * b.axisU + rho * std::sin(phi) * b.axisV;
}

Ray areaRay(const AreaEmitter& e, double u1, double u2, double u3, double u4) {
    Vec3 local(0.0);
    if (e.shape == AreaEmitter::Shape::Disk) {
        const double rho = e.radiusMm * std::sqrt(u1), phi = 2.0 * kPi * u2;
        local = Vec3(rho * std::cos(phi), rho * std::sin(phi), 0.0);
    } else {
        local = Vec3((u1 - 0.5) * e.sizeMm.x, (u2 - 0.5) * e.sizeMm.y, 0.0);
    }
    // Cosine law within the cone: sin^2(theta) uniform in [0, sin^2(cone)].
    const double s = std::sin(e.coneHalfAngleRad);
    const double sinSq = u3 * s * s;
    const double sinT = std::sqrt(sinSq), cosT = std::sqrt(1.0 - sinSq), phi = 2.0 * kPi * u4;
    const Vec3 dir(sinT * std::cos(phi), sinT * std::sin(phi), cosT);
    return {e.frame.toGlobalPoint(local), glm::normalize(e.frame.toGlobalDirection(dir))};
}

}  // namespace

EmittedRay Source::emit(CounterRng& rng, uint64_t rayCount) const {
    std::array<double, kEmitUniforms> u;
    for (double& x : u) x = rng.uniform();
    return emit(u, rayCount);
}

EmittedRay Source::emit(const std::array<double, kEmitUniforms>& u, uint64_t rayCount) const {
    const SpectralSampler::Sample line = spectrum_.sample(u[0]);
    EmittedRay out;
    out.wavelength = line.index;
    out.wavelengthNm = line.wavelengthNm;
    out.flux = totalFlux_ / static_cast<double>(rayCount) * line.weight;
    out.ray = std::visit(
        [&](const auto& k) -> Ray {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, CollimatedSource>) {
                return {beamOrigin(k.beam, u[1], u[2]), k.beam.direction};
            } else if constexpr (std::is_same_v<T, SunSource>) {
                const Beam& b = k.beam;
                return {beamOrigin(b, u[1], u[2]),
                        coneDirection(b.direction, b.axisU, b.axisV,
                                      u[3] * oneMinusCos(b.halfAngleRad), 2.0 * kPi * u[4])};
            } else if constexpr (std::is_same_v<T, PointSource>) {
                // Uniform over the cone's solid angle: 1 - cos(theta) uniform.
                return {k.positionMm,
                        coneDirection(k.axis, k.axisU, k.axisV, u[3] * oneMinusCos(k.halfAngleRad),
                                      2.0 * kPi * u[4])};
            } else {
                return areaRay(k.area, u[1], u[2], u[3], u[4]);
            }
        },
        shape_);
    // A ray drawn into an area's black spot carries nothing.
    std::visit(
        [&](const auto& k) {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, WindowSource> || std::is_same_v<T, LambertianSource>)
                if (k.area.inBlackSpot(out.ray.direction)) out.flux = 0.0;
        },
        shape_);
    return out;
}

// Source Evaluation

namespace {

// Tolerances of emits(): how far off its plane (relative to the source's size) and past its
// rim (relative) an origin may lie, how far (rad) from a beam's direction a direction may
// point, and the relative slack on a cone's 1 - cos: rounding in emit() (normalize, the
// frame transform) stays well inside them.
constexpr double kPlaneTolerance = 1e-9;
constexpr double kRimTolerance = 1e-12;
constexpr double kBeamDirectionTolerance = 1e-9;
constexpr double kConeTolerance = 1e-9;

// Whether unit w lies within angle a of unit axis (a >= pi: every direction).
bool inCone(const Vec3& w, const Vec3& axis, double a) {
    if (a >= kPi) return true;
    const Vec3 d = w - axis;
    return 0.5 * glm::dot(d, d) <= oneMinusCos(a) * (1.0 + kConeTolerance);
}

// Origin on a beam's start disk.
bool onStartDisk(const Beam& b, const Vec3& p) {
    const Vec3 o = p - b.startCenterMm;
    const double along = glm::dot(o, b.direction);
    const double scale = b.radiusMm + glm::length(b.startCenterMm);
    if (!(std::abs(along) <= kPlaneTolerance * scale)) return false;
    const Vec3 across = o - along * b.direction;
    return glm::dot(across, across) <= b.radiusMm * b.radiusMm * (1.0 + kRimTolerance);
}

bool onArea(const AreaEmitter& e, const Vec3& p) {
    const Vec3 local = e.frame.toLocalPoint(p);
    const double size =
        e.shape == AreaEmitter::Shape::Disk ? e.radiusMm : std::max(e.sizeMm.x, e.sizeMm.y);
    if (!(std::abs(local.z) <= kPlaneTolerance * (size + glm::length(e.frame.translation))))
        return false;
    if (e.shape == AreaEmitter::Shape::Disk)
        return local.x * local.x + local.y * local.y <=
               e.radiusMm * e.radiusMm * (1.0 + kRimTolerance);
    return std::abs(local.x) <= 0.5 * e.sizeMm.x * (1.0 + kRimTolerance) &&
           std::abs(local.y) <= 0.5 * e.sizeMm.y * (1.0 + kRimTolerance);
}

// cos(theta) of a global direction about the area's normal; <= 0 when it is not emitted.
double areaCos(const AreaEmitter& e, const Vec3& w) {
    const Vec3 local = e.frame.toLocalDirection(w);
    if (!(local.z > 0.0)) return 0.0;
    if (e.inBlackSpot(w)) return 0.0;
    const double s = std::sin(e.coneHalfAngleRad);
    if (local.x * local.x + local.y * local.y > s * s * (1.0 + kConeTolerance)) return 0.0;
    return local.z;
}

double coneSolidAngleSr(double halfAngleRad) { return 2.0 * kPi * oneMinusCos(halfAngleRad); }

}  // namespace

Source::Delta Source::delta() const {
    if (std::holds_alternative<CollimatedSource>(shape_)) return Delta::Direction;
    if (std::holds_alternative<PointSource>(shape_)) return Delta::Position;
    return Delta::None;
}

bool Source::emits(const Ray& ray) const {
    const Vec3& w = ray.direction;
    return std::visit(
        [&](const auto& k) -> bool {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, CollimatedSource>) {
                return onStartDisk(k.beam, ray.origin) &&
                       glm::length(w - k.beam.direction) <= kBeamDirectionTolerance;
            } else if constexpr (std::is_same_v<T, SunSource>) {
                return onStartDisk(k.beam, ray.origin) &&
                       inCone(w, k.beam.direction, k.beam.halfAngleRad);
            } else if constexpr (std::is_same_v<T, PointSource>) {
                const double scale = 1.0 + glm::length(k.positionMm);
                return glm::length(ray.origin - k.positionMm) <= kPlaneTolerance * scale &&
                       inCone(w, k.axis, k.halfAngleRad);
            } else {
                return onArea(k.area, ray.origin) && areaCos(k.area, w) > 0.0;
            }
        },
        shape_);
}

std::optional<double> Source::crossing(const Ray& ray, double tMax) const {
    // The plane of S: a point on it and its normal.
    Vec3 centre(0.0), normal(0.0);
    if (const auto* sun = std::get_if<SunSource>(&shape_)) {
        centre = sun->beam.startCenterMm;
        normal = sun->beam.direction;
    } else if (const auto* w = std::get_if<WindowSource>(&shape_)) {
        centre = w->area.frame.translation;
        normal = w->area.frame.toGlobalDirection(Vec3(0.0, 0.0, 1.0));
    } else if (const auto* l = std::get_if<LambertianSource>(&shape_)) {
        centre = l->area.frame.translation;
        normal = l->area.frame.toGlobalDirection(Vec3(0.0, 0.0, 1.0));
    } else {
        return std::nullopt;  // delta kinds
    }
    const double along = glm::dot(ray.direction, normal);
    if (along == 0.0) return std::nullopt;
    const double t = glm::dot(centre - ray.origin, normal) / along;
    if (!(t > 0.0 && t <= tMax)) return std::nullopt;
    const Ray light{ray.origin + t * ray.direction, -ray.direction};
    if (!emits(light)) return std::nullopt;
    return t;
}

std::optional<Source::IncidentSample> Source::sampleIncident(const Vec3& pointMm, int line,
                                                             double u1, double u2) const {
    const double share = spectrum_.share(line);
    if (!(share > 0.0)) return std::nullopt;
    // A beam: the point must lie downstream of the start disk, within its rim, along -d.
    auto beamSample = [&](const Beam& b, const Vec3& d) -> std::optional<IncidentSample> {
        const double along = glm::dot(d, b.direction);
        if (!(along > 0.0)) return std::nullopt;
        const double t = glm::dot(pointMm - b.startCenterMm, b.direction) / along;
        if (!(t > 0.0)) return std::nullopt;
        const Vec3 q = pointMm - t * d;
        const double value = emitted(q, d, line);
        if (!(value > 0.0)) return std::nullopt;
        return IncidentSample{-d, t, value, 0.0};
    };
    return std::visit(
        [&](const auto& k) -> std::optional<IncidentSample> {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, CollimatedSource>) {
                return beamSample(k.beam, k.beam.direction);
            } else if constexpr (std::is_same_v<T, SunSource>) {
                const Beam& b = k.beam;
                const double omc = oneMinusCos(b.halfAngleRad);
                const Vec3 d =
                    coneDirection(b.direction, b.axisU, b.axisV, u1 * omc, 2.0 * kPi * u2);
                auto s = beamSample(b, d);
                if (s) {
                    s->value *= coneSolidAngleSr(b.halfAngleRad);
                    s->pdfSr = 1.0 / coneSolidAngleSr(b.halfAngleRad);
                }
                return s;
            } else if constexpr (std::is_same_v<T, PointSource>) {
                const Vec3 to = k.positionMm - pointMm;
                const double d2 = glm::dot(to, to);
                if (!(d2 > 0.0)) return std::nullopt;
                const double d = std::sqrt(d2);
                const Vec3 w = to / d;
                const double value = emitted(k.positionMm, -w, line) / d2;
                if (!(value > 0.0)) return std::nullopt;
                return IncidentSample{w, d, value, 0.0};
            } else {
                const AreaEmitter& e = k.area;
                const Ray r = areaRay(e, u1, u2, 0.0, 0.0);  // the point; its direction unused
                const Vec3 to = r.origin - pointMm;
                const double d2 = glm::dot(to, to);
                if (!(d2 > 0.0)) return std::nullopt;
                const double d = std::sqrt(d2);
                const Vec3 w = to / d;
                const double cosS = areaCos(e, -w);
                if (!(cosS > 0.0)) return std::nullopt;
                const double pdf = d2 / (cosS * e.areaMm2());
                const double value = emitted(r.origin, -w, line) / pdf;
                if (!(value > 0.0)) return std::nullopt;
                return IncidentSample{w, d, value, pdf};
            }
        },
        shape_);
}

double Source::incidentPdf(const Vec3& pointMm, const Vec3& emitterPointMm,
                           const Vec3& toSource) const {
    return std::visit(
        [&](const auto& k) -> double {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, SunSource>) {
                return 1.0 / coneSolidAngleSr(k.beam.halfAngleRad);
            } else if constexpr (std::is_same_v<T, WindowSource> ||
                                 std::is_same_v<T, LambertianSource>) {
                const double cosS = areaCos(k.area, -toSource);
                if (!(cosS > 0.0)) return 0.0;
                const Vec3 d = emitterPointMm - pointMm;
                return glm::dot(d, d) / (cosS * k.area.areaMm2());
            } else {
                return 0.0;
            }
        },
        shape_);
}

double Source::emittingAreaMm2() const {
    return std::visit(
        [](const auto& k) -> double {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, CollimatedSource> || std::is_same_v<T, SunSource>)
                return k.beam.areaMm2();
            else if constexpr (std::is_same_v<T, PointSource>)
                return 0.0;
            else
                return k.area.areaMm2();
        },
        shape_);
}

double Source::emittingSolidAngleSr() const {
    return std::visit(
        [](const auto& k) -> double {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, CollimatedSource>)
                return 0.0;
            else if constexpr (std::is_same_v<T, SunSource>)
                return coneSolidAngleSr(k.beam.halfAngleRad);
            else if constexpr (std::is_same_v<T, PointSource>)
                return k.solidAngleSr();
            else
                return coneSolidAngleSr(k.area.coneHalfAngleRad);
        },
        shape_);
}

double Source::emitted(const Vec3& pointMm, const Vec3& direction) const {
    if (!emits({pointMm, direction})) return 0.0;
    return std::visit(
        [&](const auto& k) -> double {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, CollimatedSource>) {
                return totalFlux_ / k.beam.areaMm2();
            } else if constexpr (std::is_same_v<T, SunSource>) {
                const double cosT = glm::dot(direction, k.beam.direction);
                return totalFlux_ /
                       (k.beam.areaMm2() * coneSolidAngleSr(k.beam.halfAngleRad) * cosT);
            } else if constexpr (std::is_same_v<T, PointSource>) {
                return totalFlux_ / k.solidAngleSr();
            } else {
                return totalFlux_ / (k.area.areaMm2() * k.area.projectedSolidAngleSr());
            }
        },
        shape_);
}

double Source::emitted(const Vec3& pointMm, const Vec3& direction, int line) const {
    return spectrum_.share(line) * emitted(pointMm, direction);
}

double Source::pdf(const Ray& ray) const {
    if (!emits(ray)) return 0.0;
    return std::visit(
        [&](const auto& k) -> double {
            using T = std::decay_t<decltype(k)>;
            if constexpr (std::is_same_v<T, CollimatedSource>) {
                return 1.0 / k.beam.areaMm2();
            } else if constexpr (std::is_same_v<T, SunSource>) {
                return 1.0 / (k.beam.areaMm2() * coneSolidAngleSr(k.beam.halfAngleRad));
            } else if constexpr (std::is_same_v<T, PointSource>) {
                return 1.0 / k.solidAngleSr();
            } else {
                // Uniform in area, cosine law within the cone (areaRay()).
                return areaCos(k.area, ray.direction) /
                       (k.area.areaMm2() * k.area.projectedSolidAngleSr());
            }
        },
        shape_);
}

std::ostream& operator<<(std::ostream& os, Source::Delta d) {
    switch (d) {
        case Source::Delta::None:
            return os << "none";
        case Source::Delta::Direction:
            return os << "direction";
        case Source::Delta::Position:
            return os << "position";
    }
    return os << "?";
}

std::ostream& operator<<(std::ostream& os, const Source& s) {
    return os << "Source{" << s.name() << ": " << s.shape() << ", " << s.totalFlux() << " "
              << s.unit() << ", " << s.spectrum() << "}";
}

// Reading [[source]] Tables

namespace {

enum class Quantity { Flux, Irradiance, Intensity, Radiance };

struct AmountKey {
    const char* key;
    Quantity quantity;
    std::optional<FluxUnit> unit;  // nullopt: the source's `unit`
};
const AmountKey kAmountKeys[] = {
    {"flux", Quantity::Flux, std::nullopt},
    {"irradiance_w_mm2", Quantity::Irradiance, FluxUnit::Watt},
    {"illuminance_lm_mm2", Quantity::Irradiance, FluxUnit::Lumen},
    {"intensity_w_sr", Quantity::Intensity, FluxUnit::Watt},
    {"intensity_cd", Quantity::Intensity, FluxUnit::Lumen},
    {"radiance_w_mm2_sr", Quantity::Radiance, FluxUnit::Watt},
    {"luminance_cd_mm2", Quantity::Radiance, FluxUnit::Lumen},
};

// How much light a source emits, as written: one quantity (or none: the kind's default).
struct Amount {
    Quantity quantity = Quantity::Flux;
    bool given = false;
    double value = 1.0;
    FluxUnit unit = FluxUnit::Watt;
};

std::string allowedAmountKeys(Quantity second) {
    std::string list = "flux";
    for (const AmountKey& k : kAmountKeys)
        if (k.quantity == second) list += std::string(", ") + k.key;
    return list;
}

Amount readAmount(const TomlTable& t, Quantity second, const std::string& kind) {
    std::optional<FluxUnit> unit;
    const std::optional<TomlValue> unitValue = t.get("unit");
    if (unitValue) {
        const std::string s = unitValue->asString();
        if (s == "W")
            unit = FluxUnit::Watt;
        else if (s == "lm")
            unit = FluxUnit::Lumen;
        else
            unitValue->fail(unitValue->path() +
                            " must be \"W\" (radiometric) or \"lm\" "
                            "(photometric), not \"" +
                            s + "\"");
    }
    Amount a;
    std::string givenKey;
    for (const AmountKey& k : kAmountKeys) {
        if (!t.has(k.key)) continue;
        const TomlValue v = *t.get(k.key);
        if (k.quantity != Quantity::Flux && k.quantity != second)
            v.fail(std::string("'") + k.key + "' does not apply to a " + kind +
                   " source (give one of " + allowedAmountKeys(second) + ")");
        if (a.given)
            v.fail("give one of " + allowedAmountKeys(second) + ", not both '" + givenKey +
                   "' and '" + k.key + "'");
        a.given = true;
        givenKey = k.key;
        a.quantity = k.quantity;
        a.value = v.asNumber(NumberRange::above(0.0));
        if (k.unit) {
            if (unit && *unit != *k.unit)
                unitValue->fail(unitValue->path() + " is \"" + unitSymbol(*unit) + "\" but '" +
                                k.key + "' is in " + unitSymbol(*k.unit));
            unit = k.unit;
        }
    }
    a.unit = unit.value_or(FluxUnit::Watt);
    return a;
}

Vec3 readVec3(const TomlValue& v, const NumberRange& range = NumberRange::any()) {
    const std::vector<TomlValue> xs = v.asArray();
    if (xs.size() != 3) v.failExpected("a triple [x, y, z]");
    return {xs[0].asNumber(range), xs[1].asNumber(range), xs[2].asNumber(range)};
}

// Ranges of a source's lengths (mm): within kMaxSourceLengthMm.
const NumberRange kAnyLength = NumberRange::between(-kMaxSourceLengthMm, kMaxSourceLengthMm);
const NumberRange kLength = NumberRange::between(0.0, kMaxSourceLengthMm);
const NumberRange kPositiveLength{0.0, kMaxSourceLengthMm, true, false};

// A field: y alone, or [x, y] (degrees), as in system.fields_deg.
Vec2 readField(const TomlValue& v) {
    const NumberRange range = NumberRange::strictlyBetween(-90.0, 90.0);
    if (v.isNumber()) return {0.0, v.asNumber(range)};
    if (!v.isArray()) v.failExpected("a number (y) or a pair [x, y]");
    const std::vector<TomlValue> xs = v.asArray();
    if (xs.size() != 2) v.failExpected("a pair [x, y]");
    return {xs[0].asNumber(range), xs[1].asNumber(range)};
}

bool validName(const std::string& n) {
    if (n.empty()) return false;
    return std::all_of(n.begin(), n.end(), [](unsigned char c) {
        return std::isalnum(c) || c == '_' || c == '.' || c == '-';
    });
}

class SourceReader {
  public:
    SourceReader(const Prescription& p, const SequentialModel& model)
        : aperture_(entranceAperture(p, model)) {
        const int n = model.wavelengthCount();
        const bool systemWavelengths = static_cast<int>(p.system.wavelengths.size()) == n;
        for (int i = 0; i < n; ++i)
            lines_.push_back(
                {model.wavelengthNm(i), systemWavelengths ? p.system.wavelengths[i].weight : 1.0});
    }

    Source read(const TomlTable& t) {
        const std::string kind =
            t.require("kind", "collimated, sun, point, window or lambertian").asString();
        std::string name = kind;
        if (const auto v = t.get("name")) {
            name = v->asString();
            if (!validName(name))
                v->fail(v->path() + " '" + name +
                        "' may hold letters, digits, '_', '.' and '-' only (names are typed "
                        "in criteria)");
        }
        name_ = name;
        if (kind == "collimated" || kind == "sun") return readBeam(t, kind, name);
        if (kind == "point") return readPoint(t, name);
        if (kind == "window" || kind == "lambertian") return readArea(t, kind, name);
        // The kind is the error: the other keys belong to the kind meant, and are not
        // reported as unknown before it.
        for (const auto& [key, value] : t.table()) t.get(key.str());
        const std::vector<std::string> kinds{"collimated", "sun", "point", "window", "lambertian"};
        std::string lower = kind;
        std::transform(lower.begin(), lower.end(), lower.begin(),
                       [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
        const std::string guess = closestSpelling(kind, kinds);
        t.require("kind").fail("unknown source kind '" + kind + "'" +
                               (std::find(kinds.begin(), kinds.end(), lower) != kinds.end()
                                    ? " (kinds are lower case: '" + lower + "')"
                                : guess.empty() ? std::string()
                                                : " (did you mean '" + guess + "'?)") +
                               "; the kinds are collimated, sun, point, window and lambertian");
    }

  private:
    SpectralSampler spectrum(const TomlTable& t, FluxUnit unit, const std::string& name) {
        SpectralSampling sampling =
            unit == FluxUnit::Watt ? SpectralSampling::Radiometric : SpectralSampling::Photometric;
        if (const auto v = t.get("sampling")) {
            const std::string s = v->asString();
            if (s == "radiometric")
                sampling = SpectralSampling::Radiometric;
            else if (s == "photometric")
                sampling = SpectralSampling::Photometric;
            else
                v->fail(v->path() + " must be \"radiometric\" or \"photometric\", not \"" + s +
                        "\"");
        }
        try {
            return SpectralSampler(lines_, unit, sampling, "source '" + name + "'");
        } catch (const ModelError& e) {
            t.fail(e.what());
        }
    }

    // Runs a geometric construction, turning its ModelError into a ParseError at the table.
    template <class F>
    auto atTable(const TomlTable& t, F&& f) {
        try {
            return f();
        } catch (const ModelError& e) {
            t.fail("source '" + name_ + "': " + e.what());
        }
    }

    Source readBeam(const TomlTable& t, const std::string& kind, const std::string& name) {
        const bool sun = kind == "sun";
        Vec2 field(0.0);
        if (const auto v = t.get("field_deg")) field = readField(*v);
        BeamOptions o;
        o.marginMm = t.number("margin_mm", 0.0, kLength);
        o.radiusMm = t.number("radius_mm", 0.0, kPositiveLength);
        o.startGapMm = t.number("start_gap_mm", o.startGapMm, kLength);
        if (sun)
            o.halfAngleRad = 0.5 * kDegree *
                             t.number("angular_diameter_deg", kSunAngularDiameterDeg,
                                      NumberRange::strictlyBetween(0.0, 90.0));
        const Amount amount = readAmount(t, Quantity::Irradiance, kind);
        const Vec3 d = fieldDirection(field.x, field.y);
        const Beam beam = atTable(t, [&] { return beamFillingAperture(aperture_, d, o); });
        // Irradiance on a plane perpendicular to the beam; the default lets 1 W (lm) through
        // the aperture disk in the plane of the first vertex (projected area pi r^2 cos).
        double irradiance = amount.value;
        if (!amount.given)
            irradiance = 1.0 / (kPi * beam.apertureRadiusMm * beam.apertureRadiusMm * d.z);
        const double flux = amount.quantity == Quantity::Flux && amount.given
                                ? amount.value
                                : irradiance * beam.areaMm2();
        SourceShape shape =
            sun ? SourceShape(SunSource{beam}) : SourceShape(CollimatedSource{beam});
        return Source(name, std::move(shape), flux, spectrum(t, amount.unit, name), t.loc());
    }

    Source readPoint(const TomlTable& t, const std::string& name) {
        const Vec3 position = readVec3(t.require("position_mm", "[x, y, z] in mm"), kAnyLength);
        const double margin = t.number("margin_mm", 0.0, kLength);
        const double radius = t.number("radius_mm", 0.0, kPositiveLength);
        const std::optional<TomlValue> halfValue = t.get("half_angle_deg");
        const std::optional<TomlValue> axisValue = t.get("axis");
        PointSource ps;
        if (halfValue) {
            ps.positionMm = position;
            ps.halfAngleRad = halfValue->asNumber(NumberRange{0.0, 180.0, true, false}) * kDegree;
            Vec3 axis(0.0, 0.0, 1.0);
            if (axisValue) {
                axis = readVec3(*axisValue, kAnyLength);
                if (!(glm::length(axis) > 0.0)) axisValue->fail(axisValue->path() + " is zero");
            } else {
                axis = Vec3(0.0, 0.0,
                            0.5 * (aperture_.zRange(aperture_.radiusMm).first +
                                   aperture_.zRange(aperture_.radiusMm).second)) -
                       position;
                if (!(glm::length(axis) > 0.0)) axis = Vec3(0.0, 0.0, 1.0);
            }
            ps.axis = glm::normalize(axis);
            perpendicularBasis(ps.axis, ps.axisU, ps.axisV);
        } else {
            if (axisValue)
                axisValue->fail(axisValue->path() +
                                " needs half_angle_deg (without it the cone is aimed at the "
                                "first surface)");
            ps = atTable(t, [&] {
                return pointSourceCoveringAperture(aperture_, position, margin, radius);
            });
        }
        const Amount amount = readAmount(t, Quantity::Intensity, "point");
        const double flux = amount.quantity == Quantity::Intensity
                                ? amount.value * ps.solidAngleSr()
                                : amount.value;
        return Source(name, ps, flux, spectrum(t, amount.unit, name), t.loc());
    }

    Source readArea(const TomlTable& t, const std::string& kind, const std::string& name) {
        AreaEmitter e;
        if (kind == "window") {
            e.shape = AreaEmitter::Shape::Disk;
            e.radiusMm = t.number("radius_mm", aperture_.clearRadiusMm, kPositiveLength);
            if (!(e.radiusMm > 0.0))
                t.fail("source '" + name + "': " + aperture_.surfaceName +
                       " has no semi-diameter to size the window; give radius_mm");
            const double z = t.number("z_mm", aperture_.frontZMm - kWindowGapMm, kAnyLength);
            e.frame = Frame::alongAxis(z);
            e.coneHalfAngleRad = t.require("cone_deg", "half-angle of the emission cone, degrees")
                                     .asNumber(NumberRange{0.0, 90.0, true, false}) *
                                 kDegree;
        } else {
            const Vec3 position =
                readVec3(t.require("position_mm", "[x, y, z] of the centre"), kAnyLength);
            Vec3 normal(0.0, 0.0, 1.0);
            std::optional<TomlValue> normalValue = t.get("normal");
            if (normalValue) {
                normal = readVec3(*normalValue, kAnyLength);
                if (!(glm::length(normal) > 0.0))
                    normalValue->fail(normalValue->path() + " is zero");
                normal = glm::normalize(normal);
            }
            Vec3 u, v;
            perpendicularBasis(normal, u, v);
            if (const auto xv = t.get("x_axis")) {
                const Vec3 x = readVec3(*xv, kAnyLength);
                const Vec3 inPlane = x - glm::dot(x, normal) * normal;
                if (!(glm::length(inPlane) > 1e-9 * glm::length(x)))
                    xv->fail(xv->path() + " must not be parallel to the normal");
                u = glm::normalize(inPlane);
                v = glm::cross(normal, u);
            }
            e.frame.rotation = glm::dmat3(u, v, normal);
            e.frame.translation = position;
            const auto radius = t.get("radius_mm");
            const auto size = t.get("size_mm");
            if (radius && size)
                size->fail("give radius_mm (a disk) or size_mm (a rectangle), not both");
            if (radius) {
                e.shape = AreaEmitter::Shape::Disk;
                e.radiusMm = radius->asNumber(kPositiveLength);
            } else if (size) {
                const std::vector<TomlValue> xs = size->asArray();
                if (xs.size() != 2) size->failExpected("a pair [width, height] in mm");
                e.shape = AreaEmitter::Shape::Rectangle;
                e.sizeMm = Vec2(xs[0].asNumber(kPositiveLength), xs[1].asNumber(kPositiveLength));
            } else {
                t.fail("missing key 'radius_mm' (a disk) or 'size_mm' (a rectangle) in " +
                       t.displayName());
            }
            e.coneHalfAngleRad =
                t.number("cone_deg", 90.0, NumberRange{0.0, 90.0, true, false}) * kDegree;
        }
        const Amount amount = readAmount(t, Quantity::Radiance, kind);
        const double flux = amount.quantity == Quantity::Radiance
                                ? amount.value * e.areaMm2() * e.projectedSolidAngleSr()
                                : amount.value;
        SourceShape shape =
            kind == "window" ? SourceShape(WindowSource{e}) : SourceShape(LambertianSource{e});
        return Source(name, std::move(shape), flux, spectrum(t, amount.unit, name), t.loc());
    }

    EntranceAperture aperture_;
    std::vector<Wavelength> lines_;
    std::string name_;
};

}  // namespace

std::vector<Source> readSources(TomlDocument& doc, const Prescription& p,
                                const SequentialModel& model) {
    std::vector<Source> sources;
    const std::optional<TomlValue> list = doc.root().get("source");
    if (!list) return sources;
    if (!list->isArray())
        list->fail(
            "sources are an array of tables: write [[source]] (one per source), not "
            "[source]");
    SourceReader reader(p, model);
    std::map<std::string, FileLoc> seen;
    for (const TomlValue& entry : list->asArray()) {
        const TomlTable t = entry.asTable();
        Source s = reader.read(t);
        const auto [it, fresh] = seen.emplace(s.name(), t.loc());
        if (!fresh) {
            const std::optional<TomlValue> nameValue = t.get("name");
            const std::string m = "source name '" + s.name() + "' is already used at " +
                                  it->second.str() + " (give each source its own name)";
            if (nameValue) nameValue->fail(m);
            t.fail(m);
        }
        sources.push_back(std::move(s));
    }
    return sources;
}

}  // namespace veil
