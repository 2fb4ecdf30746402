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

struct PartLight::Scratch {
    std::vector<PathEvent> chain, onward;
    std::vector<std::byte> state, scratch;
};

PartLight::PartLight(const TransportView& ts, const LensConnector& connector, int detectorObject,
                     const std::vector<bool>& followed, double radiusMm)
    : ts_(&ts),
      lc_(&connector),
      detectorObject_(detectorObject),
      objects_(ts.scene->objects().size()) {
    const DesignedPath& dp = connector.designed();
    if (!connector.any() || dp.steps() == 0 || detectorObject < 0) return;
    const Scene& scene = *ts.scene;
    for (int k = 0; k < dp.steps(); ++k) faces_.emplace_back(scene, dp.objectOfStep(k));
    faces_.emplace_back(scene, detectorObject);
    const double most = kDisks * std::numbers::pi * radiusMm * radiusMm;
    shapes_.resize(objects_);
    std::vector<bool> tried(objects_, false);
    std::vector<Target> candidates;
    for (size_t s = 0; s < ts.sources.size(); ++s)
        for (size_t o = 0; o < objects_; ++o) {
            const uint64_t chains = connector.chains(s, static_cast<int>(o));
            if (chains == 0) continue;
            const int prop = ts.propertyOfObject[o];
            if (static_cast<size_t>(prop) < followed.size() && followed[static_cast<size_t>(prop)])
                continue;
            if (!tried[o]) {
                tried[o] = true;
                shapes_[o] = PartShape(scene, static_cast<int>(o));
                if (!(shapes_[o].areaMm2() < most)) shapes_[o] = PartShape();
            }
            if (!shapes_[o].valid()) continue;
            for (uint64_t m = chains; m != 0; m &= m - 1) {
                const int steps = std::countr_zero(m) + 1;
                for (int j = steps; j <= dp.steps(); ++j)
                    if (faces_[static_cast<size_t>(j)].valid())
                        candidates.push_back({s, static_cast<int>(o), steps, j});
            }
        }
    if (candidates.empty()) return;

    // The pilot: the root mean square of each cell's estimate of its own light.
    std::vector<std::pair<size_t, int>> cells;  // (candidate, cell)
    for (size_t t = 0; t < candidates.size(); ++t)
        for (int cell = 0; cell < kCellCount; ++cell) cells.emplace_back(t, cell);
    std::vector<double> rms(cells.size(), 0.0);
    std::vector<double> aimed(cells.size() * kAimCount, 0.0);  // the light per aim cell
    tbb::parallel_for(size_t{0}, cells.size(), [&](size_t i) {
        Scratch scratch;
        double sum2 = 0.0;
        for (int j = 0; j < kPilotPerCell; ++j) {
            CounterRng rng(kPartPilotSeed, i * kPilotPerCell + static_cast<uint64_t>(j));
            LensConnector::Work work;
            Splat sp;
            if (!sample(candidates[cells[i].first], cells[i].second, 1.0, rng, nullptr, scratch,
                        work, sp))
                continue;
            sum2 += sp.flux * sp.flux;
            aimed[i * kAimCount + static_cast<size_t>(sp.aim)] += 1.0;
        }
        rms[i] = std::sqrt(sum2 / kPilotPerCell);
    });
    // Candidates whose pilot found no light at all are left to the view points.
    std::vector<double> light(candidates.size(), 0.0);
    for (size_t i = 0; i < cells.size(); ++i) light[cells[i].first] += rms[i];
    std::vector<int> index(candidates.size(), -1);
    targetsOf_.assign(ts.sources.size() * objects_, {});
    std::vector<double> aimLight(candidates.size() * kAimCount, 0.0);
    for (size_t i = 0; i < cells.size(); ++i)
        for (size_t a = 0; a < kAimCount; ++a)
            aimLight[cells[i].first * kAimCount + a] += aimed[i * kAimCount + a];
    for (size_t t = 0; t < candidates.size(); ++t) {
        if (!(light[t] > 0.0)) continue;
        // Where its light went on: the aim cells in proportion to it.
        double aimTotal = 0.0;
        for (size_t a = 0; a < kAimCount; ++a) aimTotal += aimLight[t * kAimCount + a];
        double running = 0.0;
        for (size_t a = 0; a < kAimCount; ++a) {
            const double p = (1.0 - kDefensive) * aimLight[t * kAimCount + a] / aimTotal +
                             kDefensive / kAimCount;
            candidates[t].aim.push_back(p);
            running += p;
            candidates[t].aimCumulative.push_back(running);
        }
        index[t] = static_cast<int>(targets_.size());
        targetsOf_[candidates[t].source * objects_ + static_cast<size_t>(candidates[t].object)]
            .push_back(index[t]);
        targets_.push_back(std::move(candidates[t]));
    }
    if (targets_.empty()) return;
    double total = 0.0;
    size_t kept = 0;
    for (size_t i = 0; i < cells.size(); ++i)
        if (index[cells[i].first] >= 0) {
            total += rms[i];
            ++kept;
        }
    double sum = 0.0;
    for (size_t i = 0; i < cells.size(); ++i) {
        if (index[cells[i].first] < 0) continue;
        const double q =
            (1.0 - kDefensive) * rms[i] / total + kDefensive / static_cast<double>(kept);
        strata_.emplace_back(index[cells[i].first], cells[i].second);
        q_.push_back(q);
        sum += q;
        cumulative_.push_back(sum);
    }
}

bool PartLight::owns(size_t s, int object, int steps, int designed) const {
    if (targetsOf_.empty()) return false;
    for (int t : targetsOf_[s * objects_ + static_cast<size_t>(object)]) {
        const Target& target = targets_[static_cast<size_t>(t)];
        if (target.steps == steps && target.onward == designed) return true;
    }
    return false;
}

bool PartLight::sample(const Target& target, int cell, double q, CounterRng& rng,
                       const DetectorImage* detector, Scratch& sc, LensConnector::Work& work,
                       Splat& out) const {
    const TransportView& ts = *ts_;
    // Every uniform is drawn whether or not the sample counts.
    const double u = (cell % kCells + rng.uniform()) / kCells;
    const double v = (cell / kCells + rng.uniform()) / kCells;
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
    // The direction: toward a point of the face light goes on through (or the detector).
    int aim = std::min(kAimCount - 1, static_cast<int>(ua * kAimCount));
    double aimShare = 1.0 / kAimCount;
    if (!target.aim.empty()) {
        const double all = target.aimCumulative.back();
        aim = static_cast<int>(std::min<size_t>(
            static_cast<size_t>(std::upper_bound(target.aimCumulative.begin(),
                                                 target.aimCumulative.end(), ua * all) -
                                target.aimCumulative.begin()),
            kAimCount - 1));
        aimShare = target.aim[static_cast<size_t>(aim)] / all;
    }
    out.aim = aim;
    const auto y = faces_[static_cast<size_t>(target.onward)].at((aim % kAim + uy1) / kAim,
                                                                 (aim / kAim + uy2) / kAim);
    if (!y) return false;
    Vec3 to = y->point - x->point;
    const double d2 = glm::dot(to, to);
    if (!(d2 > 0.0)) return false;
    const double d = std::sqrt(d2);
    to /= d;
    const double cosY = std::abs(glm::dot(to, y->normal));
    const double cosX = std::abs(glm::dot(to, x->normal));
    if (!(cosY > 0.0) || !(cosX > 0.0)) return false;
    const double pdfDirection = aimShare * kAimCount * y->density * d2 / cosY;
    // The radiance leaving toward `to`: a view point's, with `to` toward its detector.
    const SceneObject& o = ts.scene->object(target.object);
    ViewPoint vp;
    vp.positionMm = x->point;
    vp.normal = x->normal;
    vp.toDetector = to;
    vp.object = target.object;
    vp.primitive = x->primitive;
    vp.wavelength = w;
    vp.fromFront = glm::dot(to, x->normal) > 0.0;
    vp.medium = vp.fromFront ? o.mediumFront : o.mediumBack;
    vp.otherMedium = vp.fromFront ? o.mediumBack : o.mediumFront;
    const OpticalProperty& prop = ts.properties[ts.propertyOfObject[target.object]];
    const double f = prop.bsdf(lightContext(ts, vp, -c->toLight, nm), to);
    const double radiance = f * std::abs(glm::dot(c->toLight, x->normal)) * c->value;
    if (!(radiance > 0.0)) return false;
    const auto on =
        lc_->onward({x->point, to}, target.object, x->primitive, vp.medium, target.onward, w, nm,
                    detectorObject_, work, events ? &sc.onward : nullptr);
    if (!on) return false;
    const double tol =
        1e-6 * std::max({1.0, std::abs(y->point.x), std::abs(y->point.y), std::abs(y->point.z)}) +
        1e-7 * d;
    if (glm::length(on->firstPoint - y->point) > tol) return false;
    const double pointDensity = q * kCellCount * x->density;
    out.flux = radiance * cosX / (pdfDirection * pointDensity) * on->transmit * wavelengths;
    if (!(out.flux > 0.0) || !std::isfinite(out.flux)) return false;
    if (detector) {
        const auto pixel = detector->pixelOf(on->detectorHit.point);
        if (!pixel) return false;
        out.pixel = *pixel;
    }
    if (!events) return true;
    // The light's own scatter event, from its side of the surface.
    const bool crosses = glm::dot(c->toLight, x->normal) * glm::dot(to, x->normal) < 0.0;
    sc.chain.push_back(pathEvent(crosses ? EventType::ScatterTransmit : EventType::ScatterReflect,
                                 target.object, x->primitive, crosses ? vp.otherMedium : vp.medium,
                                 vp.medium));
    return true;
}

PartLight::Result PartLight::trace(const DetectorImage& detector, uint64_t samples, uint64_t seed,
                                   const PathJudge* judge, bool prune, const Ranks& ranks) const {
    Result result;
    const size_t pixels = static_cast<size_t>(detector.pixelCount());
    result.pixels.assign(pixels, 0.0);
    const size_t criteria = judge ? static_cast<size_t>(judge->count()) : 0;
    result.byCriterion.assign(criteria, std::vector<double>(pixels, 0.0));
    result.samples = samples;
    if (targets_.empty() || samples == 0) return result;
    struct Entry {
        int pixel = 0;
        double flux = 0.0;
        uint64_t matched = 0;
    };
    struct Block {
        std::vector<Entry> entries;
        uint64_t rays = 0;
    };
    const double perSample = 1.0 / static_cast<double>(samples);
    const double all = cumulative_.back();
    auto produce = [&](uint64_t first, uint64_t last) {
        Block b;
        Scratch sc;
        if (judge) {
            sc.state.resize(judge->stateBytes());
            sc.scratch.resize(judge->stateBytes());
        }
        for (uint64_t i = first; i < last; ++i) {
            CounterRng rng(seed, i);
            const double pick = rng.uniform() * all;
            const size_t k = std::min(
                static_cast<size_t>(std::upper_bound(cumulative_.begin(), cumulative_.end(), pick) -
                                    cumulative_.begin()),
                cumulative_.size() - 1);
            const Target& target = targets_[static_cast<size_t>(strata_[k].first)];
            LensConnector::Work work;
            Splat sp;
            const bool found =
                sample(target, strata_[k].second, q_[k] / all, rng, &detector, sc, work, sp);
            b.rays += work.rays;
            if (!found) continue;
            uint64_t matched = 0;
            if (judge) {
                judge->reset(sc.state.data());
                judge->push(sc.state.data(),
                            pathEvent(EventType::Emit, static_cast<int>(target.source), 0, 0, 0));
                for (const PathEvent& e : sc.chain) judge->push(sc.state.data(), e);
                matched = judge->matches(sc.state.data(), sc.onward, sc.scratch.data());
            }
            b.entries.push_back({sp.pixel, sp.flux * perSample, matched});
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
            if (!(prune && e.matched == 0)) result.pixels[static_cast<size_t>(e.pixel)] += e.flux;
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
    forBlocksInOrderOnRanks(ranks, samples, kBlock, produce, consume, pack, unpack);
    return result;
}

}  // namespace veil
