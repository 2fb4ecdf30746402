#include "tracer/render/part_light.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "tracer/render/backward.h"
#include "tracer/runtime/ordered_blocks.h"
#include "tracer/runtime/rng.h"
#include "tracer/surfaces/media.h"

namespace veil {

namespace {

constexpr uint64_t kPartPilotSeed = 0x706172746c696768ULL;  // the pilot's own stream key
constexpr double kTwoPi = 2.0 * std::numbers::pi;

// The entry of a table of running sums (non-empty, ascending, its last the total) that a
// uniform u in [0, 1) falls in: the first whose sum exceeds u times the total, the last for u
// at the very top.
size_t drawFromRunningSums(const std::vector<double>& runningSums, double u) {
    const auto it =
        std::upper_bound(runningSums.begin(), runningSums.end(), u * runningSums.back());
    return std::min(static_cast<size_t>(it - runningSums.begin()), runningSums.size() - 1);
}

// The direction guide's map at a point x (PartLight::kGuideU): the pole p toward the detector's
// centre, e1 perpendicular to it in the plane of p and the detector's axis, away from the axis
// (so the map turns with the point about a lens's axis), e2 = p x e1. A direction at angle
// theta from p and azimuth phi from e1 has u = sin(theta / 2) and v = phi / 2 pi; its solid
// angle is 8 pi u du dv, so a density q per unit of (u, v) is q / (8 pi u) per steradian.
struct GuideFrame {
    Vec3 p{0.0, 0.0, 1.0}, e1{1.0, 0.0, 0.0}, e2{0.0, 1.0, 0.0};
    GuideFrame(const Vec3& x, const Vec3& centre, const Vec3& axis) {
        const Vec3 toCentre = centre - x;
        const double length = glm::length(toCentre);
        p = length > 0.0 ? toCentre / length : axis;
        const Vec3 offset = (x - centre) - glm::dot(x - centre, axis) * axis;
        Vec3 e = offset - glm::dot(offset, p) * p;
        if (!(glm::dot(e, e) > 1e-18 * std::max(1.0, length * length)))
            e = glm::cross(p, std::abs(p.x) < 0.9 ? Vec3(1.0, 0.0, 0.0) : Vec3(0.0, 1.0, 0.0));
        e1 = glm::normalize(e);
        e2 = glm::cross(p, e1);
    }
    int cell(const Vec3& w, double& u) const {
        const double c = std::clamp(glm::dot(w, p), -1.0, 1.0);
        u = std::sqrt(std::max(0.0, 0.5 * (1.0 - c)));
        double phi = std::atan2(glm::dot(w, e2), glm::dot(w, e1));
        if (phi < 0.0) phi += kTwoPi;
        const int i = std::min(PartLight::kGuideU - 1, static_cast<int>(u * PartLight::kGuideU));
        const int j =
            std::min(PartLight::kGuideV - 1, static_cast<int>(phi / kTwoPi * PartLight::kGuideV));
        return j * PartLight::kGuideU + i;
    }
    Vec3 at(double u, double v) const {
        const double cosT = 1.0 - 2.0 * u * u;
        const double sinT = 2.0 * u * std::sqrt(std::max(0.0, 1.0 - u * u));
        const double phi = kTwoPi * v;
        return cosT * p + sinT * (std::cos(phi) * e1 + std::sin(phi) * e2);
    }
    // The density per steradian of `w` for cell probabilities `q` (uniform within a cell).
    double pdf(const Vec3& w, const std::vector<double>& q) const {
        double u = 0.0;
        const int c = cell(w, u);
        return q[static_cast<size_t>(c)] * PartLight::kGuideCount /
               (8.0 * std::numbers::pi * std::max(u, 1e-12));
    }
};

}  // namespace

PartShape::PartShape(const Scene& scene, int object) : object_(&scene.object(object)) {
    const SceneObject& o = *object_;
    if (const MeshRef* ref = std::get_if<MeshRef>(&o.geometry)) {
        const TriangleMesh& m = scene.meshes()[static_cast<size_t>(ref->mesh)];
        const uint32_t first = ref->firstTriangle;
        const uint32_t last = ref->triangleCount == 0 ? static_cast<uint32_t>(m.triangles.size())
                                                      : first + ref->triangleCount;
        double sum = 0.0;
        for (uint32_t t = first; t < last && t < m.triangles.size(); ++t) {
            const auto& tri = m.triangles[t];
            const double a = 0.5 * glm::length(glm::cross(m.vertices[tri[1]] - m.vertices[tri[0]],
                                                          m.vertices[tri[2]] - m.vertices[tri[0]]));
            if (!(a > 0.0)) continue;
            sum += a;
            triangles_.push_back(t);
            areas_.push_back(a);
        }
        if (!(sum > 0.0)) return;
        mesh_ = &m;
        kind_ = Kind::Mesh;
        area_ = mapArea_ = sum;
        return;
    }
    const FaceGeometry& face = std::get<FaceGeometry>(o.geometry);
    if (const CylinderPatch* c = std::get_if<CylinderPatch>(&face)) {
        if (!(c->radiusMm > 0.0) || !(c->zMaxMm > c->zMinMm)) return;
        kind_ = Kind::Cylinder;
        radius_ = c->radiusMm;
        a_ = c->zMinMm;
        b_ = c->zMaxMm;
        area_ = mapArea_ = kTwoPi * radius_ * (b_ - a_);
        return;
    }
    const SurfacePatch& patch = std::get<SurfacePatch>(face);
    if (const auto* ap = std::get_if<CircularAperture>(&patch.aperture)) {
        if (!(ap->radiusMm > 0.0)) return;
        kind_ = Kind::Disc;
        a_ = 0.0;
        b_ = ap->radiusMm;
    } else if (const auto* an = std::get_if<AnnularAperture>(&patch.aperture)) {
        if (!(an->outerRadiusMm > an->innerRadiusMm) || an->innerRadiusMm < 0.0) return;
        kind_ = Kind::Annulus;
        a_ = an->innerRadiusMm;
        b_ = an->outerRadiusMm;
    } else {
        const auto& r = std::get<RectangularAperture>(patch.aperture);
        if (!(r.halfWidthMm > 0.0) || !(r.halfHeightMm > 0.0)) return;
        kind_ = Kind::Rectangle;
        a_ = r.halfWidthMm;
        b_ = r.halfHeightMm;
    }
    mapArea_ = kind_ == Kind::Rectangle ? 4.0 * a_ * b_ : std::numbers::pi * (b_ * b_ - a_ * a_);
    // The surface's area: the projected area over the mean |n_z| of a 16 x 16 grid of the map.
    constexpr int kGrid = 16;
    double inverse = 0.0;
    int n = 0;
    for (int i = 0; i < kGrid; ++i)
        for (int j = 0; j < kGrid; ++j) {
            const auto p = at((i + 0.5) / kGrid, (j + 0.5) / kGrid);
            if (!p) continue;
            inverse += 1.0 / (p->density * mapArea_);
            ++n;
        }
    area_ = n > 0 ? mapArea_ * inverse / n : 0.0;
    if (!(area_ > 0.0)) kind_ = Kind::None;
}

std::optional<PartPoint> PartShape::at(double u, double v) const {
    PartPoint out;
    switch (kind_) {
        case Kind::None:
            return std::nullopt;
        case Kind::Mesh: {
            // Triangles by count, not by area: a finely tessellated edge band gets cells of
            // its own beside a large face's few triangles.
            const size_t n = triangles_.size();
            const double x = u * static_cast<double>(n);
            const size_t k = std::min(n - 1, static_cast<size_t>(x));
            const double share = std::clamp(x - static_cast<double>(k), 0.0, 1.0);
            const uint32_t t = triangles_[k];
            const auto& tri = mesh_->triangles[t];
            const double s = std::sqrt(share);
            out.point = (1.0 - s) * mesh_->vertices[tri[0]] +
                        s * (1.0 - v) * mesh_->vertices[tri[1]] + s * v * mesh_->vertices[tri[2]];
            out.normal = mesh_->triangleNormal(t);
            out.primitive = static_cast<int>(t);
            out.density = 1.0 / (static_cast<double>(n) * areas_[k]);
            return out;
        }
        case Kind::Cylinder: {
            const FaceGeometry& face = std::get<FaceGeometry>(object_->geometry);
            const CylinderPatch& c = std::get<CylinderPatch>(face);
            const double phi = kTwoPi * v;
            const Vec3 local(radius_ * std::cos(phi), radius_ * std::sin(phi), a_ + u * (b_ - a_));
            if (c.rims) {
                if (c.rims->lower && local.z < c.rims->lower->zAt(local.x, local.y))
                    return std::nullopt;
                if (c.rims->upper && local.z > c.rims->upper->zAt(local.x, local.y))
                    return std::nullopt;
            }
            out.point = object_->frame.toGlobalPoint(local);
            out.normal = glm::normalize(object_->frame.toGlobalDirection(faceNormal(face, local)));
            out.density = 1.0 / area_;
            return out;
        }
        default:
            break;
    }
    const FaceGeometry& face = std::get<FaceGeometry>(object_->geometry);
    const SurfacePatch& patch = std::get<SurfacePatch>(face);
    double x = 0.0, y = 0.0;
    if (kind_ == Kind::Rectangle) {
        x = (2.0 * u - 1.0) * a_;
        y = (2.0 * v - 1.0) * b_;
    } else {
        const double r = std::sqrt(a_ * a_ + u * (b_ * b_ - a_ * a_));
        x = r * std::cos(kTwoPi * v);
        y = r * std::sin(kTwoPi * v);
    }
    const Vec3 local(x, y, sagAt(patch.shape, x, y));
    const Vec3 n = glm::normalize(faceNormal(face, local));
    if (!(std::abs(n.z) > 0.0)) return std::nullopt;
    out.point = object_->frame.toGlobalPoint(local);
    out.normal = object_->frame.toGlobalDirection(n);
    out.density = std::abs(n.z) / mapArea_;
    return out;
}

double PartShape::densityAt(const Vec3& point, int primitive) const {
    switch (kind_) {
        case Kind::None:
            return 0.0;
        case Kind::Mesh: {
            const auto it = std::lower_bound(triangles_.begin(), triangles_.end(),
                                             static_cast<uint32_t>(primitive));
            if (primitive < 0 || it == triangles_.end() || *it != static_cast<uint32_t>(primitive))
                return 0.0;
            const size_t k = static_cast<size_t>(it - triangles_.begin());
            return 1.0 / (static_cast<double>(triangles_.size()) * areas_[k]);
        }
        case Kind::Cylinder:
            return 1.0 / area_;
        default:
            break;
    }
    const Vec3 local = object_->frame.toLocalPoint(point);
    if (kind_ == Kind::Rectangle) {
        if (std::abs(local.x) > a_ || std::abs(local.y) > b_) return 0.0;
    } else {
        const double r2 = local.x * local.x + local.y * local.y;
        if (r2 < a_ * a_ || r2 > b_ * b_) return 0.0;
    }
    const Vec3 n = glm::normalize(faceNormal(std::get<FaceGeometry>(object_->geometry), local));
    return std::abs(n.z) / mapArea_;
}

std::optional<Vec2> PartShape::uvOf(const Vec3& point) const {
    if (kind_ != Kind::Disc && kind_ != Kind::Annulus && kind_ != Kind::Rectangle)
        return std::nullopt;
    const Vec3 local = object_->frame.toLocalPoint(point);
    if (kind_ == Kind::Rectangle)
        return Vec2(std::clamp((local.x / a_ + 1.0) * 0.5, 0.0, 1.0),
                    std::clamp((local.y / b_ + 1.0) * 0.5, 0.0, 1.0));
    const double r2 = local.x * local.x + local.y * local.y;
    double v = std::atan2(local.y, local.x) / kTwoPi;
    if (v < 0.0) v += 1.0;
    return Vec2(std::clamp((r2 - a_ * a_) / (b_ * b_ - a_ * a_), 0.0, 1.0),
                std::clamp(v, 0.0, 1.0));
}

struct PartLight::Scratch {
    std::vector<PathEvent> chain, onward;
    std::vector<std::byte> state, scratch;
};

PartLight::PartLight(const TransportView& ts, const LensConnector& connector, int detectorObject,
                     const std::vector<bool>& followed, PartMode mode,
                     const std::vector<bool>& splatted)
    : ts_(&ts),
      lc_(&connector),
      mode_(mode),
      splatted_(splatted),
      detectorObject_(detectorObject),
      objects_(ts.scene->objects().size()) {
    const DesignedPath& dp = connector.designed();
    if (!connector.any() || dp.steps() == 0 || detectorObject < 0) return;
    {
        const Frame& frame = ts.scene->object(detectorObject).frame;
        detectorCentre_ = frame.toGlobalPoint(Vec3(0.0));
        detectorAxis_ = glm::normalize(frame.toGlobalDirection(Vec3(0.0, 0.0, 1.0)));
    }
    const bool photons = mode == PartMode::Photons;
    if (photons && std::find(splatted.begin(), splatted.end(), true) == splatted.end()) return;
    const Scene& scene = *ts.scene;
    // The faces light goes on through (photon mode: the faces its splats aim at).
    for (int k = 0; k < dp.steps(); ++k) faces_.emplace_back(scene, dp.objectOfStep(k));
    faces_.emplace_back(scene, detectorObject);
    shapes_.resize(objects_);
    std::vector<bool> tried(objects_, false);
    std::vector<Target> candidates;
    // Candidates of chain `steps` going on as designed from each step j in [from, to] whose
    // face can be drawn.
    const auto addOnward = [&](size_t s, int object, int steps, int from, int to) {
        for (int j = from; j <= to; ++j)
            if (faces_[static_cast<size_t>(j)].valid()) {
                Target t;
                t.source = s;
                t.object = object;
                t.steps = steps;
                t.onward = j;
                candidates.push_back(std::move(t));
            }
    };
    for (size_t s = 0; s < ts.sources.size(); ++s)
        for (size_t o = 0; o < objects_; ++o) {
            const uint64_t chains = connector.chains(s, static_cast<int>(o));
            // Ghost routes' chains too (not in photon mode): light a bare face reflected back
            // onto a flat.
            const std::vector<int>& ghosts =
                photons ? std::vector<int>{} : connector.ghostChains(s, static_cast<int>(o));
            if (chains == 0 && ghosts.empty()) continue;
            const int prop = ts.propertyOfObject[o];
            if (static_cast<size_t>(prop) < followed.size() && followed[static_cast<size_t>(prop)])
                continue;
            if (photons && !ts.properties[static_cast<size_t>(prop)].hasScatter()) continue;
            if (!tried[o]) {
                tried[o] = true;
                shapes_[o] = PartShape(scene, static_cast<int>(o));
            }
            if (!shapes_[o].valid()) continue;
            for (uint64_t m = chains; m != 0; m &= m - 1) {
                const int steps = std::countr_zero(m) + 1;
                if (photons) {
                    Target t;
                    t.source = s;
                    t.object = static_cast<int>(o);
                    t.steps = steps;
                    t.onward = -1;
                    candidates.push_back(std::move(t));
                    continue;
                }
                addOnward(s, static_cast<int>(o), steps, steps, dp.steps());
            }
            // A ghost route's light goes on through one face: the last it met, or the one after
            // it, by the route's direction (LensConnector::onwardFaceStep).
            for (const int key : ghosts) {
                const int onward = connector.onwardFaceStep(key);
                addOnward(s, static_cast<int>(o), key, onward, onward);
            }
        }
    if (candidates.empty()) return;

    // The pilot: the root mean square of each cell's estimate of its own light, on the part's
    // whole map (level 0), then on the box of the cells where it found light, while that box
    // is at most kZoom of the one before (up to kLevels): a flat's lit ring 1/100 of its width
    // wide (the rest under its retainer) gets cells of its own.
    struct Pilot {
        std::vector<double> rms;    // [cell]
        std::vector<double> aimed;  // [cell * kAimCount + aim cell]: points found
        int found = 0;
    };
    std::vector<std::vector<Pilot>> pilots(candidates.size());  // [candidate][level]
    // [candidate][guide cell]: the light the pilot's directions brought through each cell.
    std::vector<std::vector<double>> guideLight(candidates.size());
    std::vector<size_t> alive(candidates.size());
    for (size_t t = 0; t < candidates.size(); ++t) alive[t] = t;
    for (int level = 0; level < kLevels && !alive.empty(); ++level) {
        // This level's box per candidate still zooming.
        if (level > 0) {
            std::vector<size_t> zooming;
            for (const size_t t : alive) {
                const Pilot& before = pilots[t].back();
                const Level& box = candidates[t].levels.back();
                int lo[2] = {kCells, kCells}, hi[2] = {-1, -1};
                for (int c = 0; c < kCellCount; ++c) {
                    if (!(before.rms[static_cast<size_t>(c)] > 0.0)) continue;
                    const int i = c % kCells, j = c / kCells;
                    lo[0] = std::min(lo[0], i);
                    lo[1] = std::min(lo[1], j);
                    hi[0] = std::max(hi[0], i);
                    hi[1] = std::max(hi[1], j);
                }
                if (hi[0] < 0) continue;
                const int cells = (hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1);
                if (cells > kZoom * kCellCount) continue;
                const Vec2 size = (box.hi - box.lo) / static_cast<double>(kCells);
                candidates[t].levels.push_back({box.lo + size * Vec2(lo[0], lo[1]),
                                                box.lo + size * Vec2(hi[0] + 1, hi[1] + 1)});
                zooming.push_back(t);
            }
            alive = std::move(zooming);
            if (alive.empty()) break;
        }
        for (const size_t t : alive) {
            pilots[t].emplace_back();
            pilots[t].back().rms.assign(kCellCount, 0.0);
            pilots[t].back().aimed.assign(static_cast<size_t>(kCellCount) * kAimCount, 0.0);
        }
        // Rounds of kPilotPerCell points per cell, while a candidate found light in some round
        // but in fewer than kPilotFound points in all.
        std::vector<double> sum2(alive.size() * kCellCount, 0.0);
        std::vector<int> tries(alive.size() * kCellCount, 0), hits(alive.size() * kCellCount, 0);
        for (int round = 0; round < kPilotRounds; ++round) {
            std::vector<size_t> active;  // [index into alive * kCellCount + cell]
            for (size_t a = 0; a < alive.size(); ++a) {
                const int f = pilots[alive[a]].back().found;
                if (round == 0 || (f > 0 && f < kPilotFound))
                    for (size_t c = 0; c < kCellCount; ++c) active.push_back(a * kCellCount + c);
            }
            if (active.empty()) break;
            std::vector<std::vector<uint64_t>> places(active.size());  // photon mode's
            std::vector<std::vector<std::pair<uint64_t, int>>> aims(active.size());
            std::vector<int> legs(active.size(), 0), lobes(active.size(), 0);
            std::vector<std::vector<std::pair<int, double>>> guided(active.size());
            tbb::parallel_for(size_t{0}, active.size(), [&](size_t k) {
                const size_t i = active[k];
                const size_t t = alive[i / kCellCount];
                const int cell = static_cast<int>(i % kCellCount);
                const Level& box = candidates[t].levels.back();
                Pilot& pilot = pilots[t].back();
                Scratch scratch;
                for (int j = 0; j < kPilotPerCell; ++j) {
                    const uint64_t key = ((static_cast<uint64_t>(level) * kPilotRounds +
                                           static_cast<uint64_t>(round)) *
                                              candidates.size() +
                                          t) *
                                             kCellCount +
                                         static_cast<uint64_t>(cell);
                    CounterRng rng(kPartPilotSeed, key * kPilotPerCell + static_cast<uint64_t>(j));
                    const Vec2 uv = box.at(cell, rng.uniform(), rng.uniform());
                    LensConnector::Work work;
                    Splat sp;
                    ++tries[i];
                    if (photons) {
                        if (!samplePhoton(candidates[t], uv, kCellCount / box.area(), rng, work, sp,
                                          &places[k], &aims[k]))
                            continue;
                        legs[k] += sp.legs;
                        lobes[k] += sp.lobes;
                        sum2[i] += sp.flux * sp.flux;
                        ++hits[i];
                        pilot.aimed[static_cast<size_t>(cell) * kAimCount +
                                    static_cast<size_t>(sp.aim)] += 1.0;
                        continue;
                    }
                    // kPilotDirections from the point, each with that share of its light: the
                    // point's estimate is their sum.
                    double flux = 0.0;
                    const std::function<void(const Splat&, const Scratch&)> each =
                        [&](const Splat& one, const Scratch&) {
                            flux += one.flux;
                            guided[k].push_back({one.guide, one.flux});
                            pilot.aimed[static_cast<size_t>(cell) * kAimCount +
                                        static_cast<size_t>(one.aim)] += 1.0;
                        };
                    if (!sample(candidates[t], uv, kCellCount / box.area(), rng, nullptr, scratch,
                                work, sp, kPilotDirections, &each))
                        continue;
                    sum2[i] += flux * flux;
                    ++hits[i];
                }
            });
            for (size_t i = 0; i < hits.size(); ++i) {
                pilots[alive[i / kCellCount]].back().found += hits[i];
                hits[i] = 0;
            }
            for (const auto& p : places) productive_.insert(productive_.end(), p.begin(), p.end());
            for (const auto& a : aims) aims_.insert(aims_.end(), a.begin(), a.end());
            for (size_t k = 0; k < active.size(); ++k) {
                const size_t c = alive[active[k] / kCellCount];
                Target& t = candidates[c];
                t.legs += legs[k];
                t.lobes += lobes[k];
                if (guided[k].empty()) continue;
                if (guideLight[c].empty()) guideLight[c].assign(kGuideCount, 0.0);
                for (const auto& [cell, flux] : guided[k])
                    guideLight[c][static_cast<size_t>(cell)] += flux;
            }
        }
        std::vector<size_t> lit;
        for (size_t a = 0; a < alive.size(); ++a) {
            Pilot& pilot = pilots[alive[a]].back();
            for (size_t c = 0; c < kCellCount; ++c) {
                const size_t i = a * kCellCount + c;
                pilot.rms[c] = tries[i] > 0 ? std::sqrt(sum2[i] / tries[i]) : 0.0;
            }
            if (pilot.found > 0) {
                lit.push_back(alive[a]);
            } else if (level > 0) {  // a zoom that found no light is not kept
                pilots[alive[a]].pop_back();
                candidates[alive[a]].levels.pop_back();
            }
        }
        alive = std::move(lit);
    }

    std::sort(productive_.begin(), productive_.end());
    productive_.erase(std::unique(productive_.begin(), productive_.end()), productive_.end());
    // Each place's aim: the step most of its designed splats went on from (the smaller on a
    // tie), kept only where that face can be drawn.
    std::sort(aims_.begin(), aims_.end());
    {
        std::vector<std::pair<uint64_t, int>> best;
        for (size_t i = 0; i < aims_.size();) {
            size_t mostAt = i, count = 0;
            size_t j = i;
            while (j < aims_.size() && aims_[j].first == aims_[i].first) {
                size_t k = j;
                while (k < aims_.size() && aims_[k] == aims_[j]) ++k;
                if (k - j > count) {
                    count = k - j;
                    mostAt = j;
                }
                j = k;
            }
            if (faces_[static_cast<size_t>(aims_[mostAt].second)].invertible())
                best.push_back(aims_[mostAt]);
            i = j;
        }
        aims_ = std::move(best);
        // Per object, the step the most of its places aim at (the smaller on a tie).
        std::vector<std::vector<int>> counts(objects_);
        for (const auto& [key, step] : aims_) {
            std::vector<int>& c = counts[static_cast<size_t>(key >> 32)];
            if (c.size() <= static_cast<size_t>(step)) c.resize(static_cast<size_t>(step) + 1, 0);
            ++c[static_cast<size_t>(step)];
        }
        objectAims_.assign(objects_, -1);
        for (size_t o = 0; o < objects_; ++o)
            if (!counts[o].empty())
                objectAims_[o] = static_cast<int>(
                    std::max_element(counts[o].begin(), counts[o].end()) - counts[o].begin());
    }
    // Targets: the candidates whose pilot found light on level 0; the rest are left to the view
    // points. A target's strata: its level 0 cells (the defensive share, and in proportion to
    // their light when it has no deeper level) and its deepest level's cells (in proportion to
    // their light).
    std::vector<double> light(candidates.size(), 0.0);
    size_t cells = 0;
    for (size_t t = 0; t < candidates.size(); ++t) {
        if (pilots[t].empty() || pilots[t].front().found == 0) continue;
        cells += kCellCount;
        for (const double r : pilots[t].back().rms) light[t] += r;
    }
    double total = 0.0;
    for (const double l : light) total += l;
    targetsOf_.assign(ts.sources.size() * objects_, {});
    double sum = 0.0;
    for (size_t t = 0; t < candidates.size(); ++t) {
        if (!(light[t] > 0.0)) continue;
        Target target = std::move(candidates[t]);
        // Only level 0 and the deepest level keep strata.
        if (target.levels.size() > 2)
            target.levels.erase(target.levels.begin() + 1, target.levels.end() - 1);
        const Pilot& deepest = pilots[t].back();
        // Where its light went on: the aim cells in proportion to the points that found light
        // through them, on every level.
        std::vector<double> aimLight(kAimCount, 0.0);
        for (const Pilot& pilot : pilots[t])
            for (size_t c = 0; c < kCellCount; ++c)
                for (size_t a = 0; a < kAimCount; ++a)
                    aimLight[a] += pilot.aimed[c * kAimCount + a];
        double aimTotal = 0.0;
        for (const double a : aimLight) aimTotal += a;
        double running = 0.0;
        for (size_t a = 0; a < kAimCount; ++a) {
            const double p = (1.0 - kDefensive) * aimLight[a] / aimTotal + kDefensive / kAimCount;
            target.aim.push_back(p);
            running += p;
            target.aimCumulative.push_back(running);
        }
        if (!guideLight[t].empty()) {
            double guideTotal = 0.0;
            for (const double g : guideLight[t]) guideTotal += g;
            if (guideTotal > 0.0) {
                double upTo = 0.0;
                for (const double g : guideLight[t]) {
                    target.guide.push_back(g / guideTotal);
                    upTo += g / guideTotal;
                    target.guideCumulative.push_back(upTo);
                }
            }
        }
        const int index = static_cast<int>(targets_.size());
        const int deep = static_cast<int>(target.levels.size()) - 1;
        std::vector<double>& own = targetCumulative_.emplace_back();
        double ownSum = 0.0;
        for (int level = 0; level <= deep; ++level) {
            target.first.push_back(static_cast<int>(q_.size()));
            for (int c = 0; c < kCellCount; ++c) {
                // Within the target: kDefensive evenly over the whole map, the rest over
                // the deepest grid (which does not change when the part's light is scaled,
                // as a sweep's variant of its reflectance does); the target's own share:
                // kDefensive evenly over the targets, the rest by their light.
                double w = 0.0;
                if (level == 0) w += kDefensive / kCellCount;
                if (level == deep)
                    w += (1.0 - kDefensive) *
                         ((1.0 - kSpread) * deepest.rms[static_cast<size_t>(c)] / light[t] +
                          kSpread / kCellCount);
                const double q = w * (kDefensive * kCellCount / static_cast<double>(cells) +
                                      (1.0 - kDefensive) * light[t] / total);
                strata_.push_back({index, level, c});
                q_.push_back(q);
                sum += q;
                cumulative_.push_back(sum);
                ownSum += q;
                own.push_back(ownSum);
            }
        }
        targetShare_.push_back(ownSum);
        targetsOf_[target.source * objects_ + static_cast<size_t>(target.object)].push_back(index);
        targets_.push_back(std::move(target));
    }
    for (double& share : targetShare_) share /= sum;
}

Vec2 PartLight::Level::at(int cell, double du, double dv) const {
    const Vec2 size = (hi - lo) / static_cast<double>(kCells);
    return lo + size * Vec2(cell % kCells + du, cell / kCells + dv);
}

double PartLight::density(const Target& target, const Vec2& uv) const {
    // The mixture of the target's levels: each level's cell holding uv, its q spread over the
    // cell (per unit of the map), over the sum of all q.
    double d = 0.0;
    for (size_t level = 0; level < target.levels.size(); ++level) {
        const Level& box = target.levels[level];
        const Vec2 x = (uv - box.lo) / (box.hi - box.lo) * static_cast<double>(kCells);
        if (!(x.x >= 0.0 && x.y >= 0.0 && x.x < kCells && x.y < kCells)) continue;
        const int cell = static_cast<int>(x.y) * kCells + static_cast<int>(x.x);
        d += q_[static_cast<size_t>(target.first[level] + cell)] * kCellCount / box.area();
    }
    return d / cumulative_.back();
}

bool PartLight::owns(size_t s, int object, int steps, int designed) const {
    if (targetsOf_.empty() || mode_ != PartMode::Onward) return false;
    for (int t : targetsOf_[s * objects_ + static_cast<size_t>(object)]) {
        const Target& target = targets_[static_cast<size_t>(t)];
        if (target.steps == steps && target.onward == designed) return true;
    }
    return false;
}

bool PartLight::carries(size_t s, int object, int steps) const {
    if (targetsOf_.empty() || mode_ != PartMode::Photons) return false;
    for (int t : targetsOf_[s * objects_ + static_cast<size_t>(object)])
        if (targets_[static_cast<size_t>(t)].steps == steps) return true;
    return false;
}

const PartLight::Stratum& PartLight::stratumOf(double u) const {
    return strata_[drawFromRunningSums(cumulative_, u)];
}

const PartLight::Stratum& PartLight::stratumOf(size_t t, double u) const {
    return strata_[static_cast<size_t>(targets_[t].first.front()) +
                   drawFromRunningSums(targetCumulative_[t], u)];
}

std::vector<uint64_t> PartLight::split(uint64_t samples, bool byLight) const {
    std::vector<uint64_t> upTo;
    uint64_t all = 0;
    for (const double share : targetShare_) {
        const double n =
            byLight ? share * static_cast<double>(samples)
                    : static_cast<double>(samples) / static_cast<double>(targetShare_.size());
        all += std::max<uint64_t>(1, static_cast<uint64_t>(std::llround(n)));
        upTo.push_back(all);
    }
    return upTo;
}

std::optional<PartLight::Start> PartLight::start(uint64_t i, uint64_t seed,
                                                 LensConnector::Work& work,
                                                 std::vector<PathEvent>* chain) const {
    if (targets_.empty() || mode_ != PartMode::Photons) return std::nullopt;
    CounterRng rng(seed, i);
    const Stratum& st = stratumOf(rng.uniform());
    const Target& target = targets_[static_cast<size_t>(st.target)];
    const Vec2 uv =
        target.levels[static_cast<size_t>(st.level)].at(st.cell, rng.uniform(), rng.uniform());
    return lit(target, uv, density(target, uv), rng, work, chain);
}

std::optional<PartLight::Start> PartLight::lit(const Target& target, const Vec2& uv,
                                               double uvDensity, CounterRng& rng,
                                               LensConnector::Work& work,
                                               std::vector<PathEvent>* chain) const {
    const TransportView& ts = *ts_;
    // Every uniform is drawn whether or not the point has light.
    const double u1 = rng.uniform(), u2 = rng.uniform(), uw = rng.uniform();
    const auto x = shapes_[static_cast<size_t>(target.object)].at(std::clamp(uv.x, 0.0, 1.0),
                                                                  std::clamp(uv.y, 0.0, 1.0));
    if (!x) return std::nullopt;
    const MediaOptics& media = *ts.media;
    const int wavelengths = media.wavelengthCount();
    const int w = std::min(wavelengths - 1, static_cast<int>(uw * wavelengths));
    const double nm = media.wavelengthNm(w);
    const auto c = lc_->connect(target.source, w, nm, target.steps, x->point, target.object, u1, u2,
                                work, chain);
    if (!c) return std::nullopt;
    const double density = uvDensity * x->density;
    const double flux =
        c->value * std::abs(glm::dot(c->toLight, x->normal)) / density * wavelengths;
    if (!(flux > 0.0) || !std::isfinite(flux)) return std::nullopt;
    Start out;
    out.source = target.source;
    out.object = target.object;
    out.primitive = x->primitive;
    out.steps = target.steps;
    out.line = w;
    out.wavelengthNm = nm;
    out.point = x->point;
    out.normal = x->normal;
    out.toLight = c->toLight;
    out.distanceMm = c->distanceMm;
    out.flux = flux;
    out.legsPerLobe = target.lobes > 0 ? static_cast<double>(target.legs) / target.lobes : 1.0;
    return out;
}

SceneHit PartLight::hitOf(const Scene& scene, const Start& s) {
    const SceneObject& o = scene.object(s.object);
    SceneHit hit;
    hit.object = s.object;
    hit.primitive = s.primitive;
    hit.t = s.distanceMm;
    hit.point = s.point;
    hit.normal = s.normal;
    hit.fromFront = glm::dot(s.toLight, s.normal) > 0.0;
    hit.mediumFrom = hit.fromFront ? o.mediumFront : o.mediumBack;
    hit.mediumTo = hit.fromFront ? o.mediumBack : o.mediumFront;
    return hit;
}

bool PartLight::productive(int object, int primitive) const {
    return std::binary_search(productive_.begin(), productive_.end(), placeKey(object, primitive));
}

int PartLight::aimStep(int object, int primitive) const {
    const uint64_t key = placeKey(object, primitive);
    const auto it = std::lower_bound(aims_.begin(), aims_.end(), std::pair<uint64_t, int>{key, -1});
    return it != aims_.end() && it->first == key ? it->second : -1;
}

bool PartLight::samplePhoton(const Target& target, const Vec2& uv, double uvDensity,
                             CounterRng& rng, LensConnector::Work& work, Splat& out,
                             std::vector<uint64_t>* places,
                             std::vector<std::pair<uint64_t, int>>* aims) const {
    const DesignedPath& dp = lc_->designed();
    const TransportView& ts = *ts_;
    const auto st = lit(target, uv, uvDensity, rng, work, nullptr);
    if (!st) return false;
    const SceneHit at = hitOf(*ts.scene, *st);
    const Interaction in =
        interact(ts, at, -st->toLight, st->line, st->wavelengthNm, TransportMode::Flux);
    // Follows `ray` (leaving `from`) by one child by weight until it meets the detector or a
    // scatter: the flux share that reaches the detector's object (0 for none), and where it
    // scattered (hit valid, children interacted) when it did.
    struct Leg {
        double share = 0.0;
        std::optional<SceneHit> scatterHit;
        Interaction scatterAt;
        Vec3 arriving{0.0};
        // Reaching the detector: the designed step it went on from (faces j..N-1 crossed as
        // designed, then the detector), or -1.
        int designedFrom = -1;
    };
    constexpr int kMostSegments = 64;
    std::vector<std::pair<int, EventType>> crossed;
    auto leg = [&](Ray ray, int medium, int from, int fromPrimitive) {
        Leg l;
        crossed.clear();
        double share = 1.0;
        for (int segment = 0; segment < kMostSegments; ++segment) {
            const auto h = ts.scene->closestHit(ray, kInfinity, from, fromPrimitive, medium);
            ++work.rays;
            if (!h) return l;
            const double alpha = ts.media->absorptionPerMm(medium, st->line);
            if (alpha > 0.0) share *= std::exp(-alpha * h->t);
            if (ts.detectorOfObject[h->object] >= 0) {
                if (h->object == detectorObject_) {
                    l.share = share;
                    const int first = dp.steps() - static_cast<int>(crossed.size());
                    int step = first;
                    for (const auto& [object, event] : crossed)
                        if (step >= 0) step = dp.forward(step, object, event);
                    if (first >= 0 && step >= 0 && dp.completeForward(step)) l.designedFrom = first;
                }
                return l;
            }
            Interaction next =
                interact(ts, *h, ray.direction, st->line, st->wavelengthNm, TransportMode::Flux);
            if (next.count == 0) return l;
            bool scatters = false;
            for (int c = 0; c < next.count; ++c) scatters |= next.children[c].scatter;
            if (scatters) {
                l.share = share;
                l.scatterHit = *h;
                l.scatterAt = next;
                l.arriving = ray.direction;
                return l;
            }
            const int k = next.count > 1 ? chooseChild(next, rng.uniform()) : 0;
            share *= next.total;
            crossed.emplace_back(h->object, next.children[k].event);
            const auto d = next.direction(k, rng);
            if (!d) return l;
            ray = {h->point, *d};
            medium = next.children[k].medium;
            from = h->object;
            fromPrimitive = h->primitive;
        }
        return l;
    };
    // kPilotSplits directions from the part's lobe; where one meets a splatted lobe,
    // kPilotSplits directions from that one, each followed by one child by weight to the
    // detector (a scatter ends it).
    double total = 0.0;
    int lobes = 0;  // those that met a splatted lobe whose light reached the detector
    for (int i = 0; i < kPilotSplits; ++i) {
        const double scattered = scatteredShare(in);
        const int c = chooseScatterChild(in, rng.uniform());
        if (c < 0) return false;
        const auto dir = in.direction(c, rng);
        if (!dir) continue;
        const Leg first = leg({st->point, *dir}, in.children[c].medium, st->object, st->primitive);
        if (!first.scatterHit) continue;
        const SceneHit& b = *first.scatterHit;
        const size_t prop = static_cast<size_t>(ts.propertyOfObject[b.object]);
        if (!(prop < splatted_.size() && splatted_[prop])) continue;
        bool reached = false;
        for (int j = 0; j < kPilotSplits; ++j) {
            const double onward = scatteredShare(first.scatterAt);
            const int cb = chooseScatterChild(first.scatterAt, rng.uniform());
            const auto db = first.scatterAt.direction(cb, rng);
            if (!db) continue;
            const Leg second =
                leg({b.point, *db}, first.scatterAt.children[cb].medium, b.object, b.primitive);
            if (second.scatterHit || !(second.share > 0.0)) continue;
            total += scattered * first.share * onward * second.share;
            reached = true;
            if (places) {
                places->push_back(placeKey(st->object, st->primitive));
                places->push_back(placeKey(b.object, b.primitive));
            }
            if (aims && second.designedFrom >= 0)
                aims->emplace_back(placeKey(b.object, b.primitive), second.designedFrom);
        }
        if (reached) ++lobes;
    }
    out.flux = st->flux * total / (kPilotSplits * kPilotSplits);
    out.aim = 0;
    out.legs = kPilotSplits;
    out.lobes = lobes;
    return out.flux > 0.0 && std::isfinite(out.flux);
}

bool PartLight::sample(const Target& target, const Vec2& uv, double uvDensity, CounterRng& rng,
                       const DetectorImage* detector, Scratch& sc, LensConnector::Work& work,
                       Splat& out, int directions,
                       const std::function<void(const Splat&, const Scratch&)>* each) const {
    const TransportView& ts = *ts_;
    // Every uniform is drawn whether or not the sample counts.
    const double u = std::clamp(uv.x, 0.0, 1.0), v = std::clamp(uv.y, 0.0, 1.0);
    const double u1 = rng.uniform(), u2 = rng.uniform();
    const double uw = rng.uniform();
    const double ua = rng.uniform(), uy1 = rng.uniform(), uy2 = rng.uniform();
    const auto x = shapes_[static_cast<size_t>(target.object)].at(u, v);
    if (!x) return false;
    const MediaOptics& media = *ts.media;
    const int wavelengths = media.wavelengthCount();
    const int w = std::min(wavelengths - 1, static_cast<int>(uw * wavelengths));
    const double nm = media.wavelengthNm(w);
    const bool events = !sc.state.empty();  // with criteria
    const auto c = lc_->connect(target.source, w, nm, target.steps, x->point, target.object, u1, u2,
                                work, events ? &sc.chain : nullptr);
    if (!c) return false;
    // The light's context at the point and its scatter channels, the same for every direction.
    const SceneObject& object = ts.scene->object(target.object);
    const OpticalProperty& prop = ts.properties[ts.propertyOfObject[target.object]];
    ViewPoint at;
    at.positionMm = x->point;
    at.normal = x->normal;
    at.object = target.object;
    at.primitive = x->primitive;
    at.wavelength = w;
    at.fromFront = true;
    at.medium = object.mediumFront;
    at.otherMedium = object.mediumBack;
    const SurfaceContext light = lightContext(ts, at, -c->toLight, nm);
    const PartShape& face = faces_[static_cast<size_t>(target.onward)];
    // The three ways a direction is drawn (the header comment, step 3), where the next face's
    // map can be inverted (so the aim's density of any direction is known): from the
    // direction guide, kGuideShare of them once the pilot found light; from the part's own
    // lobe, kLobeShare of the rest; toward the aim's point of the next face, the others.
    // Elsewhere the aim alone.
    double reflectShare = 0.0, transmitShare = 0.0, lobeShare = 0.0, guideShare = 0.0;
    if (face.invertible()) {
        const Channels ch = prop.channels(light);
        const double scatter = ch.scatterReflect + ch.scatterTransmit;
        if (!target.guide.empty()) guideShare = kGuideShare;
        if (scatter > 0.0) {
            reflectShare = ch.scatterReflect / scatter;
            transmitShare = ch.scatterTransmit / scatter;
            lobeShare = (1.0 - guideShare) * kLobeShare;
        }
    }
    const double aimShare = 1.0 - guideShare - lobeShare;
    const GuideFrame guideFrame(x->point, detectorCentre_, detectorAxis_);
    auto lobePdf = [&](const Vec3& to) {
        const double share = glm::dot(to, light.normal) < 0.0 ? transmitShare : reflectShare;
        return share > 0.0 ? share * prop.scatterPdf(light, to) : 0.0;
    };
    auto aimCell = [&](double da, double& share) {
        if (target.aim.empty()) {
            share = 1.0 / kAimCount;
            return std::min(kAimCount - 1, static_cast<int>(da * kAimCount));
        }
        const int cell = static_cast<int>(drawFromRunningSums(target.aimCumulative, da));
        share = target.aim[static_cast<size_t>(cell)] / target.aimCumulative.back();
        return cell;
    };
    // The density per steradian with which the aim draws `to`, met first at y (normal ny).
    auto aimPdf = [&](const Vec3& to, const Vec3& y, const Vec3& ny, int primitive, int& cell) {
        cell = 0;
        const auto uvY = face.uvOf(y);
        if (!uvY) return 0.0;
        const int i = std::min(kAim - 1, static_cast<int>(uvY->x * kAim));
        const int j = std::min(kAim - 1, static_cast<int>(uvY->y * kAim));
        cell = j * kAim + i;
        const double share = target.aim.empty() ? 1.0 / kAimCount
                                                : target.aim[static_cast<size_t>(cell)] /
                                                      target.aimCumulative.back();
        const Vec3 d = y - x->point;
        const double cosY = std::abs(glm::dot(to, ny));
        if (!(cosY > 0.0)) return 0.0;
        return share * kAimCount * face.densityAt(y, primitive) * glm::dot(d, d) / cosY;
    };
    // One direction: from the guide, from the lobe, or toward a point of the face light goes
    // on through (or the detector).
    auto direction = [&](double da, double dy1, double dy2, Splat& sp) {
        const bool fromGuide = da < guideShare;
        const bool fromLobe = !fromGuide && da < guideShare + lobeShare;
        const bool aimed = !fromGuide && !fromLobe;
        Vec3 to(0.0);
        double pdfDirection = 0.0;
        std::optional<PartPoint> y;
        double d = 0.0;
        if (fromGuide) {
            const int cell =
                static_cast<int>(drawFromRunningSums(target.guideCumulative, da / guideShare));
            to = guideFrame.at((cell % kGuideU + dy1) / kGuideU, (cell / kGuideU + dy2) / kGuideV);
        } else if (fromLobe) {
            const double dc = (da - guideShare) / lobeShare;
            const ScatterSample ss = prop.sampleScatter(light, dc < transmitShare, dy1, dy2);
            if (!(ss.pdf > 0.0)) return false;
            to = glm::normalize(ss.direction);
        } else {
            double cellShare = 0.0;
            const int aim =
                aimCell(aimShare < 1.0 ? (da - guideShare - lobeShare) / aimShare : da, cellShare);
            sp.aim = aim;
            y = face.at((aim % kAim + dy1) / kAim, (aim / kAim + dy2) / kAim);
            if (!y) return false;
            to = y->point - x->point;
            const double d2 = glm::dot(to, to);
            if (!(d2 > 0.0)) return false;
            d = std::sqrt(d2);
            to /= d;
            const double cosY = std::abs(glm::dot(to, y->normal));
            if (!(cosY > 0.0)) return false;
            pdfDirection = cellShare * kAimCount * y->density * d2 / cosY;
        }
        if (!detector) {  // the pilot's, to learn the guide from
            double guideU = 0.0;
            sp.guide = guideFrame.cell(to, guideU);
        }
        const double cosX = std::abs(glm::dot(to, x->normal));
        if (!(cosX > 0.0)) return false;
        // The radiance leaving toward `to`: a view point's, with `to` toward its detector.
        ViewPoint vp = at;
        vp.toDetector = to;
        vp.fromFront = glm::dot(to, x->normal) > 0.0;
        vp.medium = vp.fromFront ? object.mediumFront : object.mediumBack;
        vp.otherMedium = vp.fromFront ? object.mediumBack : object.mediumFront;
        const double f = prop.bsdf(light, to);
        const double radiance = f * std::abs(glm::dot(c->toLight, x->normal)) * c->value;
        if (!(radiance > 0.0)) return false;
        const auto on =
            lc_->onward({x->point, to}, target.object, x->primitive, vp.medium, target.onward, w,
                        nm, detectorObject_, work, events ? &sc.onward : nullptr);
        if (!on) return false;
        if (aimed && !on->firstMeets(y->point, d)) return false;
        // The mixture's density of `to`: the aim's through its first crossing of the face
        // (the only one the aim counts), the lobe's and the guide's.
        if (aimShare < 1.0) {
            int cell = 0;
            const double byAim =
                aimed ? pdfDirection
                      : aimPdf(to, on->firstPoint, on->firstNormal, on->firstPrimitive, cell);
            if (!aimed) sp.aim = cell;
            pdfDirection = aimShare * byAim + lobeShare * lobePdf(to) +
                           (guideShare > 0.0 ? guideShare * guideFrame.pdf(to, target.guide) : 0.0);
        }
        if (!(pdfDirection > 0.0)) return false;
        const double pointDensity = uvDensity * x->density;
        sp.flux = radiance * cosX / (pdfDirection * pointDensity) * on->transmit * wavelengths /
                  directions;
        if (!(sp.flux > 0.0) || !std::isfinite(sp.flux)) return false;
        if (detector) {
            const auto pixel = detector->pixelOf(on->detectorHit.point);
            if (!pixel) return false;
            sp.pixel = *pixel;
        }
        if (!events) return true;
        // The light's own scatter event, from its side of the surface.
        const bool crosses = glm::dot(c->toLight, x->normal) * glm::dot(to, x->normal) < 0.0;
        sc.chain.push_back(pathEvent(
            crosses ? EventType::ScatterTransmit : EventType::ScatterReflect, target.object,
            x->primitive, crosses ? vp.otherMedium : vp.medium, vp.medium));
        return true;
    };
    // The first direction's uniforms were drawn with the point's; each further one draws its
    // own. The point's light (the connection's solve) is shared by all of them: each carries
    // 1 / directions of it.
    const size_t chainEvents = sc.chain.size();
    bool any = false;
    for (int k = 0; k < directions; ++k) {
        const double a = k == 0 ? ua : rng.uniform();
        const double y1 = k == 0 ? uy1 : rng.uniform();
        const double y2 = k == 0 ? uy2 : rng.uniform();
        Splat one;
        if (events) sc.chain.resize(chainEvents);
        if (!direction(a, y1, y2, one)) continue;
        if (!any) out = one;
        any = true;
        if (each) (*each)(one, sc);
    }
    return any;
}

PartLight::Result PartLight::trace(const DetectorImage& detector, uint64_t samples, uint64_t seed,
                                   const PathJudge* judge, bool prune, const Ranks& ranks,
                                   int directions, bool splitByLight,
                                   const Deadline& deadline) const {
    Result result;
    const size_t pixels = static_cast<size_t>(detector.pixelCount());
    result.pixels.assign(pixels, 0.0);
    const size_t criteria = judge ? static_cast<size_t>(judge->count()) : 0;
    result.byCriterion.assign(criteria, std::vector<double>(pixels, 0.0));
    result.samples = samples;
    if (targets_.empty() || samples == 0 || mode_ != PartMode::Onward) return result;
    // The samples split over the targets by their shares (stratified by target: a change of
    // one part's light, as a sweep's variant makes, moves no other part's samples). Sample j
    // of target t draws from the stream (t, j) and counts share_t / n_t of its density's
    // estimate: the target's own estimate from its n_t samples.
    const std::vector<uint64_t> upTo = split(samples, splitByLight);
    result.samples = upTo.back();
    struct Entry {
        int pixel = 0;
        double flux = 0.0;
        uint64_t matched = 0;
    };
    struct Block {
        std::vector<Entry> entries;
        uint64_t rays = 0;
    };
    std::vector<double> perSample(upTo.size());
    for (size_t t = 0; t < upTo.size(); ++t)
        perSample[t] = targetShare_[t] / static_cast<double>(upTo[t] - (t == 0 ? 0 : upTo[t - 1]));
    auto produce = [&](uint64_t first, uint64_t last) {
        deadline.check();
        Block b;
        Scratch sc;
        if (judge) {
            sc.state.resize(judge->stateBytes());
            sc.scratch.resize(judge->stateBytes());
        }
        size_t t =
            static_cast<size_t>(std::upper_bound(upTo.begin(), upTo.end(), first) - upTo.begin());
        for (uint64_t i = first; i < last; ++i) {
            while (i >= upTo[t]) ++t;
            const uint64_t j = i - (t == 0 ? 0 : upTo[t - 1]);
            CounterRng rng(seed, (static_cast<uint64_t>(t) << 40) | j);
            const Stratum& st = stratumOf(t, rng.uniform());
            const Target& target = targets_[t];
            const Vec2 uv = target.levels[static_cast<size_t>(st.level)].at(st.cell, rng.uniform(),
                                                                            rng.uniform());
            LensConnector::Work work;
            Splat sp;
            const std::function<void(const Splat&, const Scratch&)> landed = [&](const Splat& o,
                                                                                 const Scratch& x) {
                uint64_t matched = 0;
                if (judge) {
                    judge->reset(sc.state.data());
                    judge->push(
                        sc.state.data(),
                        pathEvent(EventType::Emit, static_cast<int>(target.source), 0, 0, 0));
                    for (const PathEvent& e : x.chain) judge->push(sc.state.data(), e);
                    matched = judge->matches(sc.state.data(), x.onward, sc.scratch.data());
                }
                b.entries.push_back({o.pixel, o.flux * perSample[t], matched});
            };
            sample(target, uv, density(target, uv), rng, &detector, sc, work, sp, directions,
                   &landed);
            b.rays += work.rays;
        }
        return b;
    };
    auto consume = [&](const Block& b) {
        result.rays += b.rays;
        for (const Entry& e : b.entries) {
            ++result.found;
            for (uint64_t m = e.matched; m != 0; m &= m - 1)
                result.byCriterion[static_cast<size_t>(std::countr_zero(m))]
                                  [static_cast<size_t>(e.pixel)] += e.flux;
            if (prune && e.matched == 0) continue;
            result.pixels[static_cast<size_t>(e.pixel)] += e.flux;
            result.sum += e.flux;
            result.squares += e.flux * e.flux;
        }
    };
    auto pack = [](const Block& b) {
        ByteWriter w;
        w.put(b.rays);
        w.putVector(b.entries);
        return w.take();
    };
    auto unpack = [](const Bytes& bytes) {
        ByteReader r(bytes);
        Block b;
        b.rays = r.get<uint64_t>();
        b.entries = r.getVector<Entry>();
        return b;
    };
    constexpr uint64_t kBlock = 1024;
    forBlocksInOrderOnRanks(ranks, upTo.back(), kBlock, produce, consume, pack, unpack);
    return result;
}

}  // namespace veil
