// Mechanics from a prescription: barrel, seats, retainers, spacers, stop, field stop, baffles,
// vanes. User documentation: docs/format.md, section [mechanics]; the model is summarised in
// mechanics.h.
//
//   key                  type                      default        meaning
//   chord_tolerance_mm   number > 0                0.01           largest chord error
//   contact_gap_mm       number > 0                0.001          air between touching parts
//   property             string                    ""             default for every part
//   lens_edges           { property }                             lens butt ends and flats
//   barrel               bool | { enabled, wall_mm = 2, clearance_mm = 0.05, property }
//   retainers            bool | { enabled, width_mm = 1.5, property }
//   spacers              bool | { enabled, min_length_mm = 0.1, property }
//   stop                 bool | { enabled, edge_mm = 0.05, thickness_mm (<= 0.5 auto),
//                                 bevel_deg = 45, property, edge_property }
//   field_stop           { enabled, z_mm | before_image_mm = 1, radius_mm, thickness_mm = 0.5,
//                          property }                                 off when absent
//   baffles              [{ z_mm, inner_radius_mm, thickness_mm = 0.5, property, enabled }]
//   vanes                { enabled, count, depth_mm, thickness_mm = 0.5, from_z_mm, to_z_mm,
//                          property }                                 off when absent
//   parts                [{ name, profile_mm = [[r, z], ...], property, enabled }]
//
// Lengths in mm; z is global (surface 1's vertex at 0). Radii (r) are distances from the axis.

#include "geometry/mechanics.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>

#include "geometry/mesh_check.h"
#include "geometry/revolve.h"
#include "geometry/surface_frames.h"
#include "geometry/surface_shape.h"
#include "lensdata/toml_document.h"

namespace veil {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kDefaultStopThicknessMm = 0.5;
// Radial room a plate (stop, field stop, baffle) gets at least between its aperture and the
// bore, and the spacer wall a simple gap's bore leaves outside the beam.
constexpr double kMinPlateWidthMm = 1.0;
constexpr double kSpacerWallMm = 0.5;
// Thinnest ring (spacer, retainer) worth building, radially.
constexpr double kMinRingWallMm = 0.05;
// Clearance checks against glass sample both boundaries this densely.
constexpr double kCheckStepMm = 0.005;
constexpr size_t kMaxCheckSamplesPerEdge = 400000;
// Deeper than this is a collision (contacts keep contact_gap_mm, far more).
constexpr double kPenetrationMm = 1e-9;
// Placement optimizes over radii with this many samples, then refines the best.
constexpr int kPlacementSamples = 1024;
// Retainer inner radii widen by width * tan(field angle), the angle capped here.
constexpr double kMaxFieldDeg = 60.0;

std::string fmt(double v, int decimals = 3) {
    std::ostringstream os;
    os << std::fixed << std::setprecision(decimals) << v;
    return os.str();
}

// Lens Model Definitions

struct SurfaceInfo {
    std::string name;
    SurfaceShape shape;
    double zMm = 0.0;
    double clearMm = 0.0;  // sd, or mech_sd when sd is not given
    double mechMm = 0.0;   // mech_sd, or sd
    int body = -1;         // body holding it: -1 for object, image, free stop, dummies
    double at(double r) const { return zMm + sag(shape, r * r); }
};

// One lens element or one mirror without glass: the unit of the glass clearance check.
struct Piece {
    std::string name;           // "L3", "M1"
    std::vector<int> surfaces;  // element: front and back; sheet: the mirror
    // Per surface: the radius a cemented face runs out to (the smaller element's radius,
    // geometry/lens_solid.h), 0 for a face that ends at its clear aperture.
    std::vector<double> cementedTo;
    bool sheet = false;
    int elementNumber = 0;  // k of Lk; 0 for sheets
    double radiusMm = 0.0;
};

// What a seat holds: cemented elements (one group), or one mirror sheet.
struct Body {
    std::vector<int> pieces;
    std::string name;  // "L2+L3", "M1"
    bool sheet = false;
    double radiusMm = 0.0;
    double zMin = 0.0, zMax = 0.0;
    int spacerNumber = 0;  // spacers behind it are spacer<k>: its last element's number
    double boreMm = 0.0;
};

// Light between two physical surfaces (object, glass faces, mirrors, image), through any
// stop or dummy surface between them.
struct Path {
    int from = 0, to = 0;  // surface indices
    double beamMm = 0.0;   // largest clear semi-diameter along it
    // Places of its end points in the stack: body j is 2 j + 1, region k is 2 k (an end
    // point that is no body, the object or the image, lies in the region holding its z).
    int lo = 0, hi = 0;
    bool crossesRegion(int k) const { return lo <= 2 * k && 2 * k <= hi; }
    bool crossesBody(int j) const { return lo < 2 * j + 1 && 2 * j + 1 < hi; }
};

enum class PlateKind { Stop, FieldStop, Baffle, Vane };

// An annular plate: stop, field stop, baffle or vane. Its profile spans radii [ri, ro]; at
// radius r it spans [z0 - hLo(r), z0 + hHi(r)], h growing from edgeHalf at ri along the
// bevel (slope tanBevel) up to tLo / tHi. Plain plates have edgeHalf = tLo = tHi.
struct Plate {
    PlateKind kind = PlateKind::Baffle;
    std::string name;
    std::string property;
    std::string edgeProperty;
    double ri = 0.0, ro = 0.0;
    double z0 = 0.0;
    double edgeHalf = 0.0;
    double tLo = 0.0, tHi = 0.0;
    double tanBevel = 1.0;
    double vaneDepth = 0.0;  // vanes: ri = ro - depth once the bore is known
    int region = 0;
    int pushedAgainst = -1;  // stop on a lens face or mirror: that body
    int pushSide = 0;        // -1: plate below the body (smaller z), +1 above

    double hLo(double r) const {
        return std::min(tLo, edgeHalf + std::max(0.0, r - ri) * tanBevel);
    }
    double hHi(double r) const {
        return std::min(tHi, edgeHalf + std::max(0.0, r - ri) * tanBevel);
    }
};

// The space between two bodies adjacent in z (or before the first, after the last).
struct Region {
    int below = -1, above = -1;  // body indices (sorted by z); -1: none
    std::vector<int> paths;
    bool simple = false;
    int path = -1;  // the path through it when simple
    double boreMm = 0.0;
    std::vector<int> plates;  // sorted by z0
    int widestPlate = -1;     // the plate (not a vane) of largest inner radius, -1: none
};

// Something a spacer or retainer rests against.
struct StackItem {
    bool isBody = true;
    int index = 0;
};

// Mechanics Builder Definition

class MechanicsBuilder {
  public:
    MechanicsBuilder(const Prescription& p, const MechanicsSpec& spec,
                     std::vector<std::string>* notes)
        : rx_(p), spec_(spec), notes_(notes) {}
    std::vector<MechanicalPart> build();

  private:
    void readSurfaces();
    void makeBodies();
    void makePaths();
    void makeRegions();
    void makePlates();
    void computeBores();
    void placePlates();
    void placeStop(Plate& stop);
    void makeSpacersAndRetainers();
    void makeBarrel();
    void checkParts();

    // Geometry queries (mm; r >= 0).
    void pieceRange(const Piece& p, double r, double& lo, double& hi) const;
    // Body extent at r; beyond its radius the rim's extent continues outward (the seat or
    // step of the barrel sits there), so neighbours never slide past a lens rim.
    double bodyUpper(int b, double r) const;
    double bodyLower(int b, double r) const;
    // Plate mesh extent at radius r (covering the chordal mesh: profile radii r .. r / c);
    // -inf / +inf where the plate's mesh has nothing.
    double plateUpper(const Plate& p, double r) const;
    double plateLower(const Plate& p, double r) const;
    double itemUpper(const StackItem& it, double r) const;
    double itemLower(const StackItem& it, double r) const;
    double maxOver(const std::function<double(double)>& f, double r0, double r1) const;
    double minOver(const std::function<double(double)>& f, double r0, double r1) const {
        return -maxOver([&](double r) { return -f(r); }, r0, r1);
    }
    int regionOfZ(double z) const;
    double lightDirectionOfGap(int gap) const;
    std::string propertyOr(const std::string& own) const {
        return own.empty() ? spec_.property : own;
    }
    void note(const std::string& text) {
        if (notes_) notes_->push_back(text);
    }
    void addPart(const std::string& name, const std::string& property, std::vector<Vec2> profile,
                 const std::string& edgeName = {}, const std::string& edgeProperty = {});
    void checkAgainstGlass(const MechanicalPart& part) const;

    const Prescription& rx_;
    const MechanicsSpec& spec_;
    std::vector<std::string>* notes_;

    std::vector<SurfaceInfo> surfaces_;
    std::vector<double> directions_;  // per gap: +1 toward +z, -1 toward -z
    std::vector<Piece> pieces_;
    std::vector<Body> bodies_;  // sorted by zMin
    std::vector<Path> paths_;
    std::vector<Region> regions_;
    std::vector<Plate> plates_;
    std::vector<double> breakpoints_;  // radii where extents have kinks
    double fieldTan_ = 0.0;
    int segments_ = 0;
    double cosHalfStep_ = 1.0;  // cos(pi / N): mesh radii lie in [r cos, r]
    std::vector<MechanicalPart> parts_;
};

// Mechanics Builder: Lens Geometry

void MechanicsBuilder::readSurfaces() {
    const int n = static_cast<int>(rx_.surfaces.size());
    double z = 0.0;
    double dir = 1.0;
    for (int i = 0; i < n; ++i) {
        const Surface& s = rx_.surfaces[i];
        SurfaceInfo info;
        info.name = s.name.empty() ? "S" + std::to_string(i) : s.name;
        info.shape = surfaceShape(s);
        info.clearMm = s.clearSemiDiameterMm > 0.0 ? s.clearSemiDiameterMm : s.mechSemiDiameterMm;
        info.mechMm = std::max(s.mechSemiDiameterMm, info.clearMm);
        if (i == 0) {
            info.zMm = std::isfinite(s.thicknessMm) ? -s.thicknessMm : -kInf;
        } else {
            info.zMm = z;
            z += s.thicknessMm;
        }
        surfaces_.push_back(info);
        if (s.mirror) dir = -dir;
        directions_.push_back(dir);
    }
    // Field angle for widening retainers (the chief ray slope in object space).
    double maxDeg = 0.0;
    for (const Field& f : rx_.system.fields) {
        const double h = std::hypot(f.x, f.y);
        if (rx_.system.fieldKind == SystemData::FieldKind::AngleDeg) {
            maxDeg = std::max(maxDeg, h);
        } else if (n > 0 && std::isfinite(rx_.surfaces[0].thicknessMm) &&
                   rx_.surfaces[0].thicknessMm > 0.0) {
            maxDeg = std::max(
                maxDeg, std::atan(h / rx_.surfaces[0].thicknessMm) * 180.0 / std::numbers::pi);
        }
    }
    fieldTan_ = std::tan(std::min(maxDeg, kMaxFieldDeg) * std::numbers::pi / 180.0);
}

void MechanicsBuilder::makeBodies() {
    const std::vector<Element> elements = rx_.elements();
    auto requireSize = [&](int s) {
        const SurfaceInfo& si = surfaces_[s];
        if (!(si.mechMm > 0.0))
            throw ModelError(si.name,
                             "mechanics need its size: give sd or mech_sd (clear or mechanical "
                             "semi-diameter)");
        const double rim = maxRadius(si.shape);
        if (si.mechMm > rim)
            throw ModelError(si.name, "semi-diameter " + fmt(si.mechMm) +
                                          " mm lies beyond the rim of the surface (" + fmt(rim) +
                                          " mm)");
    };
    // Elements; consecutive ones sharing a surface are cemented into one body.
    for (size_t e = 0; e < elements.size(); ++e) {
        const Element& el = elements[e];
        requireSize(el.frontSurface);
        requireSize(el.backSurface);
        Piece p;
        p.name = el.name;
        p.surfaces = {el.frontSurface, el.backSurface};
        p.elementNumber = static_cast<int>(e) + 1;
        p.radiusMm = std::max(surfaces_[el.frontSurface].mechMm, surfaces_[el.backSurface].mechMm);
        const int piece = static_cast<int>(pieces_.size());
        pieces_.push_back(p);
        const bool cemented = e > 0 && elements[e - 1].backSurface == el.frontSurface;
        if (!cemented) {
            Body b;
            b.name = el.name;
            bodies_.push_back(b);
        } else {
            bodies_.back().name += "+" + el.name;
        }
        Body& b = bodies_.back();
        b.pieces.push_back(piece);
        b.radiusMm = std::max(b.radiusMm, p.radiusMm);
        b.spacerNumber = p.elementNumber;
        const int bodyIndex = static_cast<int>(bodies_.size()) - 1;
        surfaces_[el.frontSurface].body = bodyIndex;
        surfaces_[el.backSurface].body = bodyIndex;
    }
    for (size_t e = 0; e < elements.size(); ++e) {
        Piece& p = pieces_[e];
        p.cementedTo.assign(2, 0.0);
        if (e > 0 && elements[e - 1].backSurface == elements[e].frontSurface)
            p.cementedTo[0] = std::min(p.radiusMm, pieces_[e - 1].radiusMm);
        if (e + 1 < elements.size() && elements[e + 1].frontSurface == elements[e].backSurface)
            p.cementedTo[1] = std::min(p.radiusMm, pieces_[e + 1].radiusMm);
        for (int k = 0; k < 2; ++k)
            p.cementedTo[k] = std::min(p.cementedTo[k], maxRadius(surfaces_[p.surfaces[k]].shape));
    }
    // Surfaces that bound glass but belong to no element (the way back out of a Mangin
    // mirror) belong to the body of the glass before them.
    const int n = static_cast<int>(rx_.surfaces.size());
    for (int i = 1; i + 1 < n; ++i) {
        if (surfaces_[i].body < 0 && !rx_.surfaces[i - 1].material.isAir() &&
            surfaces_[i - 1].body >= 0)
            surfaces_[i].body = surfaces_[i - 1].body;
    }
    // Mirrors without glass: thin sheets.
    for (int i = 1; i + 1 < n; ++i) {
        if (!rx_.surfaces[i].mirror || surfaces_[i].body >= 0) continue;
        requireSize(i);
        Piece p;
        p.name = surfaces_[i].name;
        p.surfaces = {i};
        p.cementedTo = {0.0};
        p.sheet = true;
        p.radiusMm = surfaces_[i].mechMm;
        pieces_.push_back(p);
        Body b;
        b.name = p.name;
        b.sheet = true;
        b.pieces = {static_cast<int>(pieces_.size()) - 1};
        b.radiusMm = p.radiusMm;
        bodies_.push_back(b);
        surfaces_[i].body = static_cast<int>(bodies_.size()) - 1;
    }
    for (const SurfaceInfo& s : surfaces_) {
        breakpoints_.push_back(s.clearMm);
        breakpoints_.push_back(s.mechMm);
    }
    for (const Piece& p : pieces_) breakpoints_.push_back(p.radiusMm);
    // Extents, then sort by z (renumbering the surfaces' body index).
    for (Body& b : bodies_) {
        b.zMin = kInf;
        b.zMax = -kInf;
        for (int pi : b.pieces) {
            const Piece& p = pieces_[pi];
            b.zMin = std::min(b.zMin, minOver(
                                          [&](double r) {
                                              double lo, hi;
                                              pieceRange(p, r, lo, hi);
                                              return lo;
                                          },
                                          0.0, p.radiusMm));
            b.zMax = std::max(b.zMax, maxOver(
                                          [&](double r) {
                                              double lo, hi;
                                              pieceRange(p, r, lo, hi);
                                              return hi;
                                          },
                                          0.0, p.radiusMm));
        }
    }
    std::vector<int> order(bodies_.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = static_cast<int>(i);
    std::stable_sort(order.begin(), order.end(),
                     [&](int a, int b) { return bodies_[a].zMin < bodies_[b].zMin; });
    std::vector<int> newIndex(bodies_.size());
    std::vector<Body> sorted;
    for (size_t k = 0; k < order.size(); ++k) {
        newIndex[order[k]] = static_cast<int>(k);
        sorted.push_back(bodies_[order[k]]);
    }
    bodies_ = std::move(sorted);
    for (SurfaceInfo& s : surfaces_)
        if (s.body >= 0) s.body = newIndex[s.body];
}

void MechanicsBuilder::makePaths() {
    const int n = static_cast<int>(surfaces_.size());
    auto endpoint = [&](int i) { return i == 0 || i == n - 1 || surfaces_[i].body >= 0; };
    auto place = [&](int s) {
        return surfaces_[s].body >= 0 ? 2 * surfaces_[s].body + 1 : 2 * regionOfZ(surfaces_[s].zMm);
    };
    int from = 0;
    for (int i = 1; i < n; ++i) {
        if (!endpoint(i)) continue;
        Path p;
        p.from = from;
        p.to = i;
        // The beam the barrel must clear: lens and mirror apertures along the path; the
        // image (and object) plane is not part of the barrel, and the image circle there is
        // wider than any bore near the last lens.
        for (int s = from; s <= i; ++s)
            if (s > 0 && s < n - 1) p.beamMm = std::max(p.beamMm, surfaces_[s].clearMm);
        p.lo = std::min(place(from), place(i));
        p.hi = std::max(place(from), place(i));
        // Light inside glass is the body's own business.
        const bool insideGlass = from > 0 && !rx_.surfaces[from].material.isAir();
        if (!insideGlass) paths_.push_back(p);
        from = i;
    }
}

void MechanicsBuilder::makeRegions() {
    const int nb = static_cast<int>(bodies_.size());
    for (int k = 0; k <= nb; ++k) {
        Region r;
        r.below = k - 1;
        r.above = k < nb ? k : -1;
        for (size_t p = 0; p < paths_.size(); ++p)
            if (paths_[p].crossesRegion(k)) r.paths.push_back(static_cast<int>(p));
        // Simple: one path crosses, from the body on one side to the body on the other.
        if (nb > 0 && r.paths.size() == 1) {
            const Path& path = paths_[r.paths[0]];
            auto touches = [&](int body) {
                return body < 0 || surfaces_[path.from].body == body ||
                       surfaces_[path.to].body == body;
            };
            const bool sheets = (r.below >= 0 && bodies_[r.below].sheet) ||
                                (r.above >= 0 && bodies_[r.above].sheet);
            if (touches(r.below) && touches(r.above) && !sheets) {
                r.simple = true;
                r.path = r.paths[0];
            }
        }
        regions_.push_back(r);
    }
}

int MechanicsBuilder::regionOfZ(double z) const {
    const int nb = static_cast<int>(bodies_.size());
    for (int j = 0; j < nb; ++j) {
        const Body& b = bodies_[j];
        if (z < b.zMin) return j;
        if (z <= b.zMax) return z - b.zMin < b.zMax - z ? j : j + 1;
    }
    return nb;
}

double MechanicsBuilder::lightDirectionOfGap(int gap) const {
    return directions_[std::clamp(gap, 0, static_cast<int>(directions_.size()) - 1)];
}

// Mechanics Builder: Extents and Optimisation

void MechanicsBuilder::pieceRange(const Piece& p, double r, double& lo, double& hi) const {
    // The lens solid (geometry/lens_solid.h): each face exact to its clear semi-diameter and
    // flat beyond it, out to the element's radius; a cemented face exact to the smaller
    // element's radius. A mirror sheet: its sag out to mech_sd.
    lo = kInf;
    hi = -kInf;
    for (size_t k = 0; k < p.surfaces.size(); ++k) {
        const SurfaceInfo& si = surfaces_[p.surfaces[k]];
        const double exactTo = p.sheet ? si.mechMm : std::max(si.clearMm, p.cementedTo[k]);
        const double z = si.at(std::min(r, exactTo));
        lo = std::min(lo, z);
        hi = std::max(hi, z);
    }
}

double MechanicsBuilder::bodyUpper(int b, double r) const {
    const Body& body = bodies_[b];
    r = std::min(r, body.radiusMm);
    double best = -kInf;
    for (int pi : body.pieces) {
        const Piece& p = pieces_[pi];
        if (r > p.radiusMm) continue;
        double lo, hi;
        pieceRange(p, r, lo, hi);
        best = std::max(best, hi);
    }
    return best;
}

double MechanicsBuilder::bodyLower(int b, double r) const {
    const Body& body = bodies_[b];
    r = std::min(r, body.radiusMm);
    double best = kInf;
    for (int pi : body.pieces) {
        const Piece& p = pieces_[pi];
        if (r > p.radiusMm) continue;
        double lo, hi;
        pieceRange(p, r, lo, hi);
        best = std::min(best, lo);
    }
    return best;
}

double MechanicsBuilder::plateUpper(const Plate& p, double r) const {
    if (r > p.ro || r / cosHalfStep_ < p.ri) return -kInf;
    return p.z0 + p.hHi(std::min(r / cosHalfStep_, p.ro));
}

double MechanicsBuilder::plateLower(const Plate& p, double r) const {
    if (r > p.ro || r / cosHalfStep_ < p.ri) return kInf;
    return p.z0 - p.hLo(std::min(r / cosHalfStep_, p.ro));
}

double MechanicsBuilder::itemUpper(const StackItem& it, double r) const {
    return it.isBody ? bodyUpper(it.index, r) : plateUpper(plates_[it.index], r);
}

double MechanicsBuilder::itemLower(const StackItem& it, double r) const {
    return it.isBody ? bodyLower(it.index, r) : plateLower(plates_[it.index], r);
}

double MechanicsBuilder::maxOver(const std::function<double(double)>& f, double r0,
                                 double r1) const {
    if (r1 < r0) std::swap(r0, r1);
    std::vector<double> rs;
    rs.reserve(kPlacementSamples + breakpoints_.size() * 3 + 2);
    for (int i = 0; i <= kPlacementSamples; ++i)
        rs.push_back(i == kPlacementSamples ? r1 : r0 + (r1 - r0) * i / kPlacementSamples);
    for (double b : breakpoints_) {
        for (double x : {b, b * cosHalfStep_, b / cosHalfStep_})
            if (x > r0 && x < r1) rs.push_back(x);
    }
    std::sort(rs.begin(), rs.end());
    size_t best = 0;
    double bestValue = -kInf;
    for (size_t i = 0; i < rs.size(); ++i) {
        const double v = f(rs[i]);
        if (v > bestValue) {
            bestValue = v;
            best = i;
        }
    }
    // Golden-section refinement between the neighbours of the best sample (an interior
    // maximum of an asphere's sag, say).
    if (std::isfinite(bestValue) && best > 0 && best + 1 < rs.size()) {
        double a = rs[best - 1], b = rs[best + 1];
        const double g = (std::sqrt(5.0) - 1.0) / 2.0;
        double c = b - g * (b - a), d = a + g * (b - a);
        double fc = f(c), fd = f(d);
        for (int it = 0; it < 80 && b - a > 1e-12; ++it) {
            if (fc > fd) {
                b = d;
                d = c;
                fd = fc;
                c = b - g * (b - a);
                fc = f(c);
            } else {
                a = c;
                c = d;
                fc = fd;
                d = a + g * (b - a);
                fd = f(d);
            }
        }
        bestValue = std::max({bestValue, fc, fd});
    }
    return bestValue;
}

// Mechanics Builder: Plates

void MechanicsBuilder::makePlates() {
    // Aperture stop.
    if (spec_.stop.enabled && rx_.surfaces.size() >= 3) {
        const int s = rx_.stopIndex();
        const SurfaceInfo& si = surfaces_[s];
        const std::string stopName = rx_.surfaces[s].name.empty() ? "stop" : rx_.surfaces[s].name;
        if (!(rx_.surfaces[s].clearSemiDiameterMm > 0.0))
            throw ModelError(stopName,
                             "the aperture stop needs a clear semi-diameter (sd) to build its "
                             "plate");
        Plate p;
        p.kind = PlateKind::Stop;
        p.name = "stop";
        p.property = propertyOr(spec_.stop.property);
        p.edgeProperty = spec_.stop.edgeProperty.empty() ? p.property : spec_.stop.edgeProperty;
        p.ri = rx_.surfaces[s].clearSemiDiameterMm;
        p.edgeHalf = spec_.stop.edgeMm / 2.0;
        p.tanBevel = std::tan(spec_.stop.bevelDeg * std::numbers::pi / 180.0);
        if (si.body >= 0) {
            // On a lens face or a mirror: the plate goes on the air (incident) side.
            const Body& b = bodies_[si.body];
            bool front = false, back = false;
            for (int pi : b.pieces) {
                const Piece& piece = pieces_[pi];
                if (piece.surfaces.front() == s) front = true;
                if (piece.surfaces.back() == s && !piece.sheet) back = true;
            }
            if (front && back)
                throw ModelError(stopName, "the aperture stop lies on a cemented surface inside " +
                                               b.name + ": no stop plate can be placed there");
            const bool incidentSide = front || b.sheet;
            const double dir = incidentSide ? -lightDirectionOfGap(s - 1) : lightDirectionOfGap(s);
            p.pushedAgainst = si.body;
            p.pushSide = dir < 0 ? -1 : 1;
            p.region = p.pushSide < 0 ? si.body : si.body + 1;
            p.z0 = p.pushSide < 0 ? b.zMin : b.zMax;
        } else {
            p.z0 = si.at(std::min(p.ri, maxRadius(si.shape)));
            p.region = regionOfZ(p.z0);
        }
        plates_.push_back(p);
    }
    // Field stop.
    if (spec_.fieldStop.enabled) {
        const MechanicsSpec::FieldStop& f = spec_.fieldStop;
        Plate p;
        p.kind = PlateKind::FieldStop;
        p.name = "field_stop";
        p.property = propertyOr(f.property);
        p.ri = f.radiusMm;
        p.edgeHalf = p.tLo = p.tHi = f.thicknessMm / 2.0;
        const int image = static_cast<int>(surfaces_.size()) - 1;
        p.z0 = f.zMm ? *f.zMm
                     : surfaces_[image].zMm - lightDirectionOfGap(image - 1) * f.beforeImageMm;
        p.region = regionOfZ(p.z0);
        plates_.push_back(p);
    }
    // Baffles, named by their place in the list.
    for (size_t i = 0; i < spec_.baffles.size(); ++i) {
        const MechanicsSpec::Baffle& b = spec_.baffles[i];
        if (!b.enabled) continue;
        Plate p;
        p.kind = PlateKind::Baffle;
        p.name = "baffle" + std::to_string(i + 1);
        p.property = propertyOr(b.property);
        p.ri = b.innerRadiusMm;
        p.edgeHalf = p.tLo = p.tHi = b.thicknessMm / 2.0;
        p.z0 = b.zMm;
        p.region = regionOfZ(p.z0);
        plates_.push_back(p);
    }
    // Vanes, evenly spaced from from_z_mm to to_z_mm.
    if (spec_.vanes.enabled) {
        const MechanicsSpec::Vanes& v = spec_.vanes;
        for (int i = 0; i < v.count; ++i) {
            Plate p;
            p.kind = PlateKind::Vane;
            p.name = "vane" + std::to_string(i + 1);
            p.property = propertyOr(v.property);
            p.vaneDepth = v.depthMm;
            p.edgeHalf = p.tLo = p.tHi = v.thicknessMm / 2.0;
            p.z0 = v.count == 1 ? 0.5 * (v.fromZMm + v.toZMm)
                                : v.fromZMm + (v.toZMm - v.fromZMm) * i / (v.count - 1);
            p.region = regionOfZ(p.z0);
            plates_.push_back(p);
        }
    }
    for (size_t i = 0; i < plates_.size(); ++i)
        regions_[plates_[i].region].plates.push_back(static_cast<int>(i));
    for (Region& r : regions_)
        std::stable_sort(r.plates.begin(), r.plates.end(),
                         [&](int a, int b) { return plates_[a].z0 < plates_[b].z0; });
}

void MechanicsBuilder::computeBores() {
    const double c = spec_.barrel.clearanceMm;
    for (int j = 0; j < static_cast<int>(bodies_.size()); ++j) {
        Body& b = bodies_[j];
        b.boreMm = b.radiusMm + c;
        // Light of other paths passing beside it.
        for (const Path& p : paths_)
            if (p.crossesBody(j)) b.boreMm = std::max(b.boreMm, p.beamMm + c);
    }
    for (Region& r : regions_) {
        double plateNeed = 0.0;
        r.widestPlate = -1;
        for (int pi : r.plates)
            if (plates_[pi].kind != PlateKind::Vane &&
                plates_[pi].ri + kMinPlateWidthMm > plateNeed) {
                plateNeed = plates_[pi].ri + kMinPlateWidthMm;
                r.widestPlate = pi;
            }
        double bore = plateNeed;
        if (r.simple) {
            const double beam = paths_[r.path].beamMm;
            double seat = kInf;
            if (r.below >= 0) seat = std::min(seat, bodies_[r.below].radiusMm);
            if (r.above >= 0) seat = std::min(seat, bodies_[r.above].radiusMm);
            bore = std::max({bore, seat + c, beam + c, beam + kSpacerWallMm + spec_.contactGapMm});
        } else if (r.below < 0 || r.above < 0) {
            // An end region (object or image side): the barrel ends a retainer's width
            // into it, so it keeps the bore of the body it closes; the beam on its way to
            // the image plane widens beyond the barrel and is not the barrel's concern.
            bore = std::max(bore, bodies_[r.below >= 0 ? r.below : r.above].boreMm);
        } else {
            if (r.below >= 0) bore = std::max(bore, bodies_[r.below].boreMm);
            if (r.above >= 0) bore = std::max(bore, bodies_[r.above].boreMm);
            for (int p : r.paths) bore = std::max(bore, paths_[p].beamMm + c);
        }
        r.boreMm = bore;
    }
    double largest = 0.0;
    for (const Body& b : bodies_) largest = std::max(largest, b.boreMm);
    std::string largestPart = "the barrel's outside (its bore plus wall_mm)";
    for (const Region& r : regions_)
        if (r.boreMm > largest) {
            largest = r.boreMm;
            // A plate whose opening sets the bore is what to look at, not the barrel.
            if (r.widestPlate >= 0 &&
                plates_[r.widestPlate].ri + kMinPlateWidthMm >= r.boreMm)
                largestPart = "the barrel's outside around " + plates_[r.widestPlate].name +
                              " (its inner radius plus " + fmt(kMinPlateWidthMm) +
                              " mm of plate plus wall_mm)";
        }
    largest += spec_.barrel.wallMm;
    for (const MechanicsSpec::Part& part : spec_.parts)
        if (part.enabled)
            for (const Vec2& v : part.profileMm)
                if (v.x > largest) {
                    largest = v.x;
                    largestPart = "part " + part.name;
                }
    // Bounded work: refuse before meshing what would take a mesh of more segments.
    if (!std::isfinite(largest) ||
        chordError(largest, kMaxMechanicsSegments) > spec_.chordToleranceMm) {
        // pi / acos(1 - x), by its series where 1 - x rounds to 1.
        const double x = spec_.chordToleranceMm / largest;
        const double needed = x < 1e-6 ? std::numbers::pi / std::sqrt(2.0 * x)
                                       : std::numbers::pi / std::acos(1.0 - x);
        throw ModelError(
            "mechanics",
            "the largest radius, " + fmt(largest) + " mm at " + largestPart +
                ", needs about " + fmt(needed, 0) + " segments per turn for chord_tolerance_mm = " +
                fmt(spec_.chordToleranceMm, 6) + "; at most " +
                std::to_string(kMaxMechanicsSegments) +
                ": raise chord_tolerance_mm to at least " +
                fmt(chordError(largest, kMaxMechanicsSegments), 6) +
                " or check the radii (a baffle's inner_radius_mm, the barrel's wall_mm, a part's "
                "profile_mm)");
    }
    segments_ = chordSegmentCount(largest, spec_.chordToleranceMm);
    cosHalfStep_ = std::cos(std::numbers::pi / segments_);
    for (Plate& p : plates_) {
        p.ro = regions_[p.region].boreMm - spec_.contactGapMm;
        if (p.kind == PlateKind::Vane) {
            p.ri = p.ro - p.vaneDepth;
            if (!(p.ri > 0.0))
                throw ModelError(p.name, "depth " + fmt(p.vaneDepth) +
                                             " mm reaches the axis: the bore there is " +
                                             fmt(regions_[p.region].boreMm) + " mm");
        }
        if (!(p.ri + kMinRingWallMm <= p.ro))
            throw ModelError(p.name, "aperture radius " + fmt(p.ri) +
                                         " mm leaves no room inside the bore (" +
                                         fmt(regions_[p.region].boreMm) + " mm)");
        breakpoints_.push_back(p.ri);
        breakpoints_.push_back(p.ro);
    }
    for (const Region& r : regions_) breakpoints_.push_back(r.boreMm);
    for (const Body& b : bodies_) breakpoints_.push_back(b.boreMm);
}

void MechanicsBuilder::placePlates() {
    for (Plate& p : plates_)
        if (p.kind == PlateKind::Stop) placeStop(p);
}

void MechanicsBuilder::placeStop(Plate& p) {
    const double gap = spec_.contactGapMm;
    const double e = p.edgeHalf;
    const bool explicitThickness = spec_.stop.thicknessMm.has_value();
    const double T = std::max(spec_.stop.thicknessMm.value_or(kDefaultStopThicknessMm), 2.0 * e);
    // The bevel must reach full thickness inside the plate: the automatic thickness gets
    // there within half the plate's width; a thickness the user gave must get there at all.
    const double bevelRise = (p.ro - p.ri) * p.tanBevel;
    if (explicitThickness && T / 2.0 - e >= bevelRise)
        throw ModelError("stop", "thickness_mm = " + fmt(T) +
                                     " mm is too thick for the plate: its " +
                                     fmt(spec_.stop.bevelDeg, 1) + " deg bevels would need " +
                                     fmt((T / 2.0 - e) / p.tanBevel) + " mm of its " +
                                     fmt(p.ro - p.ri) + " mm radial width");
    const double tCap = explicitThickness ? T / 2.0 : e + 0.5 * bevelRise;
    const double r0 = p.ri * cosHalfStep_, r1 = p.ro;
    // Largest half-thickness on one side that keeps clear of `body` (-1: none).
    auto maxSide = [&](int body, bool upperSide) {
        if (body < 0) return std::min(T, tCap);
        auto fits = [&](double t) {
            Plate q = p;
            (upperSide ? q.tHi : q.tLo) = t;
            if (upperSide)
                return minOver(
                           [&](double r) { return bodyLower(body, r) - gap - plateUpper(q, r); },
                           r0, r1) >= 0.0;
            return minOver([&](double r) { return plateLower(q, r) - gap - bodyUpper(body, r); },
                           r0, r1) >= 0.0;
        };
        double lo = e, hi = std::min(T, tCap);
        if (fits(hi)) return hi;
        if (!fits(lo)) return lo;
        for (int it = 0; it < 60; ++it) {
            const double mid = 0.5 * (lo + hi);
            (fits(mid) ? lo : hi) = mid;
        }
        return lo;
    };
    const Region& region = regions_[p.region];
    if (p.pushedAgainst >= 0) {
        // Against the glass (or mirror) on one side: half the thickness there, the plate
        // moved until it keeps the contact gap; the other half on the free side.
        const int body = p.pushedAgainst;
        const double half = std::min(T / 2.0, tCap);
        p.tLo = p.tHi = half;
        if (p.pushSide < 0) {
            p.z0 = 0.0;
            p.z0 = minOver([&](double r) { return bodyLower(body, r) - gap - plateUpper(p, r); },
                           r0, r1);
            p.tLo = std::min(T - half, maxSide(region.below, false));
        } else {
            p.z0 = 0.0;
            p.z0 = -minOver([&](double r) { return plateLower(p, r) - gap - bodyUpper(body, r); },
                            r0, r1);
            p.tHi = std::min(T - half, maxSide(region.above, true));
        }
        return;
    }
    const double maxLo = maxSide(region.below, false);
    const double maxHi = maxSide(region.above, true);
    double tLo = std::min(T / 2.0, maxLo);
    const double tHi = std::min(T - tLo, maxHi);
    tLo = std::min(T - tHi, maxLo);
    if (explicitThickness && tLo + tHi < T - 1e-12) {
        // The thickness asked for does not fit: build it anyway; the clearance check names
        // what it collides with.
        p.tLo = p.tHi = std::min(T / 2.0, tCap);
        return;
    }
    p.tLo = tLo;
    p.tHi = tHi;
}

// Mechanics Builder: Rings

void MechanicsBuilder::makeSpacersAndRetainers() {
    const double gap = spec_.contactGapMm;
    const double c = cosHalfStep_;
    auto facingRadius = [&](const StackItem& it, const Region& r) {
        if (!it.isBody) return plates_[it.index].ri;
        // The face of the body the region's path leaves or enters by.
        if (r.path >= 0) {
            const Path& path = paths_[r.path];
            if (surfaces_[path.from].body == it.index) return surfaces_[path.from].clearMm;
            if (surfaces_[path.to].body == it.index) return surfaces_[path.to].clearMm;
        }
        return bodies_[it.index].radiusMm;
    };
    auto ring = [&](double rin, double rout, double z0, double z1) {
        return std::vector<Vec2>{{rin, z0}, {rout, z0}, {rout, z1}, {rin, z1}};
    };

    // Retainers: in front of the first item and behind the last, in simple end regions.
    if (spec_.retainers.enabled && !regions_.empty() && !bodies_.empty()) {
        const double w = spec_.retainers.widthMm;
        for (int end = 0; end < 2; ++end) {
            const std::string name = end == 0 ? "retainer1" : "retainer2";
            const Region& r = end == 0 ? regions_.front() : regions_.back();
            StackItem it;
            if (end == 0)
                it = r.plates.empty() ? StackItem{true, 0} : StackItem{false, r.plates.front()};
            else
                it = r.plates.empty() ? StackItem{true, static_cast<int>(bodies_.size()) - 1}
                                      : StackItem{false, r.plates.back()};
            if (!r.simple) {
                note(name + ": left out: light crosses the space " +
                     (end == 0 ? std::string("in front of the first part")
                               : std::string("behind the last part")) +
                     " more than once, or a mirror is there");
                continue;
            }
            const double rin = facingRadius(it, r) + w * fieldTan_;
            const double rout = r.boreMm - gap;
            if (rin + kMinRingWallMm > rout) {
                note(name + ": left out: no radial room between the beam (" + fmt(rin) +
                     " mm) and the bore (" + fmt(r.boreMm) + " mm)");
                continue;
            }
            double z0, z1;
            if (end == 0) {
                z1 = minOver([&](double x) { return itemLower(it, x); }, rin * c, rout) - gap;
                z0 = z1 - w;
            } else {
                z0 = maxOver([&](double x) { return itemUpper(it, x); }, rin * c, rout) + gap;
                z1 = z0 + w;
            }
            // Never across the object or image plane (a field stop just before the image).
            const double objectZ = surfaces_.front().zMm, imageZ = surfaces_.back().zMm;
            if ((objectZ >= z0 && objectZ <= z1) || (imageZ >= z0 && imageZ <= z1)) {
                note(name + ": left out: it would cross the " +
                     std::string(imageZ >= z0 && imageZ <= z1 ? "image" : "object") + " plane");
                continue;
            }
            addPart(name, propertyOr(spec_.retainers.property), ring(rin, rout, z0, z1));
        }
    }

    // Spacers: in simple regions, between every two neighbouring items.
    if (spec_.spacers.enabled) {
        for (const Region& r : regions_) {
            if (!r.simple) continue;
            std::vector<StackItem> items;
            if (r.below >= 0) items.push_back({true, r.below});
            for (int pi : r.plates) items.push_back({false, pi});
            if (r.above >= 0) items.push_back({true, r.above});
            const int slots = static_cast<int>(items.size()) - 1;
            const int number = r.below >= 0 ? bodies_[r.below].spacerNumber : 0;
            for (int k = 0; k < slots; ++k) {
                std::string name = "spacer" + std::to_string(number);
                if (slots > 1) name += static_cast<char>('a' + k);
                const StackItem &a = items[k], &b = items[k + 1];
                const double rin = std::max(facingRadius(a, r), facingRadius(b, r));
                const double rout = r.boreMm - gap;
                if (rin + kMinRingWallMm > rout) {
                    note(name + ": left out: no radial room between the beam (" + fmt(rin) +
                         " mm) and the bore (" + fmt(r.boreMm) + " mm)");
                    continue;
                }
                const double z0 =
                    maxOver([&](double x) { return itemUpper(a, x); }, rin * c, rout) + gap;
                const double z1 =
                    minOver([&](double x) { return itemLower(b, x); }, rin * c, rout) - gap;
                if (!(z1 - z0 >= spec_.spacers.minLengthMm) || !std::isfinite(z1 - z0)) {
                    note(name + ": left out: " + fmt(z1 - z0) +
                         " mm of axial room (min_length_mm = " + fmt(spec_.spacers.minLengthMm) +
                         ")");
                    continue;
                }
                addPart(name, propertyOr(spec_.spacers.property), ring(rin, rout, z0, z1));
            }
        }
    }
}

// Mechanics Builder: Barrel

void MechanicsBuilder::makeBarrel() {
    if (!spec_.barrel.enabled || bodies_.empty()) return;
    const double gap = spec_.contactGapMm;
    const double c = cosHalfStep_;
    const int nb = static_cast<int>(bodies_.size());

    // Axial extent: everything built so far, and every body.
    double zStart = bodies_.front().zMin, zEnd = bodies_.back().zMax;
    for (const Body& b : bodies_) {
        zStart = std::min(zStart, b.zMin);
        zEnd = std::max(zEnd, b.zMax);
    }
    for (const MechanicalPart& part : parts_)
        for (const Vec2& v : part.profile) {
            zStart = std::min(zStart, v.y);
            zEnd = std::max(zEnd, v.y);
        }
    for (const Plate& p : plates_) {
        zStart = std::min(zStart, p.z0 - p.tLo);
        zEnd = std::max(zEnd, p.z0 + p.tHi);
    }

    // Bores along z: region 0, body 0, region 1, ..., body nb-1, region nb, with the step
    // between a body and a region at its rim (toward a wider region) or where the narrower
    // region's bore clears the glass (a seat).
    struct Step {
        double z;
        double boreAfter;
    };
    std::vector<Step> steps;
    auto bore = [&](int k) {
        const Region& r = regions_[k];
        // An end region with nothing in it keeps the body's bore.
        const bool empty = (r.below < 0 || r.above < 0) && r.plates.empty();
        if (empty) {
            const bool front = r.below < 0;
            bool ringThere = false;
            for (const MechanicalPart& part : parts_)
                if (part.name == (front ? "retainer1" : "retainer2")) ringThere = true;
            if (!ringThere) return bodies_[front ? r.above : r.below].boreMm;
        }
        return r.boreMm;
    };
    double first = bore(0);
    for (int j = 0; j < nb; ++j) {
        const Body& b = bodies_[j];
        const double R = b.radiusMm;
        const double below = bore(j), above = bore(j + 1), own = b.boreMm;
        // Lower side of body j.
        double zLowerStep;
        if (below > own)
            zLowerStep = bodyLower(j, R);
        else
            zLowerStep =
                minOver([&](double r) { return bodyLower(j, r); }, std::min(below * c, R), R) - gap;
        // Upper side.
        double zUpperStep;
        if (above > own)
            zUpperStep = bodyUpper(j, R);
        else
            zUpperStep =
                maxOver([&](double r) { return bodyUpper(j, r); }, std::min(above * c, R), R) + gap;
        steps.push_back({zLowerStep, own});
        steps.push_back({zUpperStep, above});
    }
    // Keep the steps in order (a clash shows up in the clearance checks) and inside the tube.
    for (size_t i = 1; i < steps.size(); ++i) steps[i].z = std::max(steps[i].z, steps[i - 1].z);
    std::vector<Step> inside;
    double startBore = first;
    for (const Step& s : steps) {
        if (s.z <= zStart) {
            startBore = s.boreAfter;
            continue;
        }
        if (s.z >= zEnd) break;
        inside.push_back(s);
    }
    // Merge equal bores and steps at the same z.
    std::vector<Step> merged;
    double current = startBore;
    for (const Step& s : inside) {
        if (s.boreAfter == current) continue;
        if (!merged.empty() && merged.back().z == s.z) {
            merged.back().boreAfter = s.boreAfter;
        } else {
            merged.push_back(s);
        }
        current = s.boreAfter;
    }
    // The wall follows the bore: over each bore segment the outside is the wall thickness
    // beyond the largest bore of that segment and its two neighbours, so a step in the bore
    // deeper than the wall still leaves a shoulder of material (the outside and the bore
    // never share a radius at a step).
    const double wall = spec_.barrel.wallMm;
    std::vector<double> segBore{startBore};
    std::vector<double> segZ{zStart};
    for (const Step& s : merged) {
        segBore.push_back(s.boreAfter);
        segZ.push_back(s.z);
    }
    segZ.push_back(zEnd);
    const size_t n = segBore.size();
    std::vector<double> outerR(n);
    for (size_t i = 0; i < n; ++i) {
        double m = segBore[i];
        if (i > 0) m = std::max(m, segBore[i - 1]);
        if (i + 1 < n) m = std::max(m, segBore[i + 1]);
        outerR[i] = m + wall;
    }
    // Counter-clockwise: the outside from zStart to zEnd, then the bore back down.
    std::vector<Vec2> profile;
    profile.push_back({segBore[0], segZ[0]});
    for (size_t i = 0; i < n; ++i) {
        profile.push_back({outerR[i], segZ[i]});
        profile.push_back({outerR[i], segZ[i + 1]});
    }
    for (size_t i = n; i-- > 0;) {
        profile.push_back({segBore[i], segZ[i + 1]});
        profile.push_back({segBore[i], segZ[i]});
    }
    // Remove repeated points (a step at zStart or zEnd).
    std::vector<Vec2> clean;
    for (const Vec2& v : profile)
        if (clean.empty() || clean.back() != v) clean.push_back(v);
    while (clean.size() > 1 && clean.back() == clean.front()) clean.pop_back();
    // Drop middle points of straight runs (same r or same z on both sides).
    for (bool changed = true; changed && clean.size() > 3;) {
        changed = false;
        for (size_t i = 0; i < clean.size(); ++i) {
            const Vec2& p = clean[(i + clean.size() - 1) % clean.size()];
            const Vec2& q = clean[i];
            const Vec2& r = clean[(i + 1) % clean.size()];
            if ((p.x == q.x && q.x == r.x) || (p.y == q.y && q.y == r.y)) {
                clean.erase(clean.begin() + static_cast<long>(i));
                changed = true;
                break;
            }
        }
    }
    addPart("barrel", propertyOr(spec_.barrel.property), std::move(clean));
}

// Mechanics Builder: Parts and Checks

void MechanicsBuilder::addPart(const std::string& name, const std::string& property,
                               std::vector<Vec2> profile, const std::string& edgeName,
                               const std::string& edgeProperty) {
    MechanicalPart part;
    part.name = name;
    part.property = property;
    part.segments = segments_;
    RevolvedMesh rm = revolveProfile(profile, segments_);
    part.mesh = std::move(rm.mesh);
    const auto total = static_cast<uint32_t>(part.mesh.triangles.size());
    if (edgeName.empty()) {
        part.namedRanges.push_back({name, property, 0, total});
    } else {
        // The last profile edge is the named edge.
        const uint32_t edgeFirst = rm.edgeFirstTriangle[rm.edgeFirstTriangle.size() - 2];
        part.namedRanges.push_back({name, property, 0, edgeFirst});
        part.namedRanges.push_back({edgeName, edgeProperty, edgeFirst, total - edgeFirst});
    }
    part.profile = std::move(profile);
    parts_.push_back(std::move(part));
}

// Signed depth of a point inside a polygon: distance to its boundary, positive inside.
double depthInPolygon(const std::vector<Vec2>& poly, const Vec2& p) {
    bool inside = false;
    double dist = kInf;
    const size_t n = poly.size();
    for (size_t i = 0, j = n - 1; i < n; j = i++) {
        const Vec2 &a = poly[j], &b = poly[i];
        if ((b.y > p.y) != (a.y > p.y)) {
            const double x = b.x + (p.y - b.y) * (a.x - b.x) / (a.y - b.y);
            if (p.x < x) inside = !inside;
        }
        const Vec2 ab = b - a;
        const double len2 = glm::dot(ab, ab);
        const double t = len2 > 0.0 ? std::clamp(glm::dot(p - a, ab) / len2, 0.0, 1.0) : 0.0;
        dist = std::min(dist, glm::length(p - (a + t * ab)));
    }
    return inside ? dist : -dist;
}

void MechanicsBuilder::checkAgainstGlass(const MechanicalPart& part) const {
    const double c = cosHalfStep_;
    double partRMin = kInf, partRMax = 0.0, partZMin = kInf, partZMax = -kInf;
    for (const Vec2& v : part.profile) {
        partRMin = std::min(partRMin, v.x * c);
        partRMax = std::max(partRMax, v.x);
        partZMin = std::min(partZMin, v.y);
        partZMax = std::max(partZMax, v.y);
    }
    for (const Piece& piece : pieces_) {
        // Piece extent for a quick rejection.
        const double zMin = minOver(
            [&](double r) {
                double lo, hi;
                pieceRange(piece, r, lo, hi);
                return lo;
            },
            0.0, piece.radiusMm);
        const double zMax = maxOver(
            [&](double r) {
                double lo, hi;
                pieceRange(piece, r, lo, hi);
                return hi;
            },
            0.0, piece.radiusMm);
        if (partRMin > piece.radiusMm || partZMax < zMin || partZMin > zMax) continue;

        double worst = kPenetrationMm;
        Vec2 where{0.0};
        // (1) Points of the part (its profile and the chordal mesh radii) inside the glass.
        if (!piece.sheet) {
            const size_t n = part.profile.size();
            for (size_t i = 0; i < n; ++i) {
                const Vec2 a = part.profile[i], b = part.profile[(i + 1) % n];
                const double len = glm::length(b - a);
                const size_t steps =
                    std::min<size_t>(kMaxCheckSamplesPerEdge,
                                     static_cast<size_t>(std::ceil(len / kCheckStepMm)) + 1);
                for (size_t k = 0; k <= steps; ++k) {
                    const Vec2 q = a + (b - a) * (static_cast<double>(k) / steps);
                    if (q.y < zMin || q.y > zMax) continue;
                    for (double r : {q.x, q.x * c}) {
                        if (r > piece.radiusMm) continue;
                        double lo, hi;
                        pieceRange(piece, r, lo, hi);
                        const double d = std::min({q.y - lo, hi - q.y, piece.radiusMm - r});
                        if (d > worst) {
                            worst = d;
                            where = {r, q.y};
                        }
                    }
                }
            }
        }
        // (2) Points of the glass boundary (or the mirror sheet) inside the part's mesh: the
        // mesh holds (r, z) when the profile holds (r', z) for some r' in [r, r / c].
        auto probe = [&](double r, double z) {
            if (z < partZMin || z > partZMax || r < partRMin || r > partRMax) return;
            for (double rr : {r, 0.5 * (r + r / c), r / c}) {
                const double d = depthInPolygon(part.profile, {rr, z});
                if (d > worst) {
                    worst = d;
                    where = {r, z};
                }
            }
        };
        const double R = piece.radiusMm;
        const size_t steps = static_cast<size_t>(std::ceil(R / kCheckStepMm)) + 1;
        for (size_t k = 0; k <= steps; ++k) {
            const double r = R * static_cast<double>(k) / steps;
            double lo, hi;
            pieceRange(piece, r, lo, hi);
            probe(r, lo);
            if (hi != lo) probe(r, hi);
        }
        double lo, hi;
        pieceRange(piece, R, lo, hi);
        const size_t rimSteps = static_cast<size_t>(std::ceil((hi - lo) / kCheckStepMm)) + 1;
        for (size_t k = 0; k <= rimSteps; ++k) probe(R, lo + (hi - lo) * k / rimSteps);

        if (worst > kPenetrationMm)
            throw ModelError(part.name, "collides with " + piece.name + " (at r = " + fmt(where.x) +
                                            " mm, z = " + fmt(where.y) + " mm, " + fmt(worst, 4) +
                                            " mm deep)");
    }
}

void MechanicsBuilder::checkParts() {
    for (const MechanicalPart& part : parts_) {
        const MeshCheck check = checkMesh(part.mesh);
        if (!check.valid()) throw ModelError(part.name, "invalid mesh: " + check.problems());
    }
    std::vector<Bounds3> bounds;
    for (const MechanicalPart& part : parts_) bounds.push_back(part.mesh.bounds());
    auto overlap = [](const Bounds3& a, const Bounds3& b) {
        return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y &&
               a.lo.z <= b.hi.z && b.lo.z <= a.hi.z;
    };
    for (size_t i = 0; i < parts_.size(); ++i)
        for (size_t j = i + 1; j < parts_.size(); ++j)
            if (overlap(bounds[i], bounds[j]) && meshesIntersect(parts_[i].mesh, parts_[j].mesh))
                throw ModelError(parts_[i].name, "collides with " + parts_[j].name +
                                                     " (the meshes intersect or touch)");
}

std::vector<MechanicalPart> MechanicsBuilder::build() {
    if (rx_.surfaces.size() < 3) return {};
    readSurfaces();
    makeBodies();
    makePaths();
    makeRegions();
    makePlates();
    if (bodies_.empty() && plates_.empty()) return {};
    computeBores();
    placePlates();
    // Plates are placed where the user (or the stop surface) says: check them against the
    // glass first, so a misplaced one is named rather than the spacer next to it.
    for (const Plate& p : plates_) {
        // Counter-clockwise; the stop's knife edge is the closing edge.
        const double zl = p.z0 - p.edgeHalf, zu = p.z0 + p.edgeHalf;
        std::vector<Vec2> profile{{p.ri, zl}};
        if (p.tLo > p.edgeHalf)
            profile.push_back({p.ri + (p.tLo - p.edgeHalf) / p.tanBevel, p.z0 - p.tLo});
        profile.push_back({p.ro, p.z0 - p.tLo});
        profile.push_back({p.ro, p.z0 + p.tHi});
        if (p.tHi > p.edgeHalf)
            profile.push_back({p.ri + (p.tHi - p.edgeHalf) / p.tanBevel, p.z0 + p.tHi});
        profile.push_back({p.ri, zu});
        if (p.kind == PlateKind::Stop)
            addPart(p.name, p.property, std::move(profile), "stop.edge", p.edgeProperty);
        else
            addPart(p.name, p.property, std::move(profile));
        checkAgainstGlass(parts_.back());
    }
    const size_t plateParts = parts_.size();
    makeSpacersAndRetainers();
    makeBarrel();
    for (size_t i = plateParts; i < parts_.size(); ++i) checkAgainstGlass(parts_[i]);
    const size_t builtParts = parts_.size();
    for (const MechanicsSpec::Part& part : spec_.parts) {
        if (!part.enabled) continue;
        std::vector<Vec2> profile = part.profileMm;  // either orientation, revolved ccw
        if (profileArea(profile) < 0.0) std::reverse(profile.begin(), profile.end());
        addPart(part.name, propertyOr(part.property), std::move(profile));
        checkAgainstGlass(parts_.back());
    }
    checkParts();
    // Order: barrel, retainers, spacers, then the plates as made (stop, field stop, baffles,
    // vanes), then the user's parts as given.
    auto rank = [](const std::string& name) {
        if (name == "barrel") return 0;
        if (name.rfind("retainer", 0) == 0) return 1;
        if (name.rfind("spacer", 0) == 0) return 2;
        return 3;
    };
    for (size_t i = builtParts; i < parts_.size(); ++i)
        for (size_t j = 0; j < i; ++j)
            if (parts_[j].name == parts_[i].name)
                throw ModelError(parts_[i].name,
                                 "the part's name is already used by a part "
                                 "veil builds; choose another");

    std::stable_sort(parts_.begin(), parts_.begin() + static_cast<std::ptrdiff_t>(builtParts),
                     [&](const MechanicalPart& a, const MechanicalPart& b) {
                         return rank(a.name) < rank(b.name);
                     });
    return std::move(parts_);
}

}  // namespace

// Mechanics Functions

std::vector<MechanicalPart> buildMechanics(const Prescription& prescription,
                                           const MechanicsSpec& spec,
                                           std::vector<std::string>* notes) {
    // Every part is a solid of revolution about the global axis: a lens whose surfaces a
    // coordinate break tilts or decenters would be mounted where it is not.
    // (A tilted image plane alone mounts nothing off the axis.)
    const int off = firstSurfaceOffAxis(prescription, surfaceFrames(prescription));
    if (off >= 0 && off < prescription.imageIndex()) {
        const Surface& s = prescription.surfaces[off];
        const std::string name = s.name.empty() ? "surface " + std::to_string(off) : s.name;
        int lastBreak = off - 1;  // the break that took it off the axis
        while (!prescription.surfaces[lastBreak].coordinateBreak) --lastBreak;
        const Surface& b = prescription.surfaces[lastBreak];
        throw ModelError("mechanics",
                         "the mount generator builds barrels, spacers and stops about one "
                         "axis, and " + name + " is tilted or decentered off it by the "
                         "coordinate break " + (b.name.empty() ? "surface " + std::to_string(lastBreak) : b.name) +
                         ": leave [mechanics] out of this scene and bring the mounts in as "
                         "[[mesh]] parts placed in global coordinates");
    }
    if (const int a = prescription.firstAnamorphic(); a >= 0) {
        const Surface& s = prescription.surfaces[a];
        throw ModelError("mechanics",
                         "the mount generator seats lenses on rims of revolution, and " +
                             (s.name.empty() ? "surface " + std::to_string(a) : s.name) + " is " +
                             s.anamorphic->label() +
                             ": leave [mechanics] out of this scene and bring the mounts in as "
                             "[[mesh]] parts");
    }
    MechanicsBuilder builder(prescription, spec, notes);
    return builder.build();
}

// Printing

std::ostream& operator<<(std::ostream& os, const NamedTriangleRange& r) {
    os << r.name << "[" << r.firstTriangle << ", +" << r.triangleCount << ")";
    if (!r.property.empty()) os << " " << r.property;
    return os;
}

std::ostream& operator<<(std::ostream& os, const MechanicalPart& p) {
    os << "MechanicalPart{" << p.name;
    if (!p.property.empty()) os << ", property " << p.property;
    os << ", " << p.mesh << ", " << p.segments << " segments, ranges";
    for (const NamedTriangleRange& r : p.namedRanges) os << " " << r;
    return os << "}";
}

std::ostream& operator<<(std::ostream& os, const MechanicsSpec& s) {
    os << "MechanicsSpec{chord " << s.chordToleranceMm << " mm, gap " << s.contactGapMm << " mm";
    if (!s.property.empty()) os << ", property " << s.property;
    if (s.barrel.enabled)
        os << ", barrel wall " << s.barrel.wallMm << " clearance " << s.barrel.clearanceMm;
    if (s.retainers.enabled) os << ", retainers " << s.retainers.widthMm;
    if (s.spacers.enabled) os << ", spacers";
    if (s.stop.enabled) {
        os << ", stop edge " << s.stop.edgeMm;
        if (s.stop.thicknessMm) os << " thickness " << *s.stop.thicknessMm;
        os << " bevel " << s.stop.bevelDeg << " deg";
    }
    if (s.fieldStop.enabled) os << ", field stop r " << s.fieldStop.radiusMm;
    int baffles = 0;
    for (const auto& b : s.baffles) baffles += b.enabled;
    if (baffles > 0) os << ", " << baffles << " baffles";
    if (s.vanes.enabled) os << ", " << s.vanes.count << " vanes";
    for (const auto& p : s.parts)
        if (p.enabled) os << ", part " << p.name;
    return os << "}";
}

// Reading [mechanics]

namespace {

// A part given as `key = false`, `key = true` or `key = { ... }`. Returns the table when
// there is one; `enabled` is set from the boolean or the table's `enabled` key.
std::optional<TomlTable> partTable(const TomlTable& m, std::string_view key, bool& enabled) {
    const auto v = m.get(key);
    if (!v) return std::nullopt;
    if (v->isBool()) {
        enabled = v->asBool();
        return std::nullopt;
    }
    if (!v->isTable()) v->failExpected("a table or a boolean");
    TomlTable t = v->asTable();
    enabled = t.boolean("enabled", true);
    return t;
}

}  // namespace

MechanicsSpec readMechanicsTable(const TomlTable& m) {
    MechanicsSpec s;
    const NumberRange positive = NumberRange::above(0.0);
    s.chordToleranceMm = m.number("chord_tolerance_mm", s.chordToleranceMm, positive);
    s.contactGapMm = m.number("contact_gap_mm", s.contactGapMm, positive);
    s.property = m.string("property");
    if (const auto v = m.get("lens_edges")) {
        const TomlTable t = v->asTable();
        s.lensEdgeProperty = t.string("property");
    }

    if (const auto t = partTable(m, "barrel", s.barrel.enabled)) {
        s.barrel.wallMm = t->number("wall_mm", s.barrel.wallMm, positive);
        s.barrel.clearanceMm = t->number("clearance_mm", s.barrel.clearanceMm, positive);
        s.barrel.property = t->string("property");
    }
    if (const auto t = partTable(m, "retainers", s.retainers.enabled)) {
        s.retainers.widthMm = t->number("width_mm", s.retainers.widthMm, positive);
        s.retainers.property = t->string("property");
    }
    if (const auto t = partTable(m, "spacers", s.spacers.enabled)) {
        s.spacers.minLengthMm =
            t->number("min_length_mm", s.spacers.minLengthMm, NumberRange::atLeast(0.0));
        s.spacers.property = t->string("property");
    }
    if (const auto t = partTable(m, "stop", s.stop.enabled)) {
        s.stop.edgeMm = t->number("edge_mm", s.stop.edgeMm, positive);
        if (const auto v = t->get("thickness_mm")) {
            s.stop.thicknessMm = v->asNumber(positive);
            if (*s.stop.thicknessMm < s.stop.edgeMm)
                v->fail(v->path() + " must be at least edge_mm (" + fmt(s.stop.edgeMm, 4) +
                        " mm): the knife edge is part of the plate");
        }
        s.stop.bevelDeg =
            t->number("bevel_deg", s.stop.bevelDeg, NumberRange::strictlyBetween(0, 90));
        s.stop.property = t->string("property");
        s.stop.edgeProperty = t->string("edge_property");
    }
    {
        const auto v = m.get("field_stop");
        if (v) {
            bool enabled = true;
            if (v->isBool()) {
                if (v->asBool()) v->fail(v->path() + " needs at least radius_mm: write a table");
                enabled = false;
            } else {
                const auto t = partTable(m, "field_stop", enabled);
                MechanicsSpec::FieldStop& f = s.fieldStop;
                const auto z = t->get("z_mm");
                const auto before = t->get("before_image_mm");
                if (z && before)
                    before->fail("give z_mm or before_image_mm in " + t->displayName() +
                                 ", not both");
                if (z) f.zMm = z->asNumber();
                if (before) f.beforeImageMm = before->asNumber();
                f.radiusMm = t->require("radius_mm", "aperture radius of the field stop, mm")
                                 .asNumber(positive);
                f.thicknessMm = t->number("thickness_mm", f.thicknessMm, positive);
                f.property = t->string("property");
            }
            s.fieldStop.enabled = enabled;
        }
    }
    if (const auto v = m.get("baffles")) {
        for (const TomlValue& entry : v->asArray()) {
            const TomlTable t = entry.asTable();
            MechanicsSpec::Baffle b;
            b.enabled = t.boolean("enabled", true);
            b.zMm = t.require("z_mm", "mid-plane of the baffle, global z in mm").asNumber();
            b.innerRadiusMm =
                t.require("inner_radius_mm", "aperture radius, mm").asNumber(positive);
            b.thicknessMm = t.number("thickness_mm", b.thicknessMm, positive);
            b.property = t.string("property");
            s.baffles.push_back(b);
        }
    }
    if (const auto v = m.get("parts")) {
        std::map<std::string, FileLoc> seen;
        for (const TomlValue& entry : v->asArray()) {
            const TomlTable t = entry.asTable();
            MechanicsSpec::Part part;
            part.enabled = t.boolean("enabled", true);
            const TomlValue name = t.require("name", "the part's object name");
            part.name = name.asString();
            if (part.name.empty() || part.name.find_first_of(". \t|,()*?") != std::string::npos)
                name.fail(name.path() + " '" + part.name +
                          "' must be a non-empty name without dots, spaces, wildcards or "
                          "criteria punctuation");
            if (auto [it, inserted] = seen.emplace(part.name, name.loc()); !inserted)
                name.fail("part name '" + part.name + "' is already used at " + it->second.str());
            const TomlValue profile = t.require(
                "profile_mm", "the part's outline in the (r, z) half plane, [[r, z], ...]");
            for (const TomlValue& point : profile.asArray()) {
                const std::vector<TomlValue> rz = point.asArray();
                if (rz.size() != 2) point.failExpected("a point [r, z]");
                const double r = rz[0].asNumber(NumberRange::atLeast(0.0));
                part.profileMm.push_back({r, rz[1].asNumber()});
            }
            if (part.profileMm.size() < 3)
                profile.fail(profile.path() + " needs at least 3 points, got " +
                             std::to_string(part.profileMm.size()));
            if (part.profileMm.size() > kMaxPartProfilePoints)
                profile.fail(profile.path() + " has " + std::to_string(part.profileMm.size()) +
                             " points; at most " + std::to_string(kMaxPartProfilePoints));
            // Either orientation; revolved counter-clockwise.
            if (profileArea(part.profileMm) < 0.0)
                std::reverse(part.profileMm.begin(), part.profileMm.end());
            if (const std::string defect = profileDefect(part.profileMm); !defect.empty())
                profile.fail(profile.path() + " is not a simple closed outline: " + defect);
            part.property = t.string("property");
            s.parts.push_back(std::move(part));
        }
    }
    {
        const auto v = m.get("vanes");
        if (v) {
            bool enabled = true;
            if (v->isBool()) {
                if (v->asBool())
                    v->fail(v->path() +
                            " needs count, depth_mm, from_z_mm and to_z_mm: write a "
                            "table");
                enabled = false;
            } else {
                const auto t = partTable(m, "vanes", enabled);
                MechanicsSpec::Vanes& vn = s.vanes;
                vn.count = static_cast<int>(t->require("count", "number of vanes")
                                                .asInteger(NumberRange::between(1, 10000)));
                vn.depthMm =
                    t->require("depth_mm", "radial depth from the bore, mm").asNumber(positive);
                vn.thicknessMm = t->number("thickness_mm", vn.thicknessMm, positive);
                vn.fromZMm =
                    t->require("from_z_mm", "first vane's mid-plane, global z in mm").asNumber();
                const TomlValue to = t->require("to_z_mm", "last vane's mid-plane, global z in mm");
                vn.toZMm = to.asNumber();
                if (vn.toZMm < vn.fromZMm)
                    to.fail(to.path() + " must not be less than from_z_mm (" + fmt(vn.fromZMm) +
                            ")");
                vn.property = t->string("property");
            }
            s.vanes.enabled = enabled;
        }
    }
    return s;
}

std::optional<MechanicsSpec> readMechanics(const TomlDocument& doc) {
    const auto v = doc.root().get("mechanics");
    if (!v) return std::nullopt;
    return readMechanicsTable(v->asTable());
}

}  // namespace veil
