#include "tracer/render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <string>

#include "geometry/exact_face.h"
#include "lensdata/errors.h"

namespace veil {

std::string_view toString(RenderComponent c) {
    switch (c) {
        case RenderComponent::Visible:
            return "visible";
        case RenderComponent::Direct:
            return "direct";
        case RenderComponent::Caustic:
            return "caustic";
        case RenderComponent::Secondary:
            return "secondary";
    }
    return "?";
}

std::ostream& operator<<(std::ostream& os, RenderComponent c) { return os << toString(c); }

void RenderOptions::check() const {
    auto fail = [](const std::string& what) { throw std::invalid_argument(what); };
    if (raysPerPixel == 0) fail("rays per pixel must be at least 1");
    if (photonsPerPass == 0) fail("photons per pass must be at least 1");
    if (!(initialRadiusMm >= 0.0) || !std::isfinite(initialRadiusMm))
        fail("the initial radius must be a finite length >= 0 (0: automatic)");
    if (!(alpha > 0.0 && alpha < 1.0)) fail("alpha must lie in (0, 1)");
    if (!(minRelativeWeight >= 0.0 && minRelativeWeight < 1.0))
        fail("the minimum relative weight must lie in [0, 1)");
    if (!(viewPointRelativeWeight >= 0.0 && viewPointRelativeWeight <= 1.0))
        fail("the view point roulette threshold must lie in [0, 1]");
    if (maxSpecularDepth < 1) fail("the maximum specular depth must be at least 1");
    if (!(rouletteRelativeFlux >= 0.0 && rouletteRelativeFlux <= 1.0))
        fail("the roulette threshold must lie in [0, 1]");
    if (maxPhotonSegments < 1) fail("the maximum photon segments must be at least 1");
    if (!(photonMinRelativeFlux >= 0.0 && photonMinRelativeFlux < 1.0))
        fail("the photon cull threshold must lie in [0, 1)");
    if (areaSamples < 0 || areaSamples > 4096)
        fail("the area samples per view point must lie in [0, 4096]");
    if (!(detectorRadiusPixels >= 0.0 && detectorRadiusPixels <= 1000.0))
        fail("the detector smoothing radius must lie in [0, 1000] pixels");
}

std::ostream& operator<<(std::ostream& os, const RenderOptions& o) {
    return os << "RenderOptions{" << o.raysPerPixel << " rays per pixel, " << o.photonsPerPass
              << " photons per source per pass, r1 " << o.initialRadiusMm << " mm, alpha "
              << o.alpha << ", seed " << o.seed << (o.splitBackward ? ", split" : ", random")
              << ", roulette " << o.rouletteRelativeFlux << "}";
}

uint64_t passSeed(uint64_t seed, uint64_t pass, uint32_t purpose) {
    const auto b = CounterRng::philox(
        {uint32_t(pass), uint32_t(pass >> 32), purpose, 0x52454e44u /* "REND" */},
        {uint32_t(seed), uint32_t(seed >> 32)});
    return (uint64_t(b[0]) << 32) | b[1];
}

// Exit Aperture

namespace {

// Points that bound an object: mesh vertices, or the corners of an exact face's piece boxes.
template <class F>
void forEachBoundingPoint(const Scene& scene, const SceneObject& o, F&& f) {
    if (const auto* face = std::get_if<FaceGeometry>(&o.geometry)) {
        for (const Bounds3& b : facePieceBounds(*face))
            for (int c = 0; c < 8; ++c)
                f(o.frame.toGlobalPoint(Vec3(c & 1 ? b.hi.x : b.lo.x, c & 2 ? b.hi.y : b.lo.y,
                                             c & 4 ? b.hi.z : b.lo.z)));
        return;
    }
    const MeshRef& ref = std::get<MeshRef>(o.geometry);
    const TriangleMesh& m = scene.meshes()[ref.mesh];
    const size_t end =
        ref.triangleCount == 0 ? m.triangles.size() : size_t(ref.firstTriangle) + ref.triangleCount;
    for (size_t t = ref.firstTriangle; t < end; ++t)
        for (uint32_t v : m.triangles[t]) f(m.vertices[v]);
}

}  // namespace

ExitAperture exitApertureFor(const Scene& scene, const DetectorGeometry& detector) {
    // Detector-local frame: the sensitive side faces -z, the grid is centred on the axis.
    double nearestZ = -kInfinity;  // local z of the object point nearest the detector (< 0)
    double radius = 0.5 * std::hypot(detector.widthMm, detector.heightMm);
    bool any = false;
    for (const SceneObject& o : scene.objects()) {
        if (o.id == detector.object || o.kind == ObjectKind::Detector ||
            o.kind == ObjectKind::Dummy)
            continue;
        double objectZ = -kInfinity;
        forEachBoundingPoint(scene, o, [&](const Vec3& g) {
            const Vec3 p = detector.frame.toLocalPoint(g);
            objectZ = std::max(objectZ, p.z);
            radius = std::max(radius, std::hypot(p.x, p.y));
        });
        if (objectZ == -kInfinity) continue;
        if (!(objectZ < 0.0))
            throw ModelError(o.name, "lies beside or behind detector '" + detector.name + "' (" +
                                         std::to_string(objectZ) +
                                         " mm past its plane): the renderer needs every object "
                                         "in front of the detector's sensitive side");
        nearestZ = std::max(nearestZ, objectZ);
        any = true;
    }
    if (!any) throw ModelError(detector.name, "no object in front of the detector to render");
    ExitAperture a;
    a.centerMm = detector.frame.toGlobalPoint(Vec3(0.0, 0.0, nearestZ));
    a.normal = detector.normal();
    a.radiusMm = radius * (1.0 + 1e-9);
    return a;
}

double defaultInitialRadius(const TransportScene& ts) {
    const Scene& scene = *ts.scene;
    Bounds3 b;
    for (const SceneObject& o : scene.objects()) {
        if (ts.detectorOfObject[o.id] >= 0) continue;
        if (!ts.properties[ts.propertyOfObject[o.id]].hasScatter()) continue;
        forEachBoundingPoint(scene, o, [&](const Vec3& p) { b.extend(p); });
    }
    if (b.empty())
        throw ModelError("scene",
                         "no surface scatters: there is no diffuse stray light to render "
                         "(give mechanics or lens edges a property with a scatter model)");
    return 0.01 * glm::length(b.hi - b.lo);
}

// Render State

RenderState::RenderState(const DetectorGeometry& geometry, double initialRadiusMm, double alpha,
                         int criteria)
    : radiusMm_(initialRadiusMm), initialRadiusMm_(initialRadiusMm), alpha_(alpha) {
    for (DetectorImage& s : sums_) s = DetectorImage(geometry);
    criterionSums_.assign(static_cast<size_t>(std::max(criteria, 0)), sums_);
}

void RenderState::addTo(Sums& sums, const std::array<std::vector<double>, kRenderComponents>& x) {
    const int pixels = sums[0].pixelCount();
    RayContribution rc;
    std::vector<double> total(static_cast<size_t>(pixels), 0.0);
    for (int c = 0; c < kRenderComponents; ++c) {
        for (int p = 0; p < pixels; ++p) {
            if (x[c][p] == 0.0) continue;
            rc.add(p, x[c][p]);
            total[p] += x[c][p];
        }
        sums[c].add(rc);
    }
    for (int p = 0; p < pixels; ++p)
        if (total[p] != 0.0) rc.add(p, total[p]);
    sums[kRenderComponents].add(rc);
}

void RenderState::add(const RenderPass& pass) {
    if (pass.criteria.size() != criterionSums_.size())
        throw std::invalid_argument("RenderState::add: the pass has " +
                                    std::to_string(pass.criteria.size()) + " criteria, the state " +
                                    std::to_string(criterionSums_.size()));
    addTo(sums_, pass.pixels);
    for (size_t k = 0; k < criterionSums_.size(); ++k) addTo(criterionSums_[k], pass.criteria[k]);
    ++passes_;
    // Knaus and Zwicker: r_{k+1}^2 = r_k^2 (k + alpha) / (k + 1), k the pass just added.
    const double k = passes_;
    radiusMm_ *= std::sqrt((k + alpha_) / (k + 1.0));
}

DetectorImage RenderState::component(RenderComponent c) const {
    return sums_[static_cast<int>(c)].scaled(passes_ > 0 ? 1.0 / passes_ : 0.0);
}

DetectorImage RenderState::total() const {
    return sums_[kRenderComponents].scaled(passes_ > 0 ? 1.0 / passes_ : 0.0);
}

namespace {

// Lit pixels of a mean image and the mean of their relative errors.
std::pair<int, double> litError(const DetectorImage& mean, uint64_t passes) {
    const int pixels = mean.pixelCount();
    const double threshold = RenderState::kLitFraction * mean.totalFlux() / pixels;
    int lit = 0;
    double sum = 0.0;
    for (int p = 0; p < pixels; ++p) {
        const double v = mean.flux(p);
        if (!(v > 0.0) || v < threshold) continue;
        ++lit;
        sum += std::sqrt(mean.pixelVariance(p, passes)) / v;
    }
    return {lit, lit > 0 ? sum / lit : kInfinity};
}

}  // namespace

double RenderState::meanRelativeError() const {
    if (passes_ < 2) return kInfinity;
    return litError(total(), static_cast<uint64_t>(passes_)).second;
}

double RenderState::meanRelativeError(RenderComponent c) const {
    if (passes_ < 2) return kInfinity;
    return litError(component(c), static_cast<uint64_t>(passes_)).second;
}

DetectorImage RenderState::criterionComponent(int k, RenderComponent c) const {
    return criterionSums_.at(static_cast<size_t>(k))[static_cast<int>(c)].scaled(
        passes_ > 0 ? 1.0 / passes_ : 0.0);
}

DetectorImage RenderState::criterionTotal(int k) const {
    return criterionSums_.at(static_cast<size_t>(k))[kRenderComponents].scaled(
        passes_ > 0 ? 1.0 / passes_ : 0.0);
}

double RenderState::criterionMeanRelativeError(int k) const {
    if (passes_ < 2) return kInfinity;
    return litError(criterionTotal(k), static_cast<uint64_t>(passes_)).second;
}

int RenderState::litPixels() const {
    if (passes_ < 1) return 0;
    return litError(total(), static_cast<uint64_t>(passes_)).first;
}

bool RenderState::sameSums(const RenderState& o) const {
    for (size_t i = 0; i < sums_.size(); ++i)
        if (!sums_[i].sameSums(o.sums_[i])) return false;
    if (criterionSums_.size() != o.criterionSums_.size()) return false;
    for (size_t k = 0; k < criterionSums_.size(); ++k)
        for (size_t i = 0; i < sums_.size(); ++i)
            if (!criterionSums_[k][i].sameSums(o.criterionSums_[k][i])) return false;
    return passes_ == o.passes_ && radiusMm_ == o.radiusMm_ &&
           initialRadiusMm_ == o.initialRadiusMm_ && alpha_ == o.alpha_;
}

namespace {

constexpr char kMagic[8] = {'V', 'E', 'I', 'L', 'R', 'N', 'D', 'R'};
constexpr uint32_t kVersion = 2;  // 2: the criteria's sums follow the plain ones

template <class T>
void put(std::ostream& os, const T& v) {
    os.write(reinterpret_cast<const char*>(&v), sizeof(T));
}
template <class T>
void putVector(std::ostream& os, const std::vector<T>& v) {
    os.write(reinterpret_cast<const char*>(v.data()), std::streamsize(v.size() * sizeof(T)));
}
template <class T>
T get(std::istream& is) {
    T v{};
    is.read(reinterpret_cast<char*>(&v), sizeof(T));
    return v;
}
template <class T>
std::vector<T> getVector(std::istream& is, size_t n) {
    std::vector<T> v(n);
    is.read(reinterpret_cast<char*>(v.data()), std::streamsize(n * sizeof(T)));
    return v;
}

}  // namespace

void RenderState::write(const std::filesystem::path& path, uint64_t fingerprint) const {
    const std::filesystem::path tmp = path.string() + ".tmp";
    {
        std::ofstream os(tmp, std::ios::binary | std::ios::trunc);
        if (!os) throw std::runtime_error(tmp.string() + ": cannot write the checkpoint");
        os.write(kMagic, sizeof kMagic);
        put(os, kVersion);
        put(os, fingerprint);
        put(os, int32_t(sums_[0].pixelsX()));
        put(os, int32_t(sums_[0].pixelsY()));
        put(os, int32_t(passes_));
        put(os, radiusMm_);
        put(os, initialRadiusMm_);
        put(os, alpha_);
        put(os, int32_t(criterionSums_.size()));
        auto putSums = [&](const Sums& sums) {
            for (const DetectorImage& s : sums) {
                putVector(os, s.fluxes());
                putVector(os, s.fluxesSquared());
                putVector(os, s.counts());
                put(os, s.totalFlux());
                put(os, s.totalFluxSquared());
                put(os, s.totalCount());
            }
        };
        putSums(sums_);
        for (const Sums& sums : criterionSums_) putSums(sums);
        os.flush();
        if (!os) {
            std::error_code ec;
            std::filesystem::remove(tmp, ec);
            throw std::runtime_error(tmp.string() + ": writing the checkpoint failed");
        }
    }
    std::error_code ec;
    std::filesystem::rename(tmp, path, ec);
    if (ec) {
        std::filesystem::remove(tmp, ec);
        throw std::runtime_error(path.string() + ": cannot move the checkpoint into place");
    }
}

RenderState RenderState::read(const std::filesystem::path& path, uint64_t fingerprint,
                              const DetectorGeometry& geometry) {
    std::ifstream is(path, std::ios::binary);
    if (!is) throw std::runtime_error(path.string() + ": cannot read the checkpoint");
    auto fail = [&](const std::string& why) {
        throw std::runtime_error(path.string() + ": " + why);
    };
    char magic[sizeof kMagic];
    is.read(magic, sizeof magic);
    if (!is || std::memcmp(magic, kMagic, sizeof kMagic) != 0) fail("not a veil render checkpoint");
    if (get<uint32_t>(is) != kVersion) fail("a checkpoint of another veil version");
    if (get<uint64_t>(is) != fingerprint)
        fail(
            "the checkpoint belongs to another scene or other render options (seed, rays per "
            "pixel, photons, radius, alpha, roulette, criteria must match)");
    const int32_t nx = get<int32_t>(is), ny = get<int32_t>(is);
    if (nx != geometry.pixelsX || ny != geometry.pixelsY)
        fail("the checkpoint's detector grid differs from the scene's");
    RenderState s;
    s.passes_ = get<int32_t>(is);
    s.radiusMm_ = get<double>(is);
    s.initialRadiusMm_ = get<double>(is);
    s.alpha_ = get<double>(is);
    const int32_t criteria = get<int32_t>(is);
    if (!is || criteria < 0 || criteria > 64) fail("the checkpoint is damaged");
    const size_t n = static_cast<size_t>(geometry.pixelCount());
    auto getSums = [&](Sums& sums) {
        for (DetectorImage& img : sums) {
            auto flux = getVector<double>(is, n);
            auto flux2 = getVector<double>(is, n);
            auto counts = getVector<uint64_t>(is, n);
            const double t = get<double>(is), t2 = get<double>(is);
            const uint64_t tc = get<uint64_t>(is);
            if (!is) fail("the checkpoint is truncated");
            img = DetectorImage::fromSums(geometry, std::move(flux), std::move(flux2),
                                          std::move(counts), t, t2, tc);
        }
    };
    getSums(s.sums_);
    s.criterionSums_.resize(static_cast<size_t>(criteria));
    for (Sums& sums : s.criterionSums_) getSums(sums);
    if (s.passes_ < 0 || !(s.radiusMm_ > 0.0)) fail("the checkpoint is damaged");
    return s;
}

// Renderer

Renderer::Renderer(const TransportScene& ts, const DetectorImage& detector, ExitAperture aperture,
                   RenderOptions options, const PathJudge* judge)
    : ts_(ts),
      detector_(detector.geometry()),
      aperture_(aperture),
      options_(options),
      judge_(judge) {
    options_.check();
    if (options_.prune && !judge_)
        throw std::invalid_argument("pruning needs at least one path criterion");
}

namespace {

// View points in a uniform grid of cells of size 2r, each stored in every cell its sphere
// overlaps (at most 8), in compressed rows: a photon looks in its own cell only.
class ViewPointGrid {
  public:
    ViewPointGrid(const std::vector<ViewPoint>& vps, double radiusMm) : r_(radiusMm) {
        cell_ = 2.0 * radiusMm;
        size_t want = 1;
        while (want < 2 * vps.size() + 16) want <<= 1;
        mask_ = want - 1;
        start_.assign(want + 1, 0);
        // Count, prefix, fill.
        auto eachCell = [&](const ViewPoint& v, auto&& f) {
            int64_t lo[3], hi[3];
            for (int a = 0; a < 3; ++a) {
                lo[a] = cellIndex(v.positionMm[a] - r_);
                hi[a] = cellIndex(v.positionMm[a] + r_);
            }
            for (int64_t x = lo[0]; x <= hi[0]; ++x)
                for (int64_t y = lo[1]; y <= hi[1]; ++y)
                    for (int64_t z = lo[2]; z <= hi[2]; ++z) f(bucket(x, y, z));
        };
        for (const ViewPoint& v : vps) eachCell(v, [&](size_t b) { ++start_[b + 1]; });
        for (size_t b = 0; b < want; ++b) start_[b + 1] += start_[b];
        entries_.resize(start_[want]);
        std::vector<uint32_t> fill(start_.begin(), start_.end() - 1);
        for (size_t i = 0; i < vps.size(); ++i)
            eachCell(vps[i], [&](size_t b) { entries_[fill[b]++] = static_cast<uint32_t>(i); });
    }
    // The view points whose cells hash to p's bucket (a superset of those within r).
    std::pair<const uint32_t*, const uint32_t*> candidates(const Vec3& p) const {
        const size_t b = bucket(cellIndex(p.x), cellIndex(p.y), cellIndex(p.z));
        return {entries_.data() + start_[b], entries_.data() + start_[b + 1]};
    }

  private:
    int64_t cellIndex(double x) const { return static_cast<int64_t>(std::floor(x / cell_)); }
    size_t bucket(int64_t x, int64_t y, int64_t z) const {
        const uint64_t h =
            uint64_t(x) * 73856093u ^ uint64_t(y) * 19349663u ^ uint64_t(z) * 83492791u;
        return static_cast<size_t>((h ^ (h >> 29)) & mask_);
    }
    double r_ = 0.0, cell_ = 1.0;
    size_t mask_ = 0;
    std::vector<uint32_t> start_;
    std::vector<uint32_t> entries_;
};

struct PhotonAccumulator {
    std::vector<double> visible, caustic, secondary;
    // With criteria: [criterion] {visible, caustic, secondary}.
    std::vector<std::array<std::vector<double>, 3>> by;
    uint64_t photons = 0, segments = 0, gathers = 0, pruned = 0;
};

struct PhotonBranch {
    Ray ray;
    double flux = 0.0;
    int medium = 0, startObject = -1, startPrimitive = -1;
    bool specular = false, scattered = false;  // the events it has seen
    int segments = 0;
    size_t state = 0;               // with criteria: its path state's offset in the photon's arena
    uint64_t alive = ~uint64_t{0};  // criteria its path may still match
};

}  // namespace

double viewPointAreaShare(const Scene& scene, const ViewPoint& v, double radiusMm, int samples,
                          double turn) {
    if (samples <= 0) return 1.0;
    // The side the view point was seen from, and a tangent basis (Duff et al. 2017).
    const Vec3 side = v.fromFront ? v.normal : -v.normal;
    const double sign = std::copysign(1.0, side.z);
    const double a = -1.0 / (sign + side.z), b = side.x * side.y * a;
    const Vec3 t1(1.0 + sign * side.x * side.x * a, sign * b, -sign * side.x);
    const Vec3 t2(b, sign + side.y * side.y * a, -side.y);
    // Each probe starts just off the tangent plane (a hair on the view point's side, so a flat
    // face is met ahead of the ray) and looks along the normal both ways, up to r: a face that
    // curves away from the plane (a sag of rho^2 / 2R) is found below it, one that curves
    // toward it (a bore seen from inside) above. Only the view point's object, with its
    // orientation and within r of it, counts; anything else met first blocks the probe.
    const double hair = std::max(1e-3 * radiusMm, 1e-4);
    constexpr double kGolden = 2.39996322972865332;  // pi (3 - sqrt 5)
    auto lands = [&](const std::optional<SceneHit>& hit) {
        if (!hit || hit->object != v.object) return false;
        if (!(glm::dot(hit->normal, v.normal) > 0.0)) return false;
        const Vec3 d = hit->point - v.positionMm;
        return glm::dot(d, d) <= radiusMm * radiusMm;
    };
    int on = 0;
    for (int i = 0; i < samples; ++i) {
        const double rho = radiusMm * std::sqrt((i + 0.5) / samples);
        const double phi = turn + kGolden * i;
        const Vec3 q = v.positionMm + rho * (std::cos(phi) * t1 + std::sin(phi) * t2) + hair * side;
        if (lands(scene.closestHit({q, -side}, hair + radiusMm)) ||
            lands(scene.closestHit({q, side}, radiusMm)))
            ++on;
    }
    return static_cast<double>(std::max(on, 1)) / samples;
}

bool photonsSeeSource(const Source& s) {
    return s.delta() != Source::Delta::None || std::holds_alternative<SunSource>(s.shape());
}

BackwardOptions Renderer::backwardOptions(int k) const {
    BackwardOptions bo;
    bo.raysPerPixel = options_.raysPerPixel;
    bo.seed = passSeed(options_.seed, static_cast<uint64_t>(k), 0);
    bo.split = options_.splitBackward;
    bo.maxSpecularDepth = options_.maxSpecularDepth;
    bo.minRelativeWeight = options_.minRelativeWeight;
    bo.direct = true;
    bo.viewPointRelativeWeight = options_.viewPointRelativeWeight;
    bo.judge = judge_;
    bo.prune = options_.prune;
    for (const Source& s : ts_.sources) bo.visibleSources.push_back(!photonsSeeSource(s));
    return bo;
}

RenderPass Renderer::runPass(int k, double radiusMm) const {
    if (k < 1) throw std::invalid_argument("Renderer::runPass: passes count from 1");
    if (!(radiusMm > 0.0)) throw std::invalid_argument("Renderer::runPass: radius must be > 0");
    RenderPass out;
    out.radiusMm = radiusMm;
    const int pixels = detector_.pixelCount();

    const auto t0 = std::chrono::steady_clock::now();
    auto since = [](std::chrono::steady_clock::time_point t) {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    };
    // 1. Backward: visible, direct, view points.
    const BackwardOptions bo = backwardOptions(k);
    BackwardResult back = traceBackward(ts_, detector_, aperture_, bo);
    out.pixels[static_cast<int>(RenderComponent::Visible)] = back.visible.fluxes();
    out.pixels[static_cast<int>(RenderComponent::Direct)] = back.direct.fluxes();
    out.backwardRays = back.rays;
    out.backwardSegments = back.segments;
    out.viewPoints = back.viewPoints.size();

    out.backwardSeconds = since(t0);
    const auto t1 = std::chrono::steady_clock::now();
    // 2. Forward photons gathered at the view points.
    const std::vector<ViewPoint>& vps = back.viewPoints;
    const ViewPointGrid grid(vps, radiusMm);
    const double r2 = radiusMm * radiusMm;
    const double kernel = 1.0 / (std::numbers::pi * r2);
    // The rim correction, computed the first time a view point gathers: 1 / its area share.
    // The value depends on the view point alone (the spiral turned by its index), so threads
    // racing on it write the same bits.
    std::vector<std::atomic<float>> inverseShare(vps.size());
    for (auto& x : inverseShare) x.store(0.0f, std::memory_order_relaxed);
    auto areaCorrection = [&](uint32_t i) {
        float c = inverseShare[i].load(std::memory_order_relaxed);
        if (c == 0.0f) {
            const double turn =
                2.0 * std::numbers::pi * CounterRng(passSeed(options_.seed, k, 2), i).uniform();
            c = static_cast<float>(
                1.0 / viewPointAreaShare(*ts_.scene, vps[i], radiusMm, options_.areaSamples, turn));
            inverseShare[i].store(c, std::memory_order_relaxed);
        }
        return static_cast<double>(c);
    };
    const uint64_t perSource = options_.photonsPerPass;
    const uint64_t total = perSource * ts_.sources.size();
    const uint64_t photonSeed = passSeed(options_.seed, static_cast<uint64_t>(k), 1);
    const Scene& scene = *ts_.scene;
    const MediaOptics& media = *ts_.media;
    const uint64_t block = 4096;

    const int renderedObject = detector_.geometry().object;
    const DetectorImage& grid0 = detector_;
    // The detector's smoothing disk this pass (mm), shrinking with the gathering radius.
    const DetectorGeometry& dg = grid0.geometry();
    const double rho = options_.detectorRadiusPixels *
                       std::max(dg.pixelWidthMm(), dg.pixelHeightMm()) *
                       (options_.initialRadiusMm > 0.0 ? radiusMm / options_.initialRadiusMm : 1.0);
    // The pixels that share a deposit landing at `point`: those whose centres lie within rho
    // (its own pixel alone when none does); none when it misses the grid.
    auto splatCells = [&](const Vec3& point, std::vector<int>& cells) {
        cells.clear();
        const auto own = grid0.pixelOf(point);
        if (!own) return;
        if (rho > 0.0) {
            const Vec3 local = dg.frame.toLocalPoint(point);
            const double pw = dg.pixelWidthMm(), ph = dg.pixelHeightMm();
            const int c0 = std::max(0, int(std::floor((local.x - rho + 0.5 * dg.widthMm) / pw)));
            const int c1 =
                std::min(dg.pixelsX - 1, int(std::floor((local.x + rho + 0.5 * dg.widthMm) / pw)));
            const int r0 = std::max(0, int(std::floor((0.5 * dg.heightMm - local.y - rho) / ph)));
            const int r1 =
                std::min(dg.pixelsY - 1, int(std::floor((0.5 * dg.heightMm - local.y + rho) / ph)));
            for (int row = r0; row <= r1; ++row)
                for (int col = c0; col <= c1; ++col) {
                    const int p = grid0.pixelIndex(col, row);
                    const Vec2 c = grid0.pixelCentreLocal(p);
                    const double dx = c.x - local.x, dy = c.y - local.y;
                    if (dx * dx + dy * dy <= rho * rho) cells.push_back(p);
                }
        }
        if (cells.empty()) cells.push_back(*own);
    };
    auto splat = [](std::vector<double>& image, const std::vector<int>& cells, double flux) {
        const double share = flux / static_cast<double>(cells.size());
        for (int p : cells) image[static_cast<size_t>(p)] += share;
    };
    // Criteria: photon prefixes stream through the judge; a gather or a deposit judges the
    // joined path (the photon's events, its scatter at the view point, the view point's
    // backward events; or the detector hit).
    const PathJudge* judge = judge_;
    const size_t criteria = judge ? static_cast<size_t>(judge->count()) : 0;
    const bool prune = judge && options_.prune;
    const size_t stateBytes = judge ? judge->stateBytes() : 0;
    const std::vector<PathEvent>& vpEvents = back.events;

    PhotonAccumulator identity;
    identity.visible.assign(static_cast<size_t>(pixels), 0.0);
    identity.caustic.assign(static_cast<size_t>(pixels), 0.0);
    identity.secondary.assign(static_cast<size_t>(pixels), 0.0);
    identity.by.assign(criteria, {identity.visible, identity.caustic, identity.secondary});
    PhotonAccumulator acc = tbb::parallel_deterministic_reduce(
        tbb::blocked_range<uint64_t>(0, total, block), identity,
        [&](const tbb::blocked_range<uint64_t>& r, PhotonAccumulator a) {
            std::vector<PhotonBranch> stack;
            std::vector<int> cells;
            std::vector<std::byte> states, scratch(stateBytes);  // states: per branch
            std::vector<PathEvent> suffix;
            // Adds `value` to image slot `slot` (0 visible, 1 caustic, 2 secondary) of the
            // plain accumulator unless pruning drops it, and of every criterion matched.
            auto book = [&](int slot, uint64_t matched, const std::vector<int>* spread, int pixel,
                            double value) {
                auto into = [&](std::vector<double>& image) {
                    if (spread)
                        splat(image, *spread, value);
                    else
                        image[static_cast<size_t>(pixel)] += value;
                };
                std::vector<double>* plain[3] = {&a.visible, &a.caustic, &a.secondary};
                if (!prune || matched != 0) into(*plain[slot]);
                for (uint64_t m = matched; m != 0; m &= m - 1)
                    into(a.by[static_cast<size_t>(std::countr_zero(m))][static_cast<size_t>(slot)]);
            };
            for (uint64_t i = r.begin(); i < r.end(); ++i) {
                const size_t sourceIndex = i / perSource;
                const Source& source = ts_.sources[sourceIndex];
                const bool deposits = photonsSeeSource(source);
                CounterRng rng(photonSeed, i);
                const EmittedRay e = source.emit(rng, perSource);
                ++a.photons;
                if (!(e.flux > 0.0)) continue;
                const int w = e.wavelength;
                const double rouletteFlux = options_.rouletteRelativeFlux * e.flux;
                const double cullFlux = options_.photonMinRelativeFlux * e.flux;
                stack.clear();
                PhotonBranch first{e.ray, e.flux, 0, -1, -1, false, false, 0};
                if (judge) {
                    states.assign(stateBytes, std::byte{0});
                    judge->reset(states.data());
                    first.alive = judge->push(
                        states.data(),
                        pathEvent(EventType::Emit, static_cast<int>(sourceIndex), 0, 0, 0));
                    if (prune && first.alive == 0) {
                        ++a.pruned;
                        continue;
                    }
                }
                stack.push_back(first);
                while (!stack.empty()) {
                    PhotonBranch br = stack.back();
                    stack.pop_back();
                    // The criteria a path of this branch's events and `suffix` matches.
                    auto judged = [&] {
                        if (br.alive == 0) return uint64_t{0};
                        return judge->matches(states.data() + br.state, suffix, scratch.data());
                    };
                    for (; br.segments < options_.maxPhotonSegments; ++br.segments) {
                        const auto hit =
                            scene.closestHit(br.ray, kInfinity, br.startObject, br.startPrimitive);
                        ++a.segments;
                        if (!hit) break;
                        const double alpha = media.absorptionPerMm(br.medium, w);
                        if (alpha > 0.0) br.flux *= std::exp(-alpha * hit->t);
                        if (ts_.detectorOfObject[hit->object] >= 0) {
                            // Light that scattered nowhere lands here: the visible component
                            // of the sources the photons stand for.
                            if (deposits && !br.scattered && hit->object == renderedObject) {
                                splatCells(hit->point, cells);
                                if (cells.empty()) break;
                                uint64_t matched = 0;
                                if (judge) {
                                    suffix.assign(1,
                                                  pathEvent(EventType::DetectorHit, hit->object,
                                                            hit->primitive, br.medium, br.medium));
                                    matched = judged();
                                }
                                book(0, matched, &cells, 0, br.flux);
                            }
                            break;
                        }
                        const Interaction in = interact(ts_, *hit, br.ray.direction, w,
                                                        e.wavelengthNm, TransportMode::Flux);
                        bool scatters = false;
                        for (int c = 0; c < in.count; ++c) scatters |= in.children[c].scatter;
                        if (scatters && (br.specular || br.scattered)) {
                            const int slot = br.scattered ? 2 : 1;
                            const auto [firstVp, lastVp] = grid.candidates(hit->point);
                            for (const uint32_t* it = firstVp; it != lastVp; ++it) {
                                const ViewPoint& v = vps[*it];
                                if (v.object != hit->object || v.wavelength != w) continue;
                                if (!(glm::dot(v.normal, hit->normal) > 0.0)) continue;
                                const Vec3 d = v.positionMm - hit->point;
                                if (glm::dot(d, d) > r2) continue;
                                const double f = in.property->bsdf(in.context, v.toDetector);
                                if (!(f > 0.0)) continue;
                                ++a.gathers;
                                uint64_t matched = 0;
                                if (judge && br.alive != 0) {
                                    // The photon's scatter here toward the view point's pixel.
                                    const bool back = glm::dot(br.ray.direction, hit->normal) *
                                                          glm::dot(v.toDetector, hit->normal) <
                                                      0.0;
                                    suffix.assign(1, pathEvent(back ? EventType::ScatterReflect
                                                                    : EventType::ScatterTransmit,
                                                               hit->object, hit->primitive,
                                                               br.medium, v.medium));
                                    suffix.insert(suffix.end(), vpEvents.begin() + v.firstEvent,
                                                  vpEvents.begin() + v.firstEvent + v.eventCount);
                                    matched = judged();
                                }
                                book(slot, matched, nullptr, v.pixel,
                                     v.weight * br.flux * f * kernel * areaCorrection(*it));
                            }
                        }
                        if (in.count == 0) break;
                        // Continue as child c with flux `flux`; false when it has no direction
                        // or no criterion can match its path any more (prune).
                        auto become = [&](PhotonBranch& b, int c, double flux) {
                            const auto dir = in.direction(c, rng);
                            if (!dir) return false;
                            const InteractionChild& child = in.children[c];
                            if (judge && b.alive != 0) {
                                b.alive =
                                    judge->push(states.data() + b.state,
                                                pathEvent(child.event, hit->object, hit->primitive,
                                                          b.medium, child.medium));
                            }
                            if (prune && b.alive == 0) {
                                ++a.pruned;
                                return false;
                            }
                            (child.scatter ? b.scattered : b.specular) = true;
                            b.flux = flux;
                            b.ray = {hit->point, *dir};
                            b.medium = child.medium;
                            b.startObject = hit->object;
                            b.startPrimitive = hit->primitive;
                            return true;
                        };
                        int c = 0;
                        double flux = 0.0;
                        if (!br.scattered && in.count > 1) {
                            // Before the first scatter every child is followed (the ghosts live
                            // in the weak reflected branches); then one child by weight.
                            for (int k = in.count - 1; k >= 1; --k) {
                                const double f = br.flux * in.children[k].share;
                                if (f < cullFlux) continue;
                                PhotonBranch child = br;
                                child.segments = br.segments + 1;
                                if (judge) {  // its own copy of the path state
                                    child.state = states.size();
                                    states.resize(states.size() + stateBytes);
                                    std::memcpy(states.data() + child.state,
                                                states.data() + br.state, stateBytes);
                                }
                                if (become(child, k, f)) stack.push_back(child);
                            }
                            c = 0;
                            flux = br.flux * in.children[0].share;
                            if (flux < cullFlux) break;
                        } else {
                            c = in.count > 1 ? chooseChild(in, rng.uniform()) : 0;
                            flux = br.flux * in.total;
                        }
                        if (!become(br, c, flux)) break;
                        if (rouletteFlux > 0.0 && br.flux < rouletteFlux) {
                            if (rng.uniform() * rouletteFlux < br.flux)
                                br.flux = rouletteFlux;
                            else
                                break;
                        }
                    }
                }
            }
            return a;
        },
        [](PhotonAccumulator a, const PhotonAccumulator& b) {
            auto addInto = [](std::vector<double>& x, const std::vector<double>& y) {
                for (size_t p = 0; p < x.size(); ++p) x[p] += y[p];
            };
            addInto(a.visible, b.visible);
            addInto(a.caustic, b.caustic);
            addInto(a.secondary, b.secondary);
            for (size_t k = 0; k < a.by.size(); ++k)
                for (size_t s = 0; s < 3; ++s) addInto(a.by[k][s], b.by[k][s]);
            a.photons += b.photons;
            a.segments += b.segments;
            a.gathers += b.gathers;
            a.pruned += b.pruned;
            return a;
        });
    std::vector<double>& visible = out.pixels[static_cast<int>(RenderComponent::Visible)];
    for (int p = 0; p < pixels; ++p) visible[static_cast<size_t>(p)] += acc.visible[p];
    out.pixels[static_cast<int>(RenderComponent::Caustic)] = std::move(acc.caustic);
    out.pixels[static_cast<int>(RenderComponent::Secondary)] = std::move(acc.secondary);
    out.criteria.resize(criteria);
    for (size_t k = 0; k < criteria; ++k) {
        auto& x = out.criteria[k];
        x[static_cast<int>(RenderComponent::Visible)] = std::move(back.visibleByCriterion[k]);
        x[static_cast<int>(RenderComponent::Direct)] = std::move(back.directByCriterion[k]);
        std::vector<double>& v = x[static_cast<int>(RenderComponent::Visible)];
        for (int p = 0; p < pixels; ++p) v[static_cast<size_t>(p)] += acc.by[k][0][p];
        x[static_cast<int>(RenderComponent::Caustic)] = std::move(acc.by[k][1]);
        x[static_cast<int>(RenderComponent::Secondary)] = std::move(acc.by[k][2]);
    }
    out.photons = acc.photons;
    out.photonSegments = acc.segments;
    out.gathers = acc.gathers;
    out.prunedPhotons = acc.pruned;
    out.prunedBranches = back.prunedBranches;
    out.photonSeconds = since(t1);
    return out;
}

}  // namespace veil
