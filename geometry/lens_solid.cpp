#include "geometry/lens_solid.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>
#include <set>
#include <sstream>

#include "geometry/scene.h"
#include "geometry/surface_frames.h"
#include "geometry/surface_shape.h"
#include "lensdata/errors.h"
#include "lensdata/prescription.h"

namespace veil {

namespace {

// Thickness profiles are checked at this many radii (plus the face rims) between the axis
// and the edge.
constexpr int kProfileSamples = 512;
// And, for anamorphic elements, at this many azimuths plus one over a quarter turn.
constexpr int kProfileAzimuths = 16;
// Two surfaces are the same physical surface (a repeated pass) when their vertices are this
// close (absolute mm plus a relative part for long systems) and their shape parameters agree
// to a relative 1e-9.
constexpr double kCoincidentAbsMm = 1e-6;
constexpr double kCoincidentRel = 1e-12;
constexpr double kSameShapeRel = 1e-9;
// A neighbour's air gap may close to zero (touching) but not below this.
constexpr double kOverlapToleranceMm = 1e-9;

// Global z of every vertex: surface 1 at 0, then the signed thicknesses (surface 0, the
// object, sits one object distance in front, or at -infinity).
std::vector<double> vertexZ(const Prescription& p) {
    const int n = static_cast<int>(p.surfaces.size());
    std::vector<double> z(n, 0.0);
    if (n > 0) z[0] = -p.surfaces[0].thicknessMm;
    double acc = 0.0;
    for (int i = 1; i < n; ++i) {
        z[i] = acc;
        acc += p.surfaces[i].thicknessMm;
    }
    return z;
}

bool close(double a, double b, double rel) {
    return std::abs(a - b) <= rel * std::max(std::abs(a), std::abs(b));
}

bool sameShape(const Surface& a, const Surface& b) {
    if (!close(a.curvature, b.curvature, kSameShapeRel)) return false;
    if (std::abs(a.conic - b.conic) > kSameShapeRel * (1.0 + std::abs(a.conic))) return false;
    for (size_t i = 0; i < a.asphere.size(); ++i) {
        if (!close(a.asphere[i], b.asphere[i], kSameShapeRel)) return false;
    }
    for (size_t j = 0; j < a.oddAsphere.size(); ++j) {
        if (!close(a.oddAsphere[j], b.oddAsphere[j], kSameShapeRel)) return false;
    }
    if (a.anamorphic.has_value() != b.anamorphic.has_value()) return false;
    if (a.anamorphic) {
        const Anamorphic &aa = *a.anamorphic, &ab = *b.anamorphic;
        if (aa.kind != ab.kind || !close(aa.xCurvature, ab.xCurvature, kSameShapeRel) ||
            std::abs(aa.xConic - ab.xConic) > kSameShapeRel * (1.0 + std::abs(aa.xConic)))
            return false;
    }
    if (a.qAsphere.has_value() != b.qAsphere.has_value()) return false;
    if (a.qAsphere) {
        const QAsphere &qa = *a.qAsphere, &qb = *b.qAsphere;
        if (qa.kind != qb.kind || qa.terms.size() != qb.terms.size() ||
            !close(qa.normRadiusMm, qb.normRadiusMm, kSameShapeRel))
            return false;
        for (size_t i = 0; i < qa.terms.size(); ++i)
            if (!close(qa.terms[i], qb.terms[i], kSameShapeRel)) return false;
    }
    return true;
}

// Two frames are the same place within the coincidence tolerance.
bool samePlace(const Frame& a, const Frame& b) {
    const double tol =
        kCoincidentAbsMm +
        kCoincidentRel * std::max(glm::length(a.translation), glm::length(b.translation));
    return glm::length(a.translation - b.translation) <= tol && sameRotation(a.rotation, b.rotation);
}

bool coincide(const Prescription& p, const std::vector<Frame>& frames, int i, int j) {
    if (i == j) return true;
    return samePlace(frames[i], frames[j]) && sameShape(p.surfaces[i], p.surfaces[j]);
}

// The frame at distance z along `placement`'s z axis.
Frame alongAxisOf(const Frame& placement, double z) {
    return {placement.rotation, placement.translation + placement.rotation * Vec3(0.0, 0.0, z)};
}

double mechanicalRadius(const Surface& s) {
    return s.mechSemiDiameterMm > 0.0 ? s.mechSemiDiameterMm : s.clearSemiDiameterMm;
}

void requireClearSize(const Surface& s) {
    if (!(s.clearSemiDiameterMm > 0.0)) {
        throw ModelError(s.name,
                         "no clear semi-diameter: the scene needs the size of every "
                         "lens and mirror surface");
    }
}

void rejectHole(const Surface& s) {
    if (s.innerSemiDiameterMm > 0.0) {
        throw ModelError(s.name,
                         "central hole of " + messageNumber(s.innerSemiDiameterMm) +
                             " mm: holes in lens elements are not modelled (only mirrors in air "
                             "may have one)");
    }
}

// The face of a surface out to its clear semi-diameter: a disc, or an annulus around its hole.
Aperture clearAperture(const Surface& s) {
    if (s.innerSemiDiameterMm > 0.0)
        return AnnularAperture{s.innerSemiDiameterMm, s.clearSemiDiameterMm};
    return CircularAperture{s.clearSemiDiameterMm};
}

// A side whose exact face ends at radius r: its rim height, computed once for every object
// that meets there.
LensSide makeSide(const Prescription& p, const std::vector<double>& z, int surface, double r,
                  bool cemented) {
    const Surface& s = p.surfaces[surface];
    const SurfaceShape shape = surfaceShape(s);
    const double rim = maxRadius(shape);
    if (r > rim) {
        throw ModelError(
            s.name,
            std::string(cemented ? "cemented surface must reach r = " : "clear semi-diameter ") +
                messageNumber(r) +
                " mm, beyond the rim of the surface at r = " + messageNumber(rim) + " mm");
    }
    LensSide side;
    side.surface = surface;
    side.shape = shape;
    side.vertexZMm = z[surface];
    side.faceRadiusMm = r;
    side.cemented = cemented;
    if (isRotational(shape)) {
        side.rimZMm = z[surface] + sag(shape, r * r);
        side.rimZLoMm = side.rimZHiMm = side.rimZMm;
    } else {
        // An anamorphic face's rim is a curve: no plane for a flat or step.
        side.rimZMm = std::numeric_limits<double>::quiet_NaN();
        double lo = 0.0, hi = 0.0;
        sagRange(shape, r * r, r * r, lo, hi);
        side.rimZLoMm = z[surface] + lo;
        side.rimZHiMm = z[surface] + hi;
    }
    if (!std::isfinite(side.rimZLoMm) || !std::isfinite(side.rimZHiMm)) {
        throw ModelError(s.name, "sag undefined at r = " + messageNumber(r) + " mm");
    }
    return side;
}

double sideZ(const LensSide& side, double r) {
    if (r >= side.faceRadiusMm) return side.rimZMm;
    return side.vertexZMm + sag(side.shape, r * r);
}

// The side's z at (x, y), every shape (an anamorphic face always reaches the edge).
double sideZAt(const LensSide& side, double x, double y) {
    if (isRotational(side.shape)) return sideZ(side, std::hypot(x, y));
    return side.vertexZMm + sagAt(side.shape, x, y);
}

bool anamorphic(const LensSolid& s) {
    return !isRotational(s.front.shape) || !isRotational(s.back.shape);
}

// Azimuths at which thickness profiles are checked: one for solids of revolution, a quarter
// turn for anamorphic ones (their sags are even in x and in y).
std::vector<double> profileAzimuths(bool anamorphicSolid) {
    if (!anamorphicSolid) return {0.0};
    std::vector<double> phi;
    for (int k = 0; k <= kProfileAzimuths; ++k)
        phi.push_back(0.5 * std::numbers::pi * k / kProfileAzimuths);
    return phi;
}

// An enclosure of sideZ() over radii [r0, r1], widened into [lo, hi]: the face's sag
// enclosure inside its radius, the flat (or step) plane beyond.
void widenBySide(const LensSide& side, double r0, double r1, double& lo, double& hi) {
    if (r0 < side.faceRadiusMm) {
        const double rEnd = std::min(r1, side.faceRadiusMm);
        double zLo = 0.0, zHi = 0.0;
        sagRange(side.shape, r0 * r0, rEnd * rEnd, zLo, zHi);
        lo = std::min(lo, side.vertexZMm + zLo);
        hi = std::max(hi, side.vertexZMm + zHi);
    }
    if (r1 >= side.faceRadiusMm) {
        lo = std::min(lo, side.rimZLoMm);
        hi = std::max(hi, side.rimZHiMm);
    }
}

// Radii at which thickness profiles are checked: a regular grid plus the face rims.
std::vector<double> profileRadii(double rMax, std::initializer_list<double> extra) {
    std::vector<double> r;
    for (int k = 0; k <= kProfileSamples; ++k) r.push_back(rMax * k / kProfileSamples);
    for (double e : extra)
        if (e <= rMax) r.push_back(e);
    return r;
}

// The thinnest point of an element: the edge (beyond both face rims, where flats that cross
// show up; an anamorphic face reaches the edge and the profile covers its rim) or anywhere
// on the profile from the axis out.
LensSolidProblem thinnestPoint(const LensSolid& s, int index) {
    LensSolidProblem worst{LensSolidProblem::Kind::Thickness,       index, index,
                           std::numeric_limits<double>::infinity(), 0.0,   true};
    if (!anamorphic(s)) {
        worst.valueMm = s.direction * (s.back.rimZMm - s.front.rimZMm);
        worst.atRadiusMm = s.edgeRadiusMm;
    }
    const std::vector<double> azimuths = profileAzimuths(anamorphic(s));
    for (double r : profileRadii(s.edgeRadiusMm, {s.front.faceRadiusMm, s.back.faceRadiusMm})) {
        for (double phi : azimuths) {
            const double x = r * std::cos(phi), y = r * std::sin(phi);
            const double t = s.direction * (s.backZAt(x, y) - s.frontZAt(x, y));
            if (t < worst.valueMm || std::isnan(t)) {
                worst.valueMm = t;
                worst.atRadiusMm = r;
                worst.atEdge = false;
            }
        }
    }
    return worst;
}

void checkThickness(const LensSolid& s) {
    const LensSolidProblem t = thinnestPoint(s, 0);
    if (t.valueMm > 0.0) return;
    if (t.atEdge)
        throw ModelError(s.name, std::string(t.valueMm < 0.0 ? "negative" : "zero") +
                                     " edge thickness " + messageNumber(t.valueMm) +
                                     " mm at r = " + messageNumber(t.atRadiusMm) + " mm");
    throw ModelError(s.name, "front and back faces cross: thickness " + messageNumber(t.valueMm) +
                                 " mm at r = " + messageNumber(t.atRadiusMm) + " mm");
}

// Neighbours across an air gap (no mirror in between, so light keeps its direction) must not
// overlap anywhere both exist. Returns the narrowest point of the gap, or nothing for
// neighbours that are not compared.
std::optional<LensSolidProblem> narrowestGap(const Prescription& p, const LensSolid& a,
                                             const LensSolid& b, int index) {
    for (int j = a.back.surface; j < b.front.surface; ++j) {
        if (p.surfaces[j].mirror) return std::nullopt;
    }
    if (a.direction != b.direction) return std::nullopt;
    // Elements on different axes (a coordinate break between them) are not compared.
    if (!samePlace(a.placement, b.placement)) return std::nullopt;
    const double rMax = std::min(a.edgeRadiusMm, b.edgeRadiusMm);
    LensSolidProblem worst{LensSolidProblem::Kind::AirGap,          index, index + 1,
                           std::numeric_limits<double>::infinity(), 0.0,   false};
    const std::vector<double> azimuths = profileAzimuths(anamorphic(a) || anamorphic(b));
    for (double r : profileRadii(rMax, {a.back.faceRadiusMm, b.front.faceRadiusMm})) {
        for (double phi : azimuths) {
            const double x = r * std::cos(phi), y = r * std::sin(phi);
            const double gap = a.direction * (b.frontZAt(x, y) - a.backZAt(x, y));
            if (gap < worst.valueMm || std::isnan(gap)) {
                worst.valueMm = gap;
                worst.atRadiusMm = r;
            }
        }
    }
    return worst;
}

void checkAirGap(const Prescription& p, const LensSolid& a, const LensSolid& b) {
    const std::optional<LensSolidProblem> g = narrowestGap(p, a, b, 0);
    if (g && !(g->valueMm >= -kOverlapToleranceMm)) {
        throw ModelError(a.name, "overlaps " + b.name + ": air gap " + messageNumber(g->valueMm) +
                                     " mm at r = " + messageNumber(g->atRadiusMm) + " mm");
    }
}

}  // namespace

std::vector<Element> distinctElements(const Prescription& p) {
    const std::vector<Frame> frames = surfaceFrames(p);
    std::vector<Element> kept;
    for (const Element& e : p.elements()) {
        const bool repeat = std::any_of(kept.begin(), kept.end(), [&](const Element& k) {
            if (!(k.material == e.material)) return false;
            return (coincide(p, frames, k.frontSurface, e.frontSurface) &&
                    coincide(p, frames, k.backSurface, e.backSurface)) ||
                   (coincide(p, frames, k.frontSurface, e.backSurface) &&
                    coincide(p, frames, k.backSurface, e.frontSurface));
        });
        if (!repeat) kept.push_back(e);
    }
    return kept;
}

namespace {

// The solids of a named prescription. Thickness and overlap problems throw, or, given
// `problems`, are listed there (every element and neighbour pair, worst point first).
std::vector<LensSolid> solidsOfNamed(const Prescription& p,
                                     std::vector<LensSolidProblem>* problems = nullptr) {
    p.validate();
    const std::vector<double> z = vertexZ(p);
    const std::vector<Frame> frames = surfaceFrames(p);
    const int image = p.imageIndex();

    for (const Element& e : p.elements())
        if (e.backSurface >= image)
            throw ModelError(e.name,
                             "glass reaches the image surface: a lens element needs its "
                             "own back surface");
    const std::vector<Element> kept = distinctElements(p);

    const size_t count = kept.size();
    std::vector<double> radius(count);
    for (size_t k = 0; k < count; ++k) {
        const Surface& f = p.surfaces[kept[k].frontSurface];
        const Surface& b = p.surfaces[kept[k].backSurface];
        requireClearSize(f);
        requireClearSize(b);
        rejectHole(f);
        rejectHole(b);
        radius[k] = std::max(mechanicalRadius(f), mechanicalRadius(b));
    }
    auto cementedToNext = [&](size_t k) {
        return k + 1 < count && kept[k].backSurface == kept[k + 1].frontSurface;
    };

    std::vector<LensSolid> out(count);
    for (size_t k = 0; k < count; ++k) {
        const Element& e = kept[k];
        LensSolid& s = out[k];
        s.name = e.name;
        s.material = e.material;
        s.edgeRadiusMm = radius[k];
        const double t = p.surfaces[e.frontSurface].thicknessMm;
        if (t == 0.0) throw ModelError(e.name, "zero centre thickness");
        s.direction = t > 0.0 ? 1.0 : -1.0;
        // The element's own axis: the front surface's frame, its origin moved back to where
        // the unfolded z is 0, so the sides keep their unfolded z. The back face must lie on
        // the same axis.
        const Frame& ff = frames[e.frontSurface];
        s.placement = alongAxisOf(ff, -z[e.frontSurface]);
        if (!samePlace(alongAxisOf(s.placement, z[e.backSurface]), frames[e.backSurface]))
            throw ModelError(e.name,
                             "a coordinate break between its faces tilts or decenters one face "
                             "against the other: such elements (wedges, tilted faces) are not "
                             "modelled in the 3D scene");
        if (k > 0 && cementedToNext(k - 1)) {
            s.front = out[k - 1].back;  // the shared face, rim computed once
        } else {
            s.front = makeSide(p, z, e.frontSurface, p.surfaces[e.frontSurface].clearSemiDiameterMm,
                               false);
        }
        if (cementedToNext(k)) {
            // Glass touches glass out to the smaller element's radius.
            const double rc = std::min(radius[k], radius[k + 1]);
            s.back = makeSide(p, z, e.backSurface, rc, true);
        } else {
            s.back =
                makeSide(p, z, e.backSurface, p.surfaces[e.backSurface].clearSemiDiameterMm, false);
        }
        // Clear apertures larger than the mechanical one are caught by validate(); a cemented
        // face never exceeds its elements.
        s.edgeRadiusMm = std::max({s.edgeRadiusMm, s.front.faceRadiusMm, s.back.faceRadiusMm});
        // An anamorphic face continues to the edge: a flat or step there would have to follow
        // its curved rim.
        for (LensSide* side : {&s.front, &s.back}) {
            if (isRotational(side->shape) || side->faceRadiusMm >= s.edgeRadiusMm) continue;
            if (side->cemented)
                throw ModelError(p.surfaces[side->surface].name,
                                 std::string("a cemented ") +
                                     p.surfaces[side->surface].anamorphic->label() +
                                     " face between elements of different radii would need a "
                                     "step that is not a plane: give both elements the same "
                                     "mechanical semi-diameter");
            *side = makeSide(p, z, side->surface, s.edgeRadiusMm, false);
        }
        if (problems)
            problems->push_back(thinnestPoint(s, static_cast<int>(k)));
        else
            checkThickness(s);
    }
    for (size_t k = 0; k + 1 < count; ++k) {
        if (cementedToNext(k)) continue;
        if (!problems) {
            checkAirGap(p, out[k], out[k + 1]);
        } else if (auto g = narrowestGap(p, out[k], out[k + 1], static_cast<int>(k))) {
            problems->push_back(*g);
        }
    }
    return out;
}

Prescription withNames(const Prescription& p) {
    Prescription named = p;
    named.assignNames();
    return named;
}

// Names a surface answers to besides its own. "stop" is left out: that name belongs to the
// stop plate the mechanics builder makes.
std::vector<std::string> aliasesFor(const Prescription& p, int i) {
    std::vector<std::string> out;
    for (const std::string& a : p.aliasesOf(i)) {
        if (a != "stop" && a != p.surfaces[i].name) out.push_back(a);
    }
    return out;
}

void addAliases(SceneObject& o, const std::vector<std::string>& names) {
    for (const std::string& n : names) {
        if (n == o.name) continue;
        if (std::find(o.aliases.begin(), o.aliases.end(), n) != o.aliases.end()) continue;
        o.aliases.push_back(n);
    }
}

std::string mirrorPropertyOf(const Surface& s, const LensSolidOptions& options) {
    return options.mirrorProperty.empty() ? s.coating : options.mirrorProperty;
}

}  // namespace

// Printing

std::ostream& operator<<(std::ostream& os, const LensSolidOptions& o) {
    return os << "LensSolidOptions{edge '" << o.edgeProperty << "', flat '" << o.flatProperty
              << "', optical '" << o.opticalFaceProperty << "', mirror '" << o.mirrorProperty
              << "'}";
}

std::ostream& operator<<(std::ostream& os, const LensSide& s) {
    return os << "LensSide{surface " << s.surface << " " << s.shape << ", vertex z " << s.vertexZMm
              << " mm, face r <= " << s.faceRadiusMm << " mm, rim z " << s.rimZMm << " mm"
              << (s.cemented ? ", cemented" : "") << "}";
}

std::ostream& operator<<(std::ostream& os, const LensSolid& s) {
    return os << "LensSolid{" << s.name << " " << s.material << ", R " << s.edgeRadiusMm
              << " mm, direction " << s.direction << ", front " << s.front << ", back " << s.back
              << "}";
}

// Lens Solid Methods

double LensSolid::frontZ(double rMm) const { return sideZ(front, rMm); }
double LensSolid::backZ(double rMm) const { return sideZ(back, rMm); }
double LensSolid::frontZAt(double xMm, double yMm) const { return sideZAt(front, xMm, yMm); }
double LensSolid::backZAt(double xMm, double yMm) const { return sideZAt(back, xMm, yMm); }

int endImmersedImage(Prescription& p) {
    const int image = p.imageIndex();
    if (image < 2) return -1;
    const Surface& last = p.surfaces[image - 1];
    if (last.material.isAir() || last.coordinateBreak || last.mirror) return -1;
    std::string element;
    double frontSd = 0.0;
    for (const Element& e : p.elements())
        if (e.backSurface == image) {
            element = e.name;
            frontSd = p.surfaces[e.frontSurface].clearSemiDiameterMm;
        }
    if (element.empty()) return -1;
    Surface face = p.surfaces[image];
    face.name = element + ".back";
    face.material = Material::air();
    face.thicknessMm = 0.0;
    face.stop = false;
    face.mirror = false;
    // The medium goes on past the image in truth: light beyond the sensor is lost in it, and
    // nothing comes back from the end the model gives it.
    face.coating = "absorber";
    face.mechSemiDiameterMm = 0.0;
    face.innerSemiDiameterMm = 0.0;
    // An automatic image size computed for one on-axis field is a spot: the medium keeps the
    // width it has at its front instead.
    if (!(face.clearSemiDiameterMm > 1e-3 * frontSd)) {
        face.clearSemiDiameterMm = frontSd;
        face.semiDiameterAutomatic = true;
    }
    p.surfaces[image - 1].thicknessMm += kImmersedImageClearanceMm;
    p.surfaces.insert(p.surfaces.begin() + image, face);
    return image;
}

namespace {
// A lens face with a central obscuration that a mirror on the same face covers (a Maksutov's
// aluminized secondary spot on its meniscus): the glass is whole, and the spot, as wide as
// the obscuration at least, is cut out of the face (addOnFace). Sequential traces keep the
// obscuration, which stops the light the spot's back meets.
void coverObscurationsWithSpots(Prescription& p) {
    const std::vector<Frame> frames = surfaceFrames(p);
    const int n = static_cast<int>(p.surfaces.size());
    for (int i = 1; i + 1 < n; ++i) {
        Surface& s = p.surfaces[i];
        if (s.mirror || !(s.innerSemiDiameterMm > 0.0)) continue;
        for (int j = 1; j + 1 < n; ++j) {
            Surface& spot = p.surfaces[j];
            if (j == i || !spot.mirror || !coincide(p, frames, i, j)) continue;
            spot.clearSemiDiameterMm = std::max(spot.clearSemiDiameterMm, s.innerSemiDiameterMm);
            if (spot.mechSemiDiameterMm > 0.0)
                spot.mechSemiDiameterMm =
                    std::max(spot.mechSemiDiameterMm, spot.clearSemiDiameterMm);
            s.innerSemiDiameterMm = 0.0;
            break;
        }
    }
}

Prescription solidsPrescription(const Prescription& p, int* added = nullptr) {
    Prescription named = withNames(p);
    coverObscurationsWithSpots(named);
    const int a = endImmersedImage(named);
    if (added) *added = a;
    return named;
}
}  // namespace

std::vector<LensSolid> lensSolids(const Prescription& p) {
    return solidsOfNamed(solidsPrescription(p));
}

std::vector<LensSolid> measuredLensSolids(const Prescription& p,
                                          std::vector<LensSolidProblem>& measures) {
    measures.clear();
    return solidsOfNamed(solidsPrescription(p), &measures);
}

namespace {

// The faces, edges, flats and mirrors of a lens, planned first (a spot mirror found later cuts
// a face already made), each with the index of the surface that orders it, then added to the
// scene in that order.
class LensSolidBuilder {
  public:
    LensSolidBuilder(const Prescription& prescription, Scene& scene,
                     const LensSolidOptions& options)
        : p_(solidsPrescription(prescription, &added_)),
          solids_(solidsOfNamed(p_)),
          frames_(surfaceFrames(p_)),
          scene_(scene),
          options_(options) {}

    void build() {
        for (size_t k = 0; k < solids_.size(); ++k) addElement(k);
        // Surfaces outside the elements: mirrors, and repeated passes over faces already made.
        const int n = static_cast<int>(p_.surfaces.size());
        for (int i = 1; i < n - 1; ++i)
            if (!built_.count(i)) addOutsideSurface(i);
        std::stable_sort(planned_.begin(), planned_.end(),
                         [](const Planned& a, const Planned& b) { return a.order < b.order; });
        for (Planned& pl : planned_) scene_.addObject(std::move(pl.object));
    }

  private:
    struct Planned {
        int order;
        SceneObject object;
    };

    // One medium per distinct material; air is medium 0.
    int mediumOf(const Material& m) {
        if (m.isAir()) return 0;
        const std::vector<Medium>& media = scene_.media();
        for (size_t i = 0; i < media.size(); ++i)
            if (media[i].material == m) return static_cast<int>(i);
        return scene_.addMedium(Medium{m.label(), m});
    }
    SceneObject opticalFace(const LensSolid& s, const LensSide& side) const;
    SceneObject flat(const LensSolid& s, const LensSide& side, const char* suffix) const;
    SceneObject edge(const LensSolid& s, int glass) const;
    // Element k: its glass as a body, its faces, flats and edge.
    void addElement(size_t k);
    Planned* findCoincident(int i) {
        for (Planned& pl : planned_) {
            const int j = pl.object.sequentialSurface;
            if (j >= 0 && coincide(p_, frames_, i, j)) return &pl;
        }
        return nullptr;
    }
    void addOutsideSurface(int i);
    // Surface i coincides with a face already planned: a repeated pass, or a mirror on a lens
    // face (a spot secondary) cut out of the face.
    void addOnFace(int i, Planned& match, const std::vector<std::string>& names);

    int added_ = -1;  // the face endImmersedImage added, or -1; set before p_ by its initializer
    const Prescription p_;
    const std::vector<LensSolid> solids_;
    const std::vector<Frame> frames_;
    Scene& scene_;
    const LensSolidOptions& options_;
    std::vector<Planned> planned_;
    std::set<int> built_;
};

SceneObject LensSolidBuilder::opticalFace(const LensSolid& s, const LensSide& side) const {
    const Surface& sf = p_.surfaces[side.surface];
    SceneObject o;
    o.name = sf.name;
    o.aliases = aliasesFor(p_, side.surface);
    o.kind = sf.mirror ? ObjectKind::MirrorFace : ObjectKind::LensFace;
    o.part = s.name;
    o.property = sf.mirror ? mirrorPropertyOf(sf, options_)
                           : (options_.opticalFaceProperty.empty() ? sf.coating
                                                                   : options_.opticalFaceProperty);
    o.frame = alongAxisOf(s.placement, side.vertexZMm);
    o.geometry = FaceGeometry{SurfacePatch{side.shape, CircularAperture{side.faceRadiusMm}}};
    o.sequentialSurface = side.surface == added_ ? -1 : side.surface;
    return o;
}

SceneObject LensSolidBuilder::flat(const LensSolid& s, const LensSide& side,
                                   const char* suffix) const {
    SceneObject o;
    o.name = s.name + suffix;
    o.kind = ObjectKind::LensFlat;
    o.part = s.name;
    o.property = options_.flatProperty;
    o.frame = alongAxisOf(s.placement, side.rimZMm);
    o.geometry = FaceGeometry{
        SurfacePatch{PlaneShape{}, AnnularAperture{side.faceRadiusMm, s.edgeRadiusMm}}};
    return o;
}

SceneObject LensSolidBuilder::edge(const LensSolid& s, int glass) const {
    SceneObject o;
    o.name = s.name + ".edge";
    o.kind = ObjectKind::LensEdge;
    o.part = s.name;
    o.property = options_.edgeProperty;
    o.frame = s.placement;
    // Between the rims: the lower one is the front's when the element runs toward +z.
    const bool up = s.direction > 0.0;
    const LensSide& lower = up ? s.front : s.back;
    const LensSide& upper = up ? s.back : s.front;
    CylinderPatch patch{s.edgeRadiusMm, lower.rimZLoMm, upper.rimZHiMm, true, nullptr};
    if (anamorphic(s)) {
        auto rims = std::make_shared<RimCurves>();
        if (!isRotational(lower.shape)) rims->lower = RimCurve{lower.shape, lower.vertexZMm};
        if (!isRotational(upper.shape)) rims->upper = RimCurve{upper.shape, upper.vertexZMm};
        patch.rims = std::move(rims);
    }
    o.geometry = FaceGeometry{patch};
    o.mediumFront = 0;  // outward normal: air outside, glass inside
    o.mediumBack = glass;
    return o;
}

void LensSolidBuilder::addElement(size_t k) {
    const LensSolid& s = solids_[k];
    const int order = s.front.surface;
    const int glass = mediumOf(s.material);
    // The glass lies on the side of each face toward the element's other side: at +z of the
    // front side when the element runs toward +z.
    const bool up = s.direction > 0.0;
    auto frontSide = [&](SceneObject& o, int outside) {
        o.mediumFront = up ? glass : outside;
        o.mediumBack = up ? outside : glass;
    };
    auto backSide = [&](SceneObject& o, int outside) {
        o.mediumFront = up ? outside : glass;
        o.mediumBack = up ? glass : outside;
    };
    built_.insert(s.front.surface);
    built_.insert(s.back.surface);
    // The glass as a body (scene.h): at radius r it lies between frontZ(r) and backZ(r).
    if (glass > 0) {
        ExactBody body;
        body.part = s.name;
        body.medium = glass;
        body.radiusMm = s.edgeRadiusMm;
        body.frame = s.placement;
        body.zRange = [front = s.front, back = s.back](double r0, double r1, double& lo,
                                                       double& hi) {
            lo = std::numeric_limits<double>::infinity();
            hi = -lo;
            widenBySide(front, r0, r1, lo, hi);
            widenBySide(back, r0, r1, lo, hi);
        };
        scene_.addExactBody(std::move(body));
    }
    // A cemented front face was made with the element in front.
    if (!s.front.cemented) {
        SceneObject o = opticalFace(s, s.front);
        frontSide(o, 0);
        planned_.push_back({order, std::move(o)});
    }
    if (s.edgeRadiusMm > s.front.faceRadiusMm) {
        SceneObject o = flat(s, s.front, ".flat1");
        frontSide(o, 0);
        planned_.push_back({order, std::move(o)});
    }
    planned_.push_back({order, edge(s, glass)});
    if (s.edgeRadiusMm > s.back.faceRadiusMm) {
        SceneObject o = flat(s, s.back, ".flat2");
        backSide(o, 0);
        planned_.push_back({order, std::move(o)});
    }
    SceneObject o = opticalFace(s, s.back);
    const int outside = s.back.cemented ? mediumOf(solids_[k + 1].material) : 0;
    backSide(o, outside);
    planned_.push_back({order, std::move(o)});
}

void LensSolidBuilder::addOnFace(int i, Planned& match, const std::vector<std::string>& names) {
    const Surface& sf = p_.surfaces[i];
    SceneObject& face = match.object;
    if (!sf.mirror || face.kind == ObjectKind::MirrorFace) {
        // A repeated pass: the face was built once, with the first pass's aperture.
        if (sf.innerSemiDiameterMm > 0.0) {
            const auto& patch = std::get<SurfacePatch>(std::get<FaceGeometry>(face.geometry));
            const auto* ring = std::get_if<AnnularAperture>(&patch.aperture);
            if (!ring || ring->innerRadiusMm != sf.innerSemiDiameterMm)
                throw ModelError(
                    sf.name, "central hole of " + messageNumber(sf.innerSemiDiameterMm) + " mm: " +
                                 face.name + ", the face it coincides with, has no such hole");
        }
        addAliases(face, names);
        return;
    }
    // A mirror on a lens face (a spot secondary): cut it out of the face.
    requireClearSize(sf);
    rejectHole(sf);
    auto& patch = std::get<SurfacePatch>(std::get<FaceGeometry>(face.geometry));
    const auto* disc = std::get_if<CircularAperture>(&patch.aperture);
    if (!disc) throw ModelError(sf.name, "a second mirror on " + face.name + " is not supported");
    if (sf.clearSemiDiameterMm >= disc->radiusMm) {
        face.kind = ObjectKind::MirrorFace;
        face.property = mirrorPropertyOf(sf, options_);
        addAliases(face, names);
        return;
    }
    SceneObject spot = face;
    spot.name = sf.name;
    spot.aliases.clear();
    addAliases(spot, std::vector<std::string>(names.begin() + 1, names.end()));
    spot.kind = ObjectKind::MirrorFace;
    spot.property = mirrorPropertyOf(sf, options_);
    spot.sequentialSurface = i;
    std::get<SurfacePatch>(std::get<FaceGeometry>(spot.geometry)).aperture =
        CircularAperture{sf.clearSemiDiameterMm};
    patch.aperture = AnnularAperture{sf.clearSemiDiameterMm, disc->radiusMm};
    const int order = match.order;
    planned_.push_back({order, std::move(spot)});
}

void LensSolidBuilder::addOutsideSurface(int i) {
    const Surface& sf = p_.surfaces[i];
    if (sf.stop && !sf.mirror) return;
    std::vector<std::string> names = aliasesFor(p_, i);
    names.insert(names.begin(), sf.name);
    if (Planned* match = findCoincident(i)) {
        addOnFace(i, *match, names);
        return;
    }
    if (!sf.mirror) return;  // dummy surface
    if (!sf.material.isAir())
        throw ModelError(sf.name, "mirror inside glass that is not the back of a lens element");
    requireClearSize(sf);
    SceneObject o;
    o.name = sf.name;
    addAliases(o, std::vector<std::string>(names.begin() + 1, names.end()));
    o.kind = ObjectKind::MirrorFace;
    o.part = sf.name;
    o.property = mirrorPropertyOf(sf, options_);
    o.frame = frames_[i];
    // A hole (a Cassegrain primary) leaves an annulus: light passes through the centre.
    o.geometry = FaceGeometry{SurfacePatch{surfaceShape(sf), clearAperture(sf)}};
    o.sequentialSurface = i;
    planned_.push_back({i, std::move(o)});
}

}  // namespace

void addLensSolids(const Prescription& prescription, Scene& scene,
                   const LensSolidOptions& options) {
    LensSolidBuilder(prescription, scene, options).build();
}

}  // namespace veil
