// The mount generator's builder: the lens as bodies, light paths and regions, the extents
// parts are fitted against, the checks against glass, and build(). Mechanics from a prescription: barrel, seats, retainers, spacers, stop, field stop, baffles,
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

#include "geometry/mechanics_builder.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>

#include "geometry/lens_solid.h"
#include "geometry/mesh_check.h"
#include "geometry/revolve.h"
#include "geometry/surface_frames.h"
#include "geometry/surface_shape.h"

namespace veil::mechanics_detail {

// Mechanics Builder: Lens Geometry

void MechanicsBuilder::readSurfaces() {
    const int n = static_cast<int>(rx_.surfaces.size());
    double z = 0.0;
    double dir = 1.0;
    for (int i = 0; i < n; ++i) {
        const Surface& s = rx_.surfaces[i];
        SurfaceInfo info;
        info.name = s.name;
        if (info.name.empty()) {  // appended: GCC 12 warns falsely on "S" + ... here
            info.name = "S";
            info.name += std::to_string(i);
        }
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
    // One body per piece of glass: a repeated pass (out of a cemented Mangin) is not another.
    const std::vector<Element> elements = distinctElements(rx_);
    // A lens face is exact to its clear semi-diameter and flat beyond (pieceRange), so only
    // that must lie within the surface's rim; a mirror sheet follows its sag to mech_sd.
    auto requireSize = [&](int s, bool sheet) {
        const SurfaceInfo& si = surfaces_[s];
        if (!(si.mechMm > 0.0))
            throw ModelError(si.name,
                             "mechanics need its size: give sd or mech_sd (clear or mechanical "
                             "semi-diameter)");
        const double rim = maxRadius(si.shape);
        const double exactTo = sheet ? si.mechMm : si.clearMm;
        if (exactTo > rim)
            throw ModelError(si.name, "semi-diameter " + fmt(exactTo) +
                                          " mm lies beyond the rim of the surface (" + fmt(rim) +
                                          " mm)");
    };
    // Elements; consecutive ones sharing a surface are cemented into one body.
    for (size_t e = 0; e < elements.size(); ++e) {
        const Element& el = elements[e];
        requireSize(el.frontSurface, false);
        requireSize(el.backSurface, false);
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
        requireSize(i, true);
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

// Mechanics Builder: Parts and Checks

void MechanicsBuilder::addPart(const std::string& name, const std::string& property,
                               std::vector<Vec2> profile, const std::string& edgeName,
                               const std::string& edgeProperty) {
    MechanicalPart part;
    part.name = name;
    part.property = property;
    part.segments = segments_;
    RevolvedMesh rm;
    try {
        rm = revolveProfile(profile, segments_);
    } catch (const std::invalid_argument& e) {
        // A profile the sizes made degenerate (a stop edge_mm of 1e-320): the part is named,
        // not the function that found it.
        std::string why = e.what();
        const std::string internal = "revolveProfile: ";
        if (why.rfind(internal, 0) == 0) why.erase(0, internal.size());
        throw ModelError(name, "its cross-section cannot be built from the sizes given (" + why +
                                   "); check the mechanics' lengths for this part");
    }
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
    // A barrel's bores and a plate's outer rim follow the glass and mirrors it holds: with
    // none, there is nothing to size them by.
    if (bodies_.empty())
        throw ModelError("mechanics",
                         "the lens has no lens element or mirror for the mount generator to "
                         "hold, only its stop" +
                             std::string(plates_.size() > 1 ? " and plates" : "") +
                             ": leave [mechanics] out of this scene, or bring an aperture plate "
                             "in as a [[mesh]] part");
    computeBores();
    placePlates();
    // Plates are placed where the user (or the stop surface) says: check them against the
    // glass first, so a misplaced one is named rather than the spacer next to it.
    for (const Plate& p : plates_) {
        if (p.dropped) continue;
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

}  // namespace veil::mechanics_detail
