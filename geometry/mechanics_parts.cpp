// The mount generator's parts: plates (stop, field stop, baffles, vanes), spacers and
// retainers, and the barrel with its seats (geometry/mechanics_builder.h).

#include <algorithm>
#include <cmath>
#include <functional>
#include <iomanip>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>

#include "geometry/mechanics_builder.h"
#include "geometry/revolve.h"
#include "geometry/surface_shape.h"
#include "lensdata/errors.h"
#include "lensdata/prescription.h"

namespace veil::mechanics_detail {

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
    for (size_t i = 0; i < plates_.size(); ++i) {
        Plate& p = plates_[i];
        if (p.kind == PlateKind::Stop) placeStop(p);
        if (p.dropped) {
            std::vector<int>& in = regions_[p.region].plates;
            in.erase(std::remove(in.begin(), in.end(), static_cast<int>(i)), in.end());
        }
    }
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
    // Whether half-thickness t on one side keeps clear of `body`.
    auto sideFits = [&](int body, bool upperSide, double t) {
        Plate q = p;
        (upperSide ? q.tHi : q.tLo) = t;
        if (upperSide)
            return minOver([&](double r) { return bodyLower(body, r) - gap - plateUpper(q, r); },
                           r0, r1) >= 0.0;
        return minOver([&](double r) { return plateLower(q, r) - gap - bodyUpper(body, r); }, r0,
                       r1) >= 0.0;
    };
    // Largest half-thickness on one side that keeps clear of `body` (-1: none).
    auto maxSide = [&](int body, bool upperSide) {
        if (body < 0) return std::min(T, tCap);
        auto fits = [&](double t) { return sideFits(body, upperSide, t); };
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
    std::optional<double> movedFrom;  // the stop plane, when a face pushes the plate off it
    if (p.pushedAgainst < 0 && !explicitThickness) {
        // A free stop whose plate, however thin, would cut a face that reaches the stop plane
        // within the plate's radii on one side (a meniscus bulging through it): the plate goes
        // against that face instead, as on a stop on the face, moved as little as keeps the
        // contact gap, and says so.
        const bool lowBlocked = region.below >= 0 && !sideFits(region.below, false, e);
        const bool highBlocked = region.above >= 0 && !sideFits(region.above, true, e);
        if (lowBlocked && highBlocked) {
            dropStop(p, "no plate fits between " + bodies_[region.below].name + " and " +
                            bodies_[region.above].name + " at the stop plane");
            return;
        }
        if (lowBlocked || highBlocked) {
            p.pushedAgainst = lowBlocked ? region.below : region.above;
            p.pushSide = lowBlocked ? 1 : -1;
            movedFrom = p.z0;
        }
    }
    if (p.pushedAgainst >= 0) {
        // Against the glass (or mirror) on one side: half the thickness there, the plate
        // moved until it keeps the contact gap; the other half on the free side.
        const int body = p.pushedAgainst;
        // The free side: the body on the other side must leave room for the plate's edge.
        const int other = p.pushSide < 0 ? region.below : region.above;
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
        if (other >= 0 && !sideFits(other, p.pushSide > 0, e)) {
            dropStop(p, "no plate fits between " + bodies_[body].name + " and " +
                            bodies_[other].name + ", where the stop lies");
            return;
        }
        if (movedFrom)
            note("stop: " + bodies_[p.pushedAgainst].name +
                 " reaches into the stop plate's place (between r = " + fmt(p.ri) + " and " +
                 fmt(p.ro) + " mm of the stop plane): the plate is moved " +
                 fmt(std::abs(p.z0 - *movedFrom), 4) +
                 " mm along the axis, against it with the contact gap, to clear it");
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

void MechanicsBuilder::dropStop(Plate& p, const std::string& why) {
    p.dropped = true;
    const int s = rx_.stopIndex();
    note(std::string(kMechanicsWarning) + "stop: " + why +
         ": no stop plate is built, so the light is limited by the lens's own "
         "apertures there (the stop's clear semi-diameter " +
         fmt(rx_.surfaces[s].clearSemiDiameterMm) + " mm limits the sequential rays alone)");
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
        if (p.dropped) continue;
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
    // A step to the bore the barrel already has is none. Where two steps cross (a seat
    // between two bodies with no axial room for it: a concave face reaching past its
    // neighbour's rim), the seat goes: one step from the bore before to the bore after, at
    // the later body's place when the bore widens (the ring lies beyond the earlier body's
    // radius) and at the earlier body's otherwise. What is still out of order is kept in
    // order (a clash shows up in the clearance checks); then the steps inside the tube.
    {
        std::vector<Step> kept;
        std::vector<double> before;  // the bore before each kept step
        double current = first;
        for (const Step& st : steps) {
            if (st.boreAfter == current) continue;
            if (!kept.empty() && st.z < kept.back().z) {
                const double was = before.back();
                if (st.boreAfter > was) kept.back().z = st.z;
                kept.back().boreAfter = st.boreAfter;
                current = st.boreAfter;
                if (kept.back().boreAfter == was) {
                    kept.pop_back();
                    before.pop_back();
                }
                continue;
            }
            kept.push_back(st);
            before.push_back(current);
            current = st.boreAfter;
        }
        steps = std::move(kept);
    }
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

}  // namespace veil::mechanics_detail
