#include "analysis/studies/objects.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analysis/pictures/layout.h"
#include "analysis/pictures/scene_section.h"
#include "analysis/reports/format.h"
#include "analysis/runs/render_run.h"
#include "geometry/exact_face.h"
#include "geometry/scene.h"
#include "lensdata/errors.h"
#include "tracer/light/spectrum.h"
#include "tracer/records/detector.h"
#include "tracer/records/path_history.h"
#include "tracer/render/render.h"
#include "tracer/scene/prepared_scene.h"
#include "tracer/scene/scene_transport.h"
#include "tracer/transport/interaction.h"

namespace veil {

namespace {

constexpr double kHalfPi = 1.5707963267948966;

// Sides of an object (the header comment). Meshes: by the facing of the triangle hit;
// exact faces: kExactSide + the medium the light arrives from. kWhole: the object itself.
enum MeshSide : uint32_t { kFront = 0, kBack = 1, kBore = 2, kOutside = 3 };
constexpr uint32_t kExactSide = 4;
constexpr uint32_t kWhole = 0xFFFF;
// Per object and side: the light arriving, and (scattered = true) the share of it the
// surface scatters, the flux of the branches pruned right after their scatter event.
constexpr uint64_t key(int object, uint32_t side, bool scattered = false) {
    return (static_cast<uint64_t>(object) << 17) | (scattered ? 1u << 16 : 0u) | side;
}

uint32_t meshSide(const TriangleMesh& m, int triangle) {
    const Vec3 n = m.triangleNormal(static_cast<size_t>(triangle));
    if (n.z <= -0.7071067811865476) return kFront;
    if (n.z >= 0.7071067811865476) return kBack;
    const auto& t = m.triangles[static_cast<size_t>(triangle)];
    const Vec3 c = (m.vertices[t[0]] + m.vertices[t[1]] + m.vertices[t[2]]) / 3.0;
    return n.x * c.x + n.y * c.y < 0.0 ? kBore : kOutside;
}

std::string sideName(const Scene& scene, uint32_t side) {
    switch (side) {
        case kFront:
            return "front (-z)";
        case kBack:
            return "back (+z)";
        case kBore:
            return "bore";
        case kOutside:
            return "outside";
        default:
            break;
    }
    const size_t medium = side - kExactSide;
    return "from " + (medium < scene.media().size() ? scene.media()[medium].name
                                                    : "medium " + std::to_string(medium));
}

// A branch is wanted until its first scatter event: the arrivals before it are what the
// source lights (or the detector sees) directly, through the specular chain.
class SpecularOnly : public BranchFilter {
    struct State : BranchState {
        std::unique_ptr<BranchState> clone() const override { return std::make_unique<State>(); }
        bool push(const PathEvent& e) override {
            return e.type != EventType::ScatterReflect && e.type != EventType::ScatterTransmit;
        }
    };

  public:
    std::unique_ptr<BranchState> start() const override { return std::make_unique<State>(); }
};

struct Moments {
    double sum = 0.0, squares = 0.0;
};

// The per-ray arrival values of one pass, summed deterministically: each ray's entries wait
// in its block (raysPerBlock rays) until the block is complete, then the block is reduced in
// ray order; blocks are added in block order at the end.
class ArrivalTally {
  public:
    // `counts` (may be empty): whether a ray counts, from its emission point; the others
    // are left out of the sums and of the number of rays.
    ArrivalTally(const Scene& scene, uint64_t rays, double scale,
                 std::function<bool(const Vec3&)> counts)
        : scene_(scene),
          rays_(rays),
          scale_(scale),
          counts_(std::move(counts)),
          blocks_((rays + kBlock - 1) / kBlock) {}

    void add(uint64_t ray, const PathHistory& h) {
        std::vector<std::pair<uint64_t, double>> values;
        const auto& nodes = h.nodes();
        const bool counted = !counts_ || counts_(nodes[0].position);
        specular_.clear();
        specular_.resize(nodes.size(), true);
        counted_.clear();
        counted_.resize(nodes.size(), false);
        auto sideOf = [&](const PathNode& n) {
            const SceneObject& o = scene_.object(n.object);
            if (const MeshRef* r = std::get_if<MeshRef>(&o.geometry))
                return meshSide(scene_.meshes()[static_cast<size_t>(r->mesh)], n.face);
            return kExactSide + static_cast<uint32_t>(nodes[static_cast<size_t>(n.parent)].medium);
        };
        auto isScatter = [](EventType t) {
            return t == EventType::ScatterReflect || t == EventType::ScatterTransmit;
        };
        for (size_t i = 1; counted && i < nodes.size(); ++i) {
            const PathNode& n = nodes[i];
            const size_t p = static_cast<size_t>(n.parent);
            specular_[i] = specular_[p] && !isScatter(n.type);
            // A branch pruned at its first scatter: its flux is what that surface scattered.
            if (n.type == EventType::Culled && isScatter(nodes[p].type) &&
                specular_[static_cast<size_t>(nodes[p].parent)]) {
                const double v = n.flux * scale_;
                values.emplace_back(key(nodes[p].object, sideOf(nodes[p]), true), v);
                values.emplace_back(key(nodes[p].object, kWhole, true), v);
                continue;
            }
            // The children of one node all come from the one hit that follows it: count the
            // arrival there once. Culled and Exit events meet no object.
            if (counted_[p] || !specular_[p] || n.object < 0 || n.type == EventType::Culled ||
                n.type == EventType::Exit)
                continue;
            counted_[p] = true;
            const double v = n.flux * scale_;
            values.emplace_back(key(n.object, sideOf(n)), v);
            values.emplace_back(key(n.object, kWhole), v);
        }
        std::sort(values.begin(), values.end());
        size_t w = 0;  // merge equal keys
        for (size_t i = 0; i < values.size(); ++i) {
            if (w > 0 && values[w - 1].first == values[i].first)
                values[w - 1].second += values[i].second;
            else
                values[w++] = values[i];
        }
        values.resize(w);

        const uint64_t b = ray / kBlock;
        std::lock_guard<std::mutex> lock(mutex_);
        Open& open = open_[b];
        for (const auto& [k, v] : values) open.entries.push_back({ray, k, v});
        ++open.done;
        if (counted) ++counted_rays_;
        const uint64_t size = std::min<uint64_t>(kBlock, rays_ - b * kBlock);
        if (open.done == size) {
            std::sort(open.entries.begin(), open.entries.end(), [](const Entry& x, const Entry& y) {
                return x.ray != y.ray ? x.ray < y.ray : x.key < y.key;
            });
            std::map<uint64_t, Moments>& sums = blocks_[b];
            for (const Entry& e : open.entries) {
                Moments& m = sums[e.key];
                m.sum += e.value;
                m.squares += e.value * e.value;
            }
            open_.erase(b);
        }
    }

    // Mean per ray and its standard error, per key.
    std::map<uint64_t, std::pair<double, double>> finish() const {
        std::map<uint64_t, Moments> total;
        for (const auto& block : blocks_)
            for (const auto& [k, m] : block) {
                total[k].sum += m.sum;
                total[k].squares += m.squares;
            }
        std::map<uint64_t, std::pair<double, double>> out;
        const double n = static_cast<double>(counted_rays_);
        for (const auto& [k, m] : total) {
            const double mean = n > 0 ? m.sum / n : 0.0;
            const double var = n > 1 ? std::max(0.0, m.squares / n - mean * mean) / (n - 1) : 0.0;
            out[k] = {mean, std::sqrt(var)};
        }
        return out;
    }

    // Rays that counted.
    uint64_t countedRays() const { return counted_rays_; }

  private:
    static constexpr uint64_t kBlock = 4096;
    struct Entry {
        uint64_t ray, key;
        double value;
    };
    struct Open {
        std::vector<Entry> entries;
        uint64_t done = 0;
    };
    const Scene& scene_;
    uint64_t rays_;
    double scale_;
    std::function<bool(const Vec3&)> counts_;
    uint64_t counted_rays_ = 0;  // under mutex_
    std::mutex mutex_;
    std::map<uint64_t, Open> open_;
    std::vector<std::map<uint64_t, Moments>> blocks_;
    static thread_local std::vector<bool> specular_, counted_;
};
thread_local std::vector<bool> ArrivalTally::specular_, ArrivalTally::counted_;

struct Arrivals {
    std::map<uint64_t, std::pair<double, double>> byKey;  // mean per counted ray, error
    double countedShare = 1.0;                            // of the rays traced
};

// One pass of the forward tracer from `ts`'s sources, rays per source, with histories; the
// values are shares of the flux the counted rays emit.
Arrivals arrivals(const TransportView& ts, const std::vector<DetectorImage>& images, uint64_t rays,
                  TransportOptions options, const std::function<void(uint64_t)>& progress,
                  std::function<bool(const Vec3&)> counts = {}) {
    double flux = 0.0;
    for (const Source& s : ts.sources) flux += s.totalFlux();
    const uint64_t total = rays * ts.sources.size();
    ArrivalTally tally(*ts.scene, total, static_cast<double>(total) / flux, std::move(counts));
    const SpecularOnly filter;
    options.filter = &filter;
    options.recordHistories = true;
    traceNonsequential(ts, images, rays, options, progress,
                       [&tally](uint64_t i, const PathHistory& h) { tally.add(i, h); });
    return {tally.finish(), static_cast<double>(tally.countedRays()) / static_cast<double>(total)};
}

// Whether the line through p along the unit direction n meets the object (its own geometry,
// nothing else in the scene), within `reach` on either side.
bool lineMeetsObject(const Scene& scene, const SceneObject& o, const Vec3& p, const Vec3& n,
                     double reach) {
    const Ray r{p - reach * n, n};
    if (const FaceGeometry* f = std::get_if<FaceGeometry>(&o.geometry))
        return intersectFace(*f, o.frame.toLocal(r), 0.0, 2.0 * reach, false).has_value();
    const MeshRef& ref = std::get<MeshRef>(o.geometry);
    const TriangleMesh& m = scene.meshes()[static_cast<size_t>(ref.mesh)];
    const size_t end =
        ref.triangleCount == 0 ? m.triangles.size() : size_t(ref.firstTriangle) + ref.triangleCount;
    for (size_t t = ref.firstTriangle; t < end; ++t) {
        const auto& tri = m.triangles[t];
        if (intersectTriangle(m.vertices[tri[0]], m.vertices[tri[1]], m.vertices[tri[2]], r, 0.0,
                              2.0 * reach))
            return true;
    }
    return false;
}

// A Lambertian emitter on the detector's sensitive side, a hair in front of it: what the
// detector sees, traced forward (reciprocity).
// The emitter's rectangle is the detector's grid, set a hair in front of the detector
// object's nearest point (a curved sensor's rim may lie in front of its vertex plane).
Source detectorEmitter(const Scene& scene, const DetectorGeometry& d,
                       const SpectralSampler& spectrum, double scale, double coneHalfAngleRad) {
    const SceneObject& o = scene.object(d.object);
    Bounds3 b;
    if (const FaceGeometry* f = std::get_if<FaceGeometry>(&o.geometry))
        b = transformBounds(o.frame, faceBounds(*f));
    else
        b = scene.meshes()[static_cast<size_t>(std::get<MeshRef>(o.geometry).mesh)].bounds();
    double front = 0.0;  // how far the object reaches toward the sensitive side
    for (int c = 0; c < 8; ++c) {
        const Vec3 corner((c & 1) ? b.hi.x : b.lo.x, (c & 2) ? b.hi.y : b.lo.y,
                          (c & 4) ? b.hi.z : b.lo.z);
        front = std::max(front, glm::dot(corner - d.frame.translation, d.normal()));
    }
    AreaEmitter e;
    e.coneHalfAngleRad = coneHalfAngleRad;
    e.shape = AreaEmitter::Shape::Rectangle;
    e.sizeMm = Vec2(d.widthMm, d.heightMm);
    // Local z along the sensitive normal (the detector frame's -z): turn half about x.
    e.frame.rotation = d.frame.rotation * glm::dmat3(1.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0);
    e.frame.translation = d.frame.translation + (front + 1e-9 * scale) * d.normal();
    return Source("detector " + d.name, LambertianSource{e}, 1.0, spectrum);
}

double triangleArea(const TriangleMesh& m, size_t t) {
    const auto& tri = m.triangles[t];
    return 0.5 * glm::length(glm::cross(m.vertices[tri[1]] - m.vertices[tri[0]],
                                        m.vertices[tri[2]] - m.vertices[tri[0]]));
}

bool isOptical(ObjectKind k) { return k == ObjectKind::LensFace || k == ObjectKind::MirrorFace; }

std::string percent(double value, double error) {
    if (!(value > 0.0)) return "0";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.3e +- %.2g %%", value, 100.0 * error / value);
    return buf;
}


}  // namespace

namespace {

// (object, side) and (object, whole) keys -> flux share and its error, from arrivals().
using ArrivalMap = std::map<uint64_t, std::pair<double, double>>;

std::pair<double, double> arrivalOf(const ArrivalMap& m, uint64_t k) {
    const auto it = m.find(k);
    return it == m.end() ? std::pair<double, double>{0.0, 0.0} : it->second;
}

// The sources counted (all, or --source), checked: one unit for all.
TransportView litSources(const SceneTransport& setup, const ObjectsSpec& spec,
                         ObjectsResult& result) {
    TransportView lit = setup.view;
    if (!spec.source.empty()) {
        std::string known;
        lit.sources.clear();
        for (const Source& s : setup.view.sources) {
            if (s.name() == spec.source) lit.sources.push_back(s);
            known += (known.empty() ? "" : ", ") + s.name();
        }
        if (lit.sources.empty())
            throw ParseError({"--source " + spec.source, 0, 0},
                             "no source '" + spec.source + "' (the scene has " + known + ")");
    }
    for (const Source& s : lit.sources) {
        result.sources.push_back(s.name());
        if (s.unit() != lit.sources.front().unit())
            throw ParseError({"--source", 0, 0},
                             "sources " + lit.sources.front().name() + " and " + s.name() +
                                 " emit in different units (W and lm): their shares cannot be "
                                 "added; choose one with --source");
    }
    return lit;
}

// The detector emits only into the cone that holds every object (through the renderer's exit
// aperture, when there is one): the hemisphere's other directions meet nothing. The cone
// carries sin^2(cone) of the hemisphere's flux, so its fractions scale by that.
double detectorCone(const Scene& scene, const DetectorGeometry& det) {
    double cone = kHalfPi;
    try {
        const ExitAperture a = exitApertureFor(scene, det);
        const double distance = std::abs(glm::dot(a.centerMm - det.frame.translation, a.normal));
        const double reach = a.radiusMm + 0.5 * std::hypot(det.widthMm, det.heightMm);
        if (distance > 0.0) cone = std::min(kHalfPi, std::atan(reach / distance) * (1.0 + 1e-9));
    } catch (const ModelError&) {
        // An object beside or behind the detector's plane: the whole hemisphere.
    }
    return cone;
}

// Side areas: a mesh's triangles by their facing; an exact face's two sides are the whole
// face (faceArea).
std::map<uint32_t, double> sideAreas(const Scene& scene, const SceneObject& o, double& faceArea) {
    std::map<uint32_t, double> area;
    faceArea = 0.0;
    if (const MeshRef* r = std::get_if<MeshRef>(&o.geometry)) {
        const TriangleMesh& m = scene.meshes()[static_cast<size_t>(r->mesh)];
        const size_t end = r->triangleCount == 0 ? m.triangles.size()
                                                 : size_t(r->firstTriangle) + r->triangleCount;
        for (size_t t = r->firstTriangle; t < end; ++t) {
            const double a = triangleArea(m, t);
            area[meshSide(m, static_cast<int>(t))] += a;
            faceArea += a;
        }
    } else {
        const TriangleMesh m = tessellateFace(std::get<FaceGeometry>(o.geometry), 1e-3);
        for (size_t t = 0; t < m.triangles.size(); ++t) faceArea += triangleArea(m, t);
    }
    return area;
}

double productVariance(double l, double le, double s, double se) {
    return s * s * le * le + l * l * se * se + le * le * se * se;
}

// One object's row: what the sources light and the detector sees of it, per side, their
// products and the first-order estimate on a detector of `detectorArea`.
ObjectRow objectRow(const Scene& scene, const SceneObject& o, const ArrivalMap& litBy,
                    const ArrivalMap& seenBy, double detectorArea) {
    ObjectRow row;
    row.object = o.id;
    row.name = o.name;
    row.part = o.part;
    row.kind = std::string(toString(o.kind));
    row.optical = isOptical(o.kind);
    std::tie(row.lit, row.litError) = arrivalOf(litBy, key(o.id, kWhole));
    std::tie(row.scattered, row.scatteredError) = arrivalOf(litBy, key(o.id, kWhole, true));
    std::tie(row.seen, row.seenError) = arrivalOf(seenBy, key(o.id, kWhole));
    // The sides either pass reached (arrivals; the scattered keys lie above kWhole).
    std::map<uint32_t, ObjectSide> sides;
    for (const ArrivalMap* m : {&litBy, &seenBy})
        for (auto it = m->lower_bound(key(o.id, 0)); it != m->end() && it->first < key(o.id, kWhole);
             ++it) {
            const auto side = static_cast<uint32_t>(it->first & 0xFFFF);
            sides[side].name = sideName(scene, side);
        }
    // An opaque part scatters light back to the side it came from; glass faces, edges and
    // flats may pass it through to the other side.
    const bool opaque = isOpaqueKind(o.kind);
    double faceArea = 0.0;
    std::map<uint32_t, double> area = sideAreas(scene, o, faceArea);
    double variance = 0.0, scatterVariance = 0.0, estimateVariance = 0.0;
    for (auto& [side, s] : sides) {
        s.areaMm2 = area.count(side) ? area[side] : faceArea;
        std::tie(s.lit, s.litError) = arrivalOf(litBy, key(o.id, side));
        std::tie(s.scattered, s.scatteredError) = arrivalOf(litBy, key(o.id, side, true));
        std::tie(s.seen, s.seenError) = arrivalOf(seenBy, key(o.id, side));
        if (opaque) {
            row.product += s.lit * s.seen;
            variance += productVariance(s.lit, s.litError, s.seen, s.seenError);
            row.scatterProduct += s.scattered * s.seen;
            scatterVariance += productVariance(s.scattered, s.scatteredError, s.seen, s.seenError);
            if (s.areaMm2 > 0.0) {
                const double f = detectorArea / s.areaMm2;
                row.estimate += f * s.scattered * s.seen;
                estimateVariance +=
                    f * f * productVariance(s.scattered, s.scatteredError, s.seen, s.seenError);
            }
        }
        row.sides.push_back(s);
    }
    if (!opaque) {
        row.product = row.lit * row.seen;
        variance = productVariance(row.lit, row.litError, row.seen, row.seenError);
        row.scatterProduct = row.scattered * row.seen;
        scatterVariance = productVariance(row.scattered, row.scatteredError, row.seen, row.seenError);
        if (faceArea > 0.0) {
            const double f = detectorArea / faceArea;
            row.estimate = f * row.scatterProduct;
            estimateVariance = f * f * scatterVariance;
        }
    }
    row.estimateError = std::sqrt(estimateVariance);
    row.productError = std::sqrt(variance);
    row.scatterProductError = std::sqrt(scatterVariance);
    std::stable_sort(row.sides.begin(), row.sides.end(), [](const ObjectSide& a, const ObjectSide& b) {
        return a.lit * a.seen > b.lit * b.seen;
    });
    return row;
}

// Ranked first (by the product or the estimate; optical faces only with includeOptical),
// then the rest by product, seen and lit.
void rankRows(const ObjectsSpec& spec, ObjectsResult& result) {
    const bool byEstimate = spec.rank == ObjectsSpec::Rank::Estimate;
    auto score = [byEstimate](const ObjectRow& r) { return byEstimate ? r.estimate : r.product; };
    auto ranked = [&](const ObjectRow& r) {
        return score(r) > 0.0 && (spec.includeOptical || !r.optical);
    };
    std::stable_sort(result.rows.begin(), result.rows.end(),
                     [&](const ObjectRow& a, const ObjectRow& b) {
                         if (ranked(a) != ranked(b)) return ranked(a);
                         if (score(a) != score(b)) return score(a) > score(b);
                         if (a.product != b.product) return a.product > b.product;
                         if (a.seen != b.seen) return a.seen > b.seen;
                         return a.lit > b.lit;
                     });
    int rank = 0;
    for (ObjectRow& r : result.rows)
        if (ranked(r)) r.rank = ++rank;
    result.rankedBy = byEstimate ? "estimate" : "product";
}

}  // namespace

ObjectsResult runObjects(const PreparedScene& prepared, const ObjectsSpec& spec) {
    const auto start = std::chrono::steady_clock::now();
    const SceneTransport& setup = prepared.transport();
    const Scene& scene = prepared.scene();
    if (spec.rays == 0) throw ModelError("objects", "no rays to trace");
    ObjectsResult result;
    // The detector and the sources, checked before any ray.
    if (setup.images.empty()) throw ModelError(prepared.spec().path.string(), "no detector");
    const DetectorGeometry* det = &setup.images[findDetector(setup, spec.detector)].geometry();
    const TransportView lit = litSources(setup, spec, result);
    result.detector = det->name;
    const Bounds3 bounds = scene.bounds();
    const double size = bounds.empty() ? 1.0 : std::max(1.0, glm::length(bounds.hi - bounds.lo));
    const double cone = detectorCone(scene, *det);
    TransportView seen = setup.view;
    seen.sources = {detectorEmitter(scene, *det, lit.sources.front().spectrum(), size, cone)};
    // Only the grid's points where the detector object is count (a round sensor in its square
    // grid records nothing in the corners).
    const SceneObject& detObject = scene.object(det->object);
    auto onDetector = [&scene, &detObject, det, size](const Vec3& p) {
        return lineMeetsObject(scene, detObject, p, det->normal(), size);
    };
    const double coneShare = std::pow(std::sin(cone), 2);
    result.sourceRays = spec.rays * lit.sources.size();
    result.detectorRays = spec.rays;
    TransportOptions options = spec.transport;
    auto progressOf = [&](const std::string& task, uint64_t total) {
        return spec.progress ? std::function<void(uint64_t)>([&spec, task, total](uint64_t d) {
            spec.progress({task, d, total});
        })
                             : std::function<void(uint64_t)>();
    };
    const ArrivalMap litBy = arrivals(lit, setup.images, spec.rays, options,
                                      progressOf("objects: lit by the sources", result.sourceRays))
                                 .byKey;
    options.seed = spec.transport.seed + 1;
    Arrivals seenPass =
        arrivals(seen, setup.images, spec.rays, options,
                 progressOf("objects: seen by the detector", result.detectorRays), onDetector);
    if (seenPass.countedShare == 0.0)
        throw ModelError(det->name, "no ray from the detector's grid starts on its object");
    ArrivalMap& seenBy = seenPass.byKey;
    for (auto& [k, v] : seenBy) {
        v.first *= coneShare;
        v.second *= coneShare;
    }
    // The sensitive area: the grid's, times the share of its points on the object.
    result.detectorAreaMm2 = det->widthMm * det->heightMm * seenPass.countedShare;
    for (const SceneObject& o : scene.objects())
        if (o.kind != ObjectKind::Detector && o.kind != ObjectKind::Dummy &&
            setup.view.detectorOfObject[static_cast<size_t>(o.id)] < 0)
            result.rows.push_back(objectRow(scene, o, litBy, seenBy, result.detectorAreaMm2));
    rankRows(spec, result);
    result.seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

ReportTable ObjectsResult::table() const {
    ReportTable table;
    auto column = [&](const std::string& key, const std::string& heading, bool right,
                      bool csv = true, bool markdown = true, bool json = true) {
        ReportColumn c{key, heading};
        c.markdownRule = right ? "---:" : "---";
        c.csv = csv;
        c.markdown = markdown;
        c.json = json;
        table.addColumn(std::move(c));
    };
    column("rank", "rank", true);
    column("object", "object", false);
    column("part", "", false, true, false);
    column("kind", "kind", false);
    column("optical", "", false, true, false);
    for (const char* k : {"lit", "scattered", "seen", "product", "estimate"}) {
        const std::string key = k;
        const std::string heading = key == "product"    ? "lit x seen"
                                    : key == "estimate" ? "first-order estimate"
                                                        : key;
        column(key, heading, true, true, key != "scattered");
        column(key + "_error", "", true, true, false);
    }
    column("scatter_product", "", true, false, false);
    column("scatter_product_error", "", true, false, false);
    column("main_side", "where", false, true, true, false);
    column("sides", "", false, false, false);
    // CSV: nine significant digits.
    auto number = [](double v, double e) {
        std::ostringstream os;
        os.precision(9);
        os << v;
        return ReportCell::number(v, os.str(), percent(v, e), percent(v, e));
    };
    auto error = [](double e) {
        std::ostringstream os;
        os.precision(9);
        os << e;
        return ReportCell::number(e, os.str(), "", "");
    };
    for (const ObjectRow& r : rows) {
        ReportCell rank = ReportCell::count(r.rank);
        rank.markdown = r.rank > 0 ? std::to_string(r.rank) : r.optical ? "optical" : "-";
        ReportCell sides = ReportCell::text("");
        sides.json = nlohmann::json::array();
        for (const ObjectSide& s : r.sides)
            sides.json.push_back({{"side", s.name},
                                  {"lit", jsonNumber(s.lit)},
                                  {"lit_error", jsonNumber(s.litError)},
                                  {"scattered", jsonNumber(s.scattered)},
                                  {"scattered_error", jsonNumber(s.scatteredError)},
                                  {"seen", jsonNumber(s.seen)},
                                  {"seen_error", jsonNumber(s.seenError)},
                                  {"area_mm2", jsonNumber(s.areaMm2)}});
        table.addRow({rank, ReportCell::text(r.name), ReportCell::text(r.part),
                      ReportCell::text(r.kind), ReportCell::flag(r.optical),
                      number(r.lit, r.litError), error(r.litError),
                      number(r.scattered, r.scatteredError), error(r.scatteredError),
                      number(r.seen, r.seenError), error(r.seenError),
                      number(r.product, r.productError), error(r.productError),
                      number(r.estimate, r.estimateError), error(r.estimateError),
                      number(r.scatterProduct, r.scatterProductError),
                      error(r.scatterProductError),
                      ReportCell::text(r.product > 0.0 ? r.sides.front().name : ""), sides});
    }
    return table;
}

std::string ObjectsResult::csv() const { return table().csv(); }

std::string ObjectsResult::markdown() const {
    std::ostringstream os;
    os << "Objects lit by " << (sources.size() == 1 ? "source " : "sources ");
    for (size_t i = 0; i < sources.size(); ++i) os << (i ? ", " : "") << sources[i];
    os << " and seen by detector " << detector << ", ranked by "
       << (rankedBy == "estimate" ? "the first-order estimate" : "lit x seen") << " (" << sourceRays
       << " source rays, " << detectorRays
       << " detector rays; shares of the emitted flux, 1 sigma)\n\n";
    os << table().markdown();
    return os.str();
}

std::string ObjectsResult::json() const {
    nlohmann::json j;
    j["detector"] = detector;
    j["ranked_by"] = rankedBy;
    j["detector_area_mm2"] = detectorAreaMm2;
    j["sources"] = sources;
    j["source_rays"] = sourceRays;
    j["detector_rays"] = detectorRays;
    j["seconds"] = seconds;
    j["objects"] = table().json();
    return j.dump(2);
}

Picture drawObjects(const PreparedScene& prepared, const ObjectsResult& result, int top) {
    const Scene& scene = prepared.scene();
    LayoutOptions lo;
    const std::string& name = prepared.geometry().prescription.system.name;
    lo.title = "Lit and seen objects, ranked" + (name.empty() ? "" : ": " + name);
    TransportView ts = prepared.transport().view;
    std::vector<Source> shown;
    for (const Source& s : ts.sources)
        if (std::find(result.sources.begin(), result.sources.end(), s.name()) !=
            result.sources.end())
            shown.push_back(s);
    lo.sources = layoutSources(shown, scene);
    lo.axisVerticesMm = layoutAxis(prepared.model());
    lo.detectors = layoutDetectors(prepared.geometry().detectors);
    Picture pic = drawLayout(scene, lo);
    std::vector<LegendEntry> legend = pic.legendEntries();

    std::vector<const ObjectRow*> ranked;
    for (const ObjectRow& r : result.rows)
        if (r.rank > 0 && r.rank <= top) ranked.push_back(&r);
    // Dark red for the first, through red and orange, to pale yellow for the last shown
    // (ColorBrewer's YlOrRd, reversed).
    const Color stops[] = {Color::hex(0x800026), Color::hex(0xe31a1c), Color::hex(0xfd8d3c),
                           Color::hex(0xfed976), Color::hex(0xffffcc)};
    constexpr int kStops = 5;
    auto colourOf = [&](size_t i) {
        const double t = ranked.size() > 1 ? double(i) / double(ranked.size() - 1) : 0.0;
        const double s = 0.9 * t * (kStops - 1);  // stop short of the palest
        const int k = std::min(kStops - 2, static_cast<int>(s));
        const double f = s - k;
        const Color a = stops[k], b = stops[k + 1];
        return Color{a.r + f * (b.r - a.r), a.g + f * (b.g - a.g), a.b + f * (b.b - a.b), 1.0};
    };
    // Drawn last first, so the first ranked lie on top; each part's number in a row below
    // the scene, with a leader from the part's lowest point (the names of the elements and
    // the sources are written above the axis).
    const Color edge = Color::hex(0x202020);
    struct Label {
        Vec2 at;
        int rank;
    };
    std::vector<Label> labels;
    for (size_t i = ranked.size(); i-- > 0;) {
        const SceneObject& o = scene.object(ranked[i]->object);
        const Color c = colourOf(i);
        std::vector<std::vector<Vec2>> pieces;
        std::vector<bool> closed;
        if (const FaceGeometry* f = std::get_if<FaceGeometry>(&o.geometry)) {
            for (const auto& piece : sectionOfFace(*f, 0.005)) {
                std::vector<Vec2> global;
                for (const Vec2& yz : piece) {
                    const Vec3 g = o.frame.toGlobalPoint(Vec3(0.0, yz.x, yz.y));
                    global.emplace_back(g.z, g.y);
                }
                pieces.push_back(std::move(global));
                closed.push_back(false);
            }
        } else {
            const MeshRef& r = std::get<MeshRef>(o.geometry);
            pieces = sliceMeshX0(scene.meshes()[static_cast<size_t>(r.mesh)], r.firstTriangle,
                                 r.triangleCount, &closed);
        }
        Vec2 lowest(0.0, 1e300);
        for (size_t k = 0; k < pieces.size(); ++k) {
            if (pieces[k].size() < 2) continue;
            if (closed[k])
                pic.polygon(pieces[k], c, edge, 0.6);
            else
                pic.polyline(pieces[k], c, 3.5);
            for (const Vec2& p : pieces[k])
                if (p.y < lowest.y) lowest = p;
        }
        if (lowest.y < 1e300) labels.push_back({lowest, ranked[i]->rank});
    }
    if (!labels.empty()) {
        const Bounds3 bounds = scene.bounds();
        const double height = pic.yMax() - pic.yMin();
        const double rowY = std::max(pic.yMin() + 0.03 * height, bounds.lo.y - 0.08 * height);
        // At least 16 pt apart along the row, pushed right in z order.
        const double gap = 16.0 * (pic.zMax() - pic.zMin()) / Picture::kPageWidthPt;
        std::sort(labels.begin(), labels.end(),
                  [](const Label& a, const Label& b) { return a.at.x < b.at.x; });
        double next = -1e300;
        for (const Label& l : labels) {
            const double z = std::max(l.at.x, next);
            next = z + gap;
            pic.polyline({l.at, Vec2(z, rowY + 0.035 * height)}, edge, 0.6);
            pic.text(z, rowY, std::to_string(l.rank), edge, 12.0, TextAnchor::Middle,
                     /*halo=*/true);
        }
    }
    for (size_t i = 0; i < ranked.size(); ++i)
        legend.push_back({std::to_string(ranked[i]->rank) + " " + ranked[i]->name,
                          LegendEntry::Swatch::Fill, colourOf(i), Color::hex(0x202020), 0.6});
    pic.legend(legend);
    return pic;
}

}  // namespace veil
