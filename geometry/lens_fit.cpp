#include "geometry/lens_fit.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <sstream>

#include "geometry/lens_solid.h"
#include "lensdata/errors.h"

namespace veil {

namespace {

// The edge a fitted element keeps at least: min(kEdgeMm, centre thickness * kEdgeOfCentre).
constexpr double kEdgeMm = 0.5;
constexpr double kEdgeOfCentre = 0.25;
// The air gap fitted neighbours keep at least: min(kGapMm, axial gap * kGapOfAxial).
constexpr double kGapMm = 0.1;
constexpr double kGapOfAxial = 0.5;
// As lens_solid.cpp: a gap may close to zero (touching) but not below this.
constexpr double kOverlapToleranceMm = 1e-9;
constexpr int kBisections = 48;
// Sweeps over the neighbour pairs (shrinking one pair can move a flat toward the next).
constexpr int kPairSweeps = 4;
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string mm(double v) { return messageNumber(v); }

std::string fixed3(double v) {
    std::ostringstream os;
    os.setf(std::ios::fixed);
    os.precision(3);
    os << v;
    return os.str();
}

// The largest x in [lo, hi] with ok(x), given ok(lo) (bisection: the set of good x is taken
// to be an interval from lo).
double largest(const std::function<bool(double)>& ok, double lo, double hi) {
    if (ok(hi)) return hi;
    for (int i = 0; i < kBisections; ++i) {
        const double mid = 0.5 * (lo + hi);
        (ok(mid) ? lo : hi) = mid;
    }
    return lo;
}

std::string problemText(const LensSolidProblem& m, const std::vector<LensSolid>& solids) {
    if (m.kind == LensSolidProblem::Kind::AirGap)
        return "overlapped " + solids[m.second].name + " (air gap " + mm(m.valueMm) +
               " mm at r = " + mm(m.atRadiusMm) + " mm)";
    return std::string(m.atEdge ? "edge thickness " : "thickness ") + mm(m.valueMm) +
           " mm at r = " + mm(m.atRadiusMm) + " mm";
}

class Fitter {
  public:
    Fitter(const Prescription& p, const std::function<std::vector<double>()>& bundleOf)
        : input_(p), p_(p) {
        p_.assignNames();
        file_ = measuredLensSolids(p_, fileMeasures_);
        if (!anyProblem(fileMeasures_)) return;
        const std::vector<double> bundle = bundleOf();
        const size_t n = p_.surfaces.size();
        clear_.assign(n, 0.0);
        mech_.assign(n, 0.0);
        need_.assign(n, 0.0);
        for (size_t i = 0; i < n; ++i) {
            const Surface& s = p_.surfaces[i];
            clear_[i] = s.clearSemiDiameterMm;
            mech_[i] = s.mechSemiDiameterMm;
            const double b = i < bundle.size() ? bundle[i] : 0.0;
            need_[i] = b > 0.0 && std::isfinite(b) ? std::min(b, clear_[i]) : clear_[i];
        }
        scale_.assign(file_.size(), 2.0);
        for (const LensSolid& s : file_) {
            centre_.push_back(s.direction * (s.back.vertexZMm - s.front.vertexZMm));
        }
    }

    LensFit fit() {
        LensFit out;
        out.prescription = input_;
        if (!anyProblem(fileMeasures_)) return out;
        std::vector<std::vector<std::string>> reasons(file_.size());
        for (const LensSolidProblem& m : fileMeasures_) {
            if (!bad(m)) continue;
            reasons[m.first].push_back(problemText(m, file_));
            if (m.kind == LensSolidProblem::Kind::AirGap)
                reasons[m.second].push_back("overlapped " + file_[m.first].name + " (air gap " +
                                            mm(m.valueMm) + " mm at r = " + mm(m.atRadiusMm) +
                                            " mm)");
        }
        fitThicknesses();
        for (int sweep = 0; sweep < kPairSweeps; ++sweep)
            if (!fitGaps()) break;
        Prescription fitted = at(scale_);
        lensSolids(fitted);  // anything left throws the usual message
        std::vector<LensSolidProblem> finalMeasures;
        const std::vector<LensSolid> solids = measuredLensSolids(fitted, finalMeasures);
        for (size_t k = 0; k < file_.size(); ++k) {
            LensSizeChange c;
            c.element = file_[k].name;
            c.origin = p_.surfaces[file_[k].front.surface].origin;
            bool changed = solids[k].edgeRadiusMm != file_[k].edgeRadiusMm;
            for (int i : {file_[k].front.surface, file_[k].back.surface}) {
                const double before = input_.surfaces[i].clearSemiDiameterMm;
                const double after = fitted.surfaces[i].clearSemiDiameterMm;
                changed |= before != after;
                c.faces.push_back({p_.surfaces[i].name, before, after});
            }
            if (!changed) continue;
            c.radiusBeforeMm = 0.0;
            for (int i : {file_[k].front.surface, file_[k].back.surface}) {
                const Surface& s = input_.surfaces[i];
                c.radiusBeforeMm =
                    std::max(c.radiusBeforeMm, s.mechSemiDiameterMm > 0.0 ? s.mechSemiDiameterMm
                                                                          : s.clearSemiDiameterMm);
            }
            c.radiusBeforeMm = std::max(c.radiusBeforeMm, file_[k].edgeRadiusMm);
            c.radiusAfterMm = solids[k].edgeRadiusMm;
            if (reasons[k].empty()) {
                c.reason = "its cemented neighbour shrank";
            } else {
                c.reason = reasons[k].front();
                for (size_t j = 1; j < reasons[k].size(); ++j) c.reason += "; " + reasons[k][j];
            }
            out.changes.push_back(std::move(c));
        }
        for (size_t i = 0; i < fitted.surfaces.size(); ++i) {
            out.prescription.surfaces[i].clearSemiDiameterMm =
                fitted.surfaces[i].clearSemiDiameterMm;
            out.prescription.surfaces[i].mechSemiDiameterMm = fitted.surfaces[i].mechSemiDiameterMm;
        }
        return out;
    }

  private:
    static bool bad(const LensSolidProblem& m) {
        return m.kind == LensSolidProblem::Kind::Thickness ? !(m.valueMm > 0.0)
                                                           : !(m.valueMm >= -kOverlapToleranceMm);
    }
    static bool anyProblem(const std::vector<LensSolidProblem>& ms) {
        return std::any_of(ms.begin(), ms.end(), bad);
    }

    // The prescription at these scales (per solid: 2 = the file's sizes, 1 = the outer radius
    // down to the largest clear semi-diameter, 0 = the bundle's sizes), each face capped at
    // caps[surface] if given.
    Prescription at(const std::vector<double>& scale,
                    const std::vector<double>* caps = nullptr) const {
        Prescription q = p_;
        std::vector<double> s(p_.surfaces.size(), kInf);
        for (size_t k = 0; k < file_.size(); ++k)
            for (int i : {file_[k].front.surface, file_[k].back.surface})
                s[i] = std::min(s[i], scale[k]);
        for (size_t i = 0; i < s.size(); ++i) {
            if (s[i] == kInf) continue;
            const double c = clear_[i], m = mech_[i], n = need_[i];
            double clear = c, mech = m;
            if (s[i] >= 1.0) {
                if (m > c) mech = c + (s[i] - 1.0) * (m - c);
            } else {
                clear = n + s[i] * (c - n);
                mech = 0.0;
            }
            if (caps && clear > (*caps)[i]) {
                clear = (*caps)[i];
                mech = 0.0;
            }
            q.surfaces[i].clearSemiDiameterMm = clear;
            q.surfaces[i].mechSemiDiameterMm = mech;
        }
        return q;
    }

    std::vector<LensSolidProblem> measure(const std::vector<double>& scale,
                                          const std::vector<double>* caps = nullptr) const {
        std::vector<LensSolidProblem> ms;
        measuredLensSolids(at(scale, caps), ms);
        return ms;
    }
    static double valueOf(const std::vector<LensSolidProblem>& ms, LensSolidProblem::Kind kind,
                          int first) {
        for (const LensSolidProblem& m : ms)
            if (m.kind == kind && m.first == first) return m.valueMm;
        return kInf;
    }
    double thickness(const std::vector<double>& scale, int k,
                     const std::vector<double>* caps = nullptr) const {
        return valueOf(measure(scale, caps), LensSolidProblem::Kind::Thickness, k);
    }

    void fitThicknesses() {
        for (size_t k = 0; k < file_.size(); ++k) {
            const int ki = static_cast<int>(k);
            if (thickness(scale_, ki) > 0.0) continue;
            const double margin = std::min(kEdgeMm, kEdgeOfCentre * centre_[k]);
            std::vector<double> trial = scale_;
            bool found = false;
            // The first point of the path with the margin; else, when even the bundle's sizes
            // leave less, those sizes themselves (the thickest edge the light allows).
            for (double least : {margin, 0.0}) {
                auto ok = [&](double s) {
                    trial[k] = s;
                    const double t = thickness(trial, ki);
                    return least > 0.0 ? t >= least : t > 0.0;
                };
                if (!ok(0.0)) continue;
                scale_[k] = least > 0.0 ? largest(ok, 0.0, scale_[k]) : 0.0;
                found = true;
                break;
            }
            if (!found) throw crossing(ki, ki);
        }
    }

    // One sweep over the neighbours; returns whether anything changed.
    bool fitGaps() {
        bool changed = false;
        for (size_t k = 0; k + 1 < file_.size(); ++k) {
            const int a = static_cast<int>(k), b = a + 1;
            const std::vector<LensSolidProblem> now = measure(scale_);
            const double gap = valueOf(now, LensSolidProblem::Kind::AirGap, a);
            if (gap >= -kOverlapToleranceMm) continue;
            const double axial =
                file_[b].direction * (file_[b].front.vertexZMm - file_[a].back.vertexZMm);
            const double margin = std::min(kGapMm, kGapOfAxial * axial);
            bool found = false;
            for (double least : {margin, 0.0}) {
                double bestSum = -kInf;
                std::vector<double> best;
                // Shrink the front element, the back one, or both together.
                for (int which = 0; which < 3; ++which) {
                    std::vector<double> trial = scale_;
                    auto set = [&](double u) {
                        if (which != 1) trial[a] = u * scale_[a];
                        if (which != 0) trial[b] = u * scale_[b];
                    };
                    auto ok = [&](double u) {
                        set(u);
                        const std::vector<LensSolidProblem> ms = measure(trial);
                        const double g = valueOf(ms, LensSolidProblem::Kind::AirGap, a);
                        return (least > 0.0 ? g >= least : g >= -kOverlapToleranceMm) &&
                               valueOf(ms, LensSolidProblem::Kind::Thickness, a) > 0.0 &&
                               valueOf(ms, LensSolidProblem::Kind::Thickness, b) > 0.0;
                    };
                    if (!ok(0.0)) continue;
                    // Without the margin: the bundle's sizes for the element(s) shrunk.
                    set(least > 0.0 ? largest(ok, 0.0, 1.0) : 0.0);
                    std::vector<LensSolidProblem> ignored;
                    const std::vector<LensSolid> solids = measuredLensSolids(at(trial), ignored);
                    const double sum = solids[a].edgeRadiusMm + solids[b].edgeRadiusMm;
                    if (sum > bestSum) {
                        bestSum = sum;
                        best = trial;
                    }
                }
                if (best.empty()) continue;
                scale_ = best;
                found = changed = true;
                break;
            }
            if (!found) throw crossing(a, b);
        }
        return changed;
    }

    // The error for a lens whose light needs glass that cannot be there: elements a and b
    // (a == b: the element's own faces cross).
    ModelError crossing(int a, int b) const {
        const LensSolid& ea = file_[a];
        const LensSolid& eb = file_[b];
        const int fa = a == b ? ea.front.surface : ea.back.surface;
        const int fb = a == b ? ea.back.surface : eb.front.surface;
        const std::vector<double> zero(file_.size(), 0.0);
        const std::vector<LensSolidProblem> atNeed = measure(zero);
        const LensSolidProblem* worst = nullptr;
        for (const LensSolidProblem& m : atNeed)
            if (m.first == a && m.second == b &&
                m.kind ==
                    (a == b ? LensSolidProblem::Kind::Thickness : LensSolidProblem::Kind::AirGap))
                worst = &m;
        // The largest semi-diameter that fits: every face of a and b capped at rho.
        std::vector<double> caps(p_.surfaces.size(), kInf);
        auto ok = [&](double rho) {
            for (int i : {ea.front.surface, ea.back.surface, eb.front.surface, eb.back.surface})
                caps[i] = rho;
            std::vector<LensSolidProblem> ms;
            try {
                ms = measure(zero, &caps);
            } catch (const ModelError&) {
                return false;
            }
            if (valueOf(ms, LensSolidProblem::Kind::Thickness, a) <= 0.0) return false;
            if (valueOf(ms, LensSolidProblem::Kind::Thickness, b) <= 0.0) return false;
            return a == b || valueOf(ms, LensSolidProblem::Kind::AirGap, a) >= -kOverlapToleranceMm;
        };
        const double reach = std::max(need_[fa], need_[fb]);
        const double least = 1e-9 * reach;
        const double fits = ok(least) ? largest(ok, least, reach) : 0.0;
        std::string text = a == b ? "its faces " + p_.surfaces[fa].name + " and " +
                                        p_.surfaces[fb].name + " cross inside the light"
                                  : p_.surfaces[fa].name + " and " + p_.surfaces[fb].name + " (" +
                                        ea.name + " and " + eb.name + ") cross inside the light";
        text += ": the traced rays reach r = " + fixed3(need_[fa]) + " mm on " +
                p_.surfaces[fa].name + " and r = " + fixed3(need_[fb]) + " mm on " +
                p_.surfaces[fb].name;
        if (worst)
            text += ", where " + std::string(a == b ? "the thickness is " : "the air gap is ") +
                    mm(worst->valueMm) + " mm at r = " + mm(worst->atRadiusMm) + " mm";
        text += "; the largest semi-diameter that fits is " + fixed3(fits) + " mm. Check the " +
                (a == b ? "thickness of " + ea.name : "air gap after " + p_.surfaces[fa].name) +
                " and the field and aperture of the file";
        return ModelError(p_.surfaces[fa].name, text);
    }

    const Prescription& input_;
    Prescription p_;  // named
    std::vector<LensSolid> file_;
    std::vector<LensSolidProblem> fileMeasures_;
    std::vector<double> clear_, mech_, need_;  // per surface
    std::vector<double> scale_, centre_;       // per solid
};

}  // namespace

LensFit fitLensSizes(const Prescription& p,
                     const std::function<std::vector<double>()>& bundleSemiDiameterMm) {
    return Fitter(p, bundleSemiDiameterMm).fit();
}

std::string describe(const LensSizeChange& c) {
    std::string s = c.element + ": ";
    for (const LensSizeChange::Face& f : c.faces) {
        if (f.clearBeforeMm == f.clearAfterMm) continue;
        s += f.name + " clear semi-diameter " + fixed3(f.clearBeforeMm) + " -> " +
             fixed3(f.clearAfterMm) + " mm, ";
    }
    s += "outer radius " + fixed3(c.radiusBeforeMm) + " -> " + fixed3(c.radiusAfterMm) +
         " mm; the file's sizes gave " + c.reason;
    return s;
}

}  // namespace veil
