#include "tracer/render/render.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <string>

#include "geometry/exact_face.h"
#include "geometry/scene.h"
#include "lensdata/errors.h"
#include "lensdata/output_file.h"
#include "tracer/records/detector.h"
#include "tracer/render/photon_pass.h"
#include "tracer/runtime/rng.h"
#include "tracer/transport/interaction.h"

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

double renderMemoryBytes(uint64_t pixels, const RenderOptions& o, size_t criteria, size_t sources) {
    // A view point, its grid entry (a float position, its object and index), its two
    // gathering disks (5 floats each) and its two reached marks; the view point counted three
    // times, for its copies while the pass's lists are gathered and sorted. Calibrated on the
    // README's render (65536 pixels x 16 rays): peak resident memory 0.50 GB measured, 0.26 GB
    // with one ViewPoint a view point, about 0.53 GB with three.
    constexpr double kPerViewPoint = 3.0 * sizeof(ViewPoint) + 20.0 + 40.0 + 2.0;
    // The view points of one tile of the sensor (RenderOptions::tileRays) at a time.
    const uint64_t tile = static_cast<uint64_t>(
        o.tilePixels(static_cast<int>(std::min<uint64_t>(pixels, uint64_t{1} << 30))));
    const double viewPoints =
        static_cast<double>(std::min(pixels, tile)) * static_cast<double>(o.raysPerPixel);
    // Tiled, each photon's gathered light over the tiles (a double per photon of each source).
    const double perPhoton =
        tile < pixels ? 8.0 *
                            static_cast<double>(std::max(o.photonsPerPass, o.maxPhotonsPerPass) +
                                                o.partPhotons) *
                            static_cast<double>(std::max<size_t>(sources, 1))
                      : 0.0;
    // Accumulated: (components + total) per criterion and plain, the radius differences, the
    // image-forming and stray images, 3 doubles a pixel each; a pass: as many again, and the
    // photon pass's own images (6 plain, 5 per criterion, a double a pixel).
    const double c = static_cast<double>(criteria);
    const double images =
        2.0 * ((kRenderComponents + 1) * (1.0 + c) + 3.0 + c) * 24.0 + (6.0 + 5.0 * c) * 8.0;
    return viewPoints * kPerViewPoint + static_cast<double>(pixels) * images + perPhoton;
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
        double objectZ = -kInfinity, objectLowZ = kInfinity;
        forEachBoundingPoint(scene, o, [&](const Vec3& g) {
            const Vec3 p = detector.frame.toLocalPoint(g);
            objectZ = std::max(objectZ, p.z);
            objectLowZ = std::min(objectLowZ, p.z);
            radius = std::max(radius, std::hypot(p.x, p.y));
        });
        if (objectZ == -kInfinity) continue;
        // A lens element across the detector's plane: an image inside its glass
        // (endImmersedImage), where pixel rays would have to start in the medium.
        const bool glass = o.kind == ObjectKind::LensFace || o.kind == ObjectKind::LensEdge ||
                           o.kind == ObjectKind::LensFlat;
        if (glass && objectZ >= 0.0 && objectLowZ < 0.0)
            throw ModelError(detector.name,
                             "lies inside the glass of " + o.part +
                                 " (an image inside a medium): the renderer starts its pixel "
                                 "rays in air in front of the detector, and cannot render "
                                 "a detector inside a medium yet; trace this scene with "
                                 "`veil trace`, whose sources start outside the glass");
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

double defaultInitialRadius(const TransportView& ts) {
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
    radiusDifference_ = DetectorImage(geometry);
    criterionRadiusDifference_.assign(criterionSums_.size(), radiusDifference_);
    imageForming_ = DetectorImage(geometry);
    stray_ = DetectorImage(geometry);
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

void RenderState::addDifference(DetectorImage& sums,
                                const std::array<std::vector<double>, kRenderComponents>& x,
                                const std::vector<double>& half) {
    const int pixels = sums.pixelCount();
    const auto& caustic = x[static_cast<int>(RenderComponent::Caustic)];
    const auto& secondary = x[static_cast<int>(RenderComponent::Secondary)];
    RayContribution rc;
    for (int p = 0; p < pixels; ++p) {
        const size_t i = static_cast<size_t>(p);
        const double d = caustic[i] + secondary[i] - (half.empty() ? 0.0 : half[i]);
        if (d != 0.0) rc.add(p, d);
    }
    sums.add(rc);
}

RadiusBias RenderState::biasOf(const DetectorImage& sums, int passes) {
    RadiusBias b;
    if (passes < 2) return b;
    b.difference = sums.totalFlux() / passes;
    b.sigma = std::sqrt(std::max(0.0, sums.totalVariance(static_cast<uint64_t>(passes)))) / passes;
    return b;
}

RadiusBias RenderState::radiusBias() const { return biasOf(radiusDifference_, passes_); }

RadiusBias RenderState::criterionRadiusBias(int k) const {
    return biasOf(criterionRadiusDifference_.at(static_cast<size_t>(k)), passes_);
}

DetectorImage RenderState::imageForming() const {
    return imageForming_.scaled(passes_ > 0 ? 1.0 / passes_ : 0.0);
}

DetectorImage RenderState::strayLight() const {
    return stray_.scaled(passes_ > 0 ? 1.0 / passes_ : 0.0);
}

void RenderState::addImageAndStray(const RenderPass& pass) {
    const int pixels = imageForming_.pixelCount();
    RayContribution image, stray;
    for (int p = 0; p < pixels; ++p) {
        const size_t i = static_cast<size_t>(p);
        const double formed = pass.imageForming.empty() ? 0.0 : pass.imageForming[i];
        // The visible light off the designed path: the image-forming light is a part of the
        // visible light summed in another order, so what rounding leaves is dropped.
        const double visible = pass.pixels[static_cast<int>(RenderComponent::Visible)][i];
        double straySum = visible - formed;
        if (std::abs(straySum) <= 1e-12 * std::abs(visible)) straySum = 0.0;
        for (int c = 0; c < kRenderComponents; ++c)
            if (c != static_cast<int>(RenderComponent::Visible)) straySum += pass.pixels[c][i];
        if (formed != 0.0) image.add(p, formed);
        if (straySum != 0.0) stray.add(p, straySum);
    }
    imageForming_.add(image);
    stray_.add(stray);
}

void RenderState::add(const RenderPass& pass) {
    if (pass.criteria.size() != criterionSums_.size())
        throw std::invalid_argument("RenderState::add: the pass has " +
                                    std::to_string(pass.criteria.size()) + " criteria, the state " +
                                    std::to_string(criterionSums_.size()));
    addTo(sums_, pass.pixels);
    addDifference(radiusDifference_, pass.pixels, pass.gatheredHalf);
    addImageAndStray(pass);
    for (size_t k = 0; k < criterionSums_.size(); ++k) {
        addTo(criterionSums_[k], pass.criteria[k]);
        addDifference(criterionRadiusDifference_[k], pass.criteria[k],
                      k < pass.criteriaGatheredHalf.size() ? pass.criteriaGatheredHalf[k]
                                                           : std::vector<double>{});
    }
    if (!pass.learned.empty()) {
        if (learned_.empty()) learned_.assign(pass.learned.size(), 0.0);
        if (learned_.size() != pass.learned.size())
            throw std::invalid_argument("RenderState::add: the pass's guide has " +
                                        std::to_string(pass.learned.size()) + " bins, the state " +
                                        std::to_string(learned_.size()));
        for (size_t b = 0; b < learned_.size(); ++b) learned_[b] += pass.learned[b];
    }
    photonsPerPass_ = pass.nextPhotonsPerSource;
    if (pass.ghostPerSource + pass.visiblePerSource > 0)
        visibleInverseSum_ +=
            1.0 / static_cast<double>(pass.ghostPerSource + pass.visiblePerSource);
    gatheredSum_ += pass.gatheredSum;
    gatheredSquares_ += pass.gatheredSquares;
    raySum_ += pass.raySum;
    raySquares_ += pass.raySquares;
    ++passes_;
    // Knaus and Zwicker: r_{k+1}^2 = r_k^2 (k + alpha) / (k + 1), k the pass just added.
    const double k = passes_;
    radiusMm_ *= std::sqrt((k + alpha_) / (k + 1.0));
}

void RenderState::add(const RenderPass& pass, const Ranks& ranks) {
    if (ranks.root()) {
        add(pass);
    } else {
        ++passes_;  // rank 0's radius follows
    }
    shareFromRoot(ranks);
}

void RenderState::shareFromRoot(const Ranks& ranks) {
    if (ranks.single()) return;
    ByteWriter w;
    if (ranks.root()) {
        w.put(int32_t(passes_));
        w.put(radiusMm_);
        w.put(initialRadiusMm_);
        w.put(alpha_);
        w.putVector(learned_);
        w.put(photonsPerPass_);
        w.put(visiblePhotons_);
        w.put(visibleInverseSum_);
    }
    Bytes bytes = w.take();
    ranks.broadcast(bytes);
    if (ranks.root()) return;
    ByteReader r(bytes);
    passes_ = r.get<int32_t>();
    radiusMm_ = r.get<double>();
    initialRadiusMm_ = r.get<double>();
    alpha_ = r.get<double>();
    learned_ = r.getVector<double>();
    photonsPerPass_ = r.get<uint64_t>();
    visiblePhotons_ = r.get<int64_t>();
    visibleInverseSum_ = r.get<double>();
}

double RenderState::effectivePhotons() const {
    return gatheredSquares_ > 0.0 ? gatheredSum_ * gatheredSum_ / gatheredSquares_ : 0.0;
}

double RenderState::effectiveRays() const {
    return raySquares_ > 0.0 ? raySum_ * raySum_ / raySquares_ : 0.0;
}

DetectorImage RenderState::component(RenderComponent c) const {
    return sums_[static_cast<int>(c)].scaled(passes_ > 0 ? 1.0 / passes_ : 0.0);
}

DetectorImage RenderState::total() const {
    return sums_[kRenderComponents].scaled(passes_ > 0 ? 1.0 / passes_ : 0.0);
}

double standardErrorBias(uint64_t n) {
    if (n < 2) return 1.0;
    const double k = static_cast<double>(n);
    return std::sqrt(2.0 / (k - 1.0)) *
           std::exp(std::lgamma(0.5 * k) - std::lgamma(0.5 * (k - 1.0)));
}

namespace {

// Lit pixels of a mean image and the mean of their relative errors. A pixel's standard error
// from n passes, sqrt of the unbiased variance, is low on average by c4(n) (0.80 at 2 passes,
// 0.94 at 5, 0.97 at 10, for normal passes): the mean is divided by it.
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
    return {lit, lit > 0 ? sum / lit / standardErrorBias(passes) : kInfinity};
}

}  // namespace

double RenderState::meanRelativeError() const {
    if (passes_ < 2) return kInfinity;
    return litError(total(), static_cast<uint64_t>(passes_)).second;
}

double RenderState::strayMeanRelativeError() const {
    if (passes_ < 2) return kInfinity;
    return litError(strayLight(), static_cast<uint64_t>(passes_)).second;
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
    if (!radiusDifference_.sameSums(o.radiusDifference_)) return false;
    if (!imageForming_.sameSums(o.imageForming_) || !stray_.sameSums(o.stray_)) return false;
    for (size_t k = 0; k < criterionRadiusDifference_.size(); ++k)
        if (!criterionRadiusDifference_[k].sameSums(o.criterionRadiusDifference_[k])) return false;
    for (size_t k = 0; k < criterionSums_.size(); ++k)
        for (size_t i = 0; i < sums_.size(); ++i)
            if (!criterionSums_[k][i].sameSums(o.criterionSums_[k][i])) return false;
    return passes_ == o.passes_ && learned_ == o.learned_ && gatheredSum_ == o.gatheredSum_ &&
           gatheredSquares_ == o.gatheredSquares_ && raySum_ == o.raySum_ &&
           raySquares_ == o.raySquares_ && radiusMm_ == o.radiusMm_ &&
           photonsPerPass_ == o.photonsPerPass_ && visiblePhotons_ == o.visiblePhotons_ &&
           visibleInverseSum_ == o.visibleInverseSum_ && initialRadiusMm_ == o.initialRadiusMm_ &&
           alpha_ == o.alpha_;
}

namespace {

constexpr char kMagic[8] = {'V', 'E', 'I', 'L', 'R', 'N', 'D', 'R'};
// 2: the criteria's sums follow the plain ones; 3: the guide; 4: the radius differences;
// 5: the next pass's photons; 6: the photons' gathered sums; 7: the rays' sums; 8: the
// visible photons
constexpr uint32_t kVersion = 8;

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
        errno = 0;
        std::ofstream os(tmp, std::ios::binary | std::ios::trunc);
        if (!os)
            throw std::runtime_error(tmp.string() +
                                     ": cannot write the checkpoint: " + systemReason());
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
        auto putImage = [&](const DetectorImage& s) {
            putVector(os, s.fluxes());
            putVector(os, s.fluxesSquared());
            putVector(os, s.counts());
            put(os, s.totalFlux());
            put(os, s.totalFluxSquared());
            put(os, s.totalCount());
        };
        auto putSums = [&](const Sums& sums) {
            for (const DetectorImage& s : sums) putImage(s);
        };
        putSums(sums_);
        for (const Sums& sums : criterionSums_) putSums(sums);
        putImage(radiusDifference_);
        for (const DetectorImage& d : criterionRadiusDifference_) putImage(d);
        putImage(imageForming_);
        putImage(stray_);
        put(os, uint64_t(learned_.size()));
        putVector(os, learned_);
        put(os, photonsPerPass_);
        put(os, visiblePhotons_);
        put(os, visibleInverseSum_);
        put(os, gatheredSum_);
        put(os, gatheredSquares_);
        put(os, raySum_);
        put(os, raySquares_);
        os.flush();
        if (!os) {
            const std::string reason = systemReason();
            std::error_code ec;
            std::filesystem::remove(tmp, ec);
            throw std::runtime_error(tmp.string() + ": writing the checkpoint failed: " + reason);
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
    auto getImage = [&](DetectorImage& img) {
        auto flux = getVector<double>(is, n);
        auto flux2 = getVector<double>(is, n);
        auto counts = getVector<uint64_t>(is, n);
        const double t = get<double>(is), t2 = get<double>(is);
        const uint64_t tc = get<uint64_t>(is);
        if (!is) fail("the checkpoint is truncated");
        img = DetectorImage::fromSums(geometry, std::move(flux), std::move(flux2),
                                      std::move(counts), t, t2, tc);
    };
    auto getSums = [&](Sums& sums) {
        for (DetectorImage& img : sums) getImage(img);
    };
    getSums(s.sums_);
    s.criterionSums_.resize(static_cast<size_t>(criteria));
    for (Sums& sums : s.criterionSums_) getSums(sums);
    getImage(s.radiusDifference_);
    s.criterionRadiusDifference_.resize(static_cast<size_t>(criteria));
    for (DetectorImage& d : s.criterionRadiusDifference_) getImage(d);
    getImage(s.imageForming_);
    getImage(s.stray_);
    const uint64_t bins = get<uint64_t>(is);
    if (!is || bins > (uint64_t{1} << 28)) fail("the checkpoint is damaged");
    s.learned_ = getVector<double>(is, static_cast<size_t>(bins));
    s.photonsPerPass_ = get<uint64_t>(is);
    s.visiblePhotons_ = get<int64_t>(is);
    s.visibleInverseSum_ = get<double>(is);
    s.gatheredSum_ = get<double>(is);
    s.gatheredSquares_ = get<double>(is);
    s.raySum_ = get<double>(is);
    s.raySquares_ = get<double>(is);
    if (!is) fail("the checkpoint is truncated");
    if (s.passes_ < 0 || !(s.radiusMm_ > 0.0)) fail("the checkpoint is damaged");
    return s;
}

// Renderer

Renderer::Renderer(const TransportView& ts, const DetectorImage& detector, ExitAperture aperture,
                   RenderOptions options, const PathJudge* judge, Ranks ranks)
    : ts_(ts),
      detector_(detector.geometry()),
      aperture_(aperture),
      options_(options),
      judge_(judge),
      ranks_(ranks) {
    options_.check();
    if (options_.prune && !judge_)
        throw std::invalid_argument("pruning needs at least one path criterion");
    if (options_.connectThroughLens) connector_ = LensConnector(ts_, options_.ghostRoutes);
    if (connector_.any() && options_.partSamples > 0) {
        const std::vector<bool> followed =
            followedLobes(ts_, options_.followLobesBelowDeg * std::numbers::pi / 180.0);
        parts_ = PartLight(ts_, connector_, detector_.geometry().object, followed);
    }
    if (connector_.any() && options_.partPhotons > 0 && options_.splatLobesBelowDeg > 0.0) {
        const double followRad = options_.followLobesBelowDeg * std::numbers::pi / 180.0;
        const std::vector<bool> splatted =
            splattedLobes(ts_, options_.splatLobesBelowDeg * std::numbers::pi / 180.0, followRad);
        partPhotons_ = PartLight(ts_, connector_, detector_.geometry().object,
                                 followedLobes(ts_, followRad), PartMode::Photons, splatted);
    }
}

bool inGapAt(const Scene& scene, const Vec3& point, int object, int primitive, const Vec3& side,
             double gapMm) {
    return scene.closestHit({point, side}, gapMm, object, primitive).has_value();
}

namespace {

// The places around a view point v where photons of one side of its face land: on v's
// object, with its orientation (kGatherNormalCos), within `reach` of v, in v's kind of place
// (in a gap on the photons' side or not). A point of v's tangent plane is projected along the
// normal onto the face (viewPointAreaShare).
class FaceProbe {
  public:
    FaceProbe(const Scene& scene, const ViewPoint& v, bool otherSide, double gapMm)
        : scene_(scene), v_(v), gap_(gapMm), otherSide_(otherSide) {
        // The side the photons come from (the view point's own, or the other for the light
        // the face transmits to it), and a tangent basis (Duff et al. 2017).
        side_ = v.fromFront != otherSide ? v.normal : -v.normal;
        inGap_ = inGapAt(scene, v.positionMm, v.object, v.primitive, side_, gapMm);
        rays_ = 1;
        // Transmitted light leaves on the view point's side: there too a photon counts only in
        // v's kind of place (a lens's back flat half under its retainer sends its light into
        // the retainer, the open half toward the sensor).
        if (otherSide) {
            viewInGap_ = inGapAt(scene, v.positionMm, v.object, v.primitive, -side_, gapMm);
            ++rays_;
        }
        const double sign = std::copysign(1.0, side_.z);
        const double a = -1.0 / (sign + side_.z), b = side_.x * side_.y * a;
        t1_ = Vec3(1.0 + sign * side_.x * side_.x * a, sign * b, -sign * side_.x);
        t2_ = Vec3(b, sign + side_.y * side_.y * a, -side_.y);
    }
    bool inGap() const { return inGap_; }
    bool viewInGap() const { return viewInGap_; }
    // The rays it has cast so far (its cost, RenderPass::viewPointWork).
    uint64_t rays() const { return rays_; }

    // Whether the point at polar coordinates (rho, phi) of the tangent plane lands. Each probe
    // starts a gap's height off the tangent plane on the photons' side and looks along the
    // normal toward the face, then, if it missed, the other way, up to `reach`: a face that
    // curves away from the plane (a sag of rho^2 / 2R) is found below it, one that curves
    // toward it (a bore seen from inside) above. Other objects do not block a probe: it passes
    // through them, since a face is reached through a gap however thin (a lens flat under a
    // spacer 1 um away), and the last one it crossed within the gap's height of the face puts
    // the probe's point in a gap, which costs no ray of its own.
    bool lands(double rho, double phi, double reach) const {
        const double lift = std::max(gap_, std::max(1e-3 * reach, 1e-4));
        const Vec3 q =
            v_.positionMm + rho * (std::cos(phi) * t1_ + std::sin(phi) * t2_) + lift * side_;
        return along(q, -side_, lift + reach, reach, true) || along(q, side_, reach, reach, false);
    }

  private:
    bool along(Vec3 origin, const Vec3& direction, double length, double reach,
               bool towardFace) const {
        constexpr int kMaxCrossings = 8;
        int skipObject = -1, skipPrimitive = -1;
        double travelled = 0.0, crossedAt = -kInfinity;
        for (int crossing = 0; crossing <= kMaxCrossings; ++crossing) {
            ++rays_;
            const auto hit =
                scene_.closestHit({origin, direction}, length, skipObject, skipPrimitive);
            if (!hit) return false;
            if (hit->object == v_.object) {
                if (!(glm::dot(hit->normal, v_.normal) > kGatherNormalCos)) return false;
                const Vec3 d = hit->point - v_.positionMm;
                if (glm::dot(d, d) > reach * reach) return false;
                const Vec3 facing = glm::dot(hit->normal, side_) > 0.0 ? hit->normal : -hit->normal;
                if (otherSide_) {
                    ++rays_;
                    if (inGapAt(scene_, hit->point, hit->object, hit->primitive, -facing, gap_) !=
                        viewInGap_)
                        return false;
                }
                if (towardFace) return (travelled + hit->t - crossedAt <= gap_) == inGap_;
                ++rays_;
                return inGapAt(scene_, hit->point, hit->object, hit->primitive, facing, gap_) ==
                       inGap_;
            }
            origin = hit->point;
            length -= hit->t;
            travelled += hit->t;
            crossedAt = travelled;
            skipObject = hit->object;
            skipPrimitive = hit->primitive;
        }
        return false;
    }

    const Scene& scene_;
    const ViewPoint& v_;
    double gap_;
    bool otherSide_ = false;
    Vec3 side_, t1_, t2_;
    bool inGap_ = false, viewInGap_ = false;
    mutable uint64_t rays_ = 0;
};

constexpr double kGolden = 2.39996322972865332;  // pi (3 - sqrt 5)

// The share of the disk of radius r that lands: `samples` points on a Fibonacci spiral turned
// by `turn`. The outer half of the spiral first (radii above r / sqrt 2, spread around the
// circle by the golden angle): when all of it lands, the disk is taken as whole. A straight
// rim that leaves every outer probe on the face leaves the inner ones there too (with 16
// probes, averaged over the turns, the shortcut's 1 / share equals the full count's to 1e-4
// at every distance from the rim); what it would miss is a hole or a patch of another kind of
// place inside r / sqrt 2 that reaches no outer probe.
double diskShare(const FaceProbe& probe, double radiusMm, int samples, double turn) {
    int on = 0;
    const int outer = samples - samples / 2;
    for (int i = samples - 1; i >= 0; --i) {
        if (i == samples / 2 - 1 && on == outer) return 1.0;
        const double rho = radiusMm * std::sqrt((i + 0.5) / samples);
        if (probe.lands(rho, turn + kGolden * i, radiusMm)) ++on;
    }
    return static_cast<double>(std::max(on, 1)) / samples;
}

}  // namespace

DiskShare viewPointAreaShare(const Scene& scene, const ViewPoint& v, double radiusMm, int samples,
                             double turn, bool otherSide) {
    const FaceProbe probe(scene, v, otherSide, kGapFraction * radiusMm);
    DiskShare out;
    out.inGap = probe.inGap();
    out.viewInGap = probe.viewInGap();
    if (samples > 0) out.share = diskShare(probe, radiusMm, samples, turn);
    return out;
}

namespace {

// pieceWidth with the view point's probe.
double chordWidth(const FaceProbe& probe, double reachMm, double turn) {
    // How far the piece reaches from v along the half line at angle phi, to 1/256 of reach.
    auto extent = [&](double phi) {
        if (probe.lands(reachMm, phi, reachMm)) return reachMm;
        double lo = 0.0, hi = reachMm;
        for (int step = 0; step < 8; ++step) {
            const double mid = 0.5 * (lo + hi);
            (probe.lands(mid, phi, reachMm) ? lo : hi) = mid;
        }
        return std::max(lo, reachMm / 512.0);
    };
    // The second narrowest chord: a view point on a face's very rim finds no extent along the
    // line that follows the rim (its probes fall off the face on either side), and a strip's
    // second narrowest chord is at most sqrt 2 times its width.
    std::array<double, kPieceWidthLines> chords{};
    for (int j = 0; j < kPieceWidthLines; ++j) {
        const double phi = turn + std::numbers::pi * j / kPieceWidthLines;
        chords[static_cast<size_t>(j)] = extent(phi) + extent(phi + std::numbers::pi);
    }
    std::sort(chords.begin(), chords.end());
    return chords[1];
}

}  // namespace

double pieceWidth(const Scene& scene, const ViewPoint& v, double reachMm, double gapMm, double turn,
                  bool otherSide) {
    return chordWidth(FaceProbe(scene, v, otherSide, gapMm), reachMm, turn);
}

GatherDisk viewPointDisk(const Scene& scene, const ViewPoint& v, double radiusMm, int samples,
                         double turn, bool otherSide) {
    const double gap = kGapFraction * radiusMm;
    const FaceProbe probe(scene, v, otherSide, gap);
    GatherDisk out;
    out.inGap = probe.inGap();
    out.viewInGap = probe.viewInGap();
    out.radiusMm = radiusMm;
    auto done = [&] {
        out.rays = probe.rays();
        return out;
    };
    if (samples <= 0) return done();
    out.share = diskShare(probe, radiusMm, samples, turn);
    if (out.share == 1.0) return done();  // a whole disk: its half is whole too
    if (out.share < kFitShare) {
        // Extents up to 2.5 r, so that a view point on the rim of a wide face finds a chord
        // well over 2 r across it.
        const double width = chordWidth(probe, 2.5 * radiusMm, turn);
        const double fitted = std::min(radiusMm, kPieceRadiusFraction * width);
        if (fitted < radiusMm) {
            out.radiusMm = fitted;
            out.share = diskShare(probe, fitted, samples, turn);
        }
    }
    out.halfShare = diskShare(probe, 0.5 * out.radiusMm, samples, turn + 0.5 * kGolden);
    return done();
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
    bo.followLobesBelowRad = options_.followLobesBelowDeg * std::numbers::pi / 180.0;
    bo.judge = judge_;
    bo.prune = options_.prune;
    bo.ranks = ranks_;
    if (connector_.any()) bo.connector = &connector_;
    if (parts_.any()) bo.parts = &parts_;
    for (const Source& s : ts_.sources) bo.visibleSources.push_back(!photonsSeeSource(s));
    return bo;
}

uint64_t balancedPhotons(const RenderOptions& o, const RenderPass& pass) {
    const uint64_t n = pass.photonsPerSource;
    const uint64_t ghost = std::min(o.ghostPhotonsPerPass, n);
    const uint64_t most = std::max(o.maxPhotonsPerPass, ghost + kMinBalancedPhotons) - ghost;
    const uint64_t others = n - ghost;
    const uint64_t otherWork =
        pass.photonWork - std::min(pass.ghostWork + pass.visibleWork, pass.photonWork);
    double next = static_cast<double>(kMinBalancedPhotons);
    if (others > 0 && otherWork > 0) {
        // The other photons' share of the view points' work: what the ghost photons leave.
        const double room = static_cast<double>(pass.viewPointWork) -
                            static_cast<double>(pass.photonWork - otherWork);
        const double ratio = std::max(room, 0.0) / static_cast<double>(otherWork);
        next = static_cast<double>(others) * std::clamp(ratio, 0.25, 4.0);
    } else if (others > 0) {
        next = static_cast<double>(others);  // no work to weigh: as it was
    }
    next = std::clamp(std::round(next), static_cast<double>(kMinBalancedPhotons),
                      static_cast<double>(most));
    return ghost + static_cast<uint64_t>(next);
}

namespace {

// Calls f(p, mean, variance of the mean, weight) for each of the target's lit pixels (at least
// RenderState::kLitFraction of the mean pixel's light) with a variance, the weight
// 1 / (standard error x light): how the mean relative pixel error responds to that pixel's
// variance. The photon balances split that error between the parts of a pass.
template <class F>
void forEachLitPixel(const DetectorImage& target, uint64_t passes, F&& f) {
    const int pixels = target.pixelCount();
    const double threshold = RenderState::kLitFraction * target.totalFlux() / pixels;
    for (int p = 0; p < pixels; ++p) {
        const double mean = target.flux(p);
        if (!(mean > 0.0) || mean < threshold) continue;
        const double var = target.pixelVariance(p, passes);
        if (!(var > 0.0)) continue;
        f(p, var, 1.0 / (std::sqrt(var) * mean));
    }
}

}  // namespace

uint64_t balancedPhotonsByError(const RenderOptions& o, const RenderPass& pass,
                                const DetectorImage& target, const std::vector<double>& parity,
                                int passes) {
    const uint64_t byWork = balancedPhotons(o, pass);
    const uint64_t n = pass.photonsPerSource;
    const uint64_t ghost = std::min(o.ghostPhotonsPerPass, n);
    const uint64_t others = n - ghost;
    const uint64_t otherWork =
        pass.photonWork - std::min(pass.ghostWork + pass.visibleWork, pass.photonWork);
    const int pixels = target.pixelCount();
    if (passes < 2 || others == 0 || otherWork == 0 || parity.size() != static_cast<size_t>(pixels))
        return byWork;
    const auto k = static_cast<uint64_t>(passes);
    // Per pass: the variance of a pixel is passes x that of its mean; the photons' share,
    // parity^2.
    double a = 0.0, total = 0.0;
    forEachLitPixel(target, k, [&](int p, double var, double w) {
        const double d = parity[static_cast<size_t>(p)];
        a += w * d * d;
        total += w * var * static_cast<double>(k);
    });
    // The rest: what the photons leave of the spread, at least a tenth of it (one pass's
    // photon halves are a noisy measure of their share).
    const double b = std::max(total - a, 0.1 * total);
    if (!(a > 0.0) || !(b > 0.0)) return byWork;
    const double tp = static_cast<double>(otherWork);
    const double tr = static_cast<double>(pass.viewPointWork + pass.photonWork) - tp;
    if (!(tr > 0.0)) return byWork;
    // Now T_p / T_r = tp / tr; the best, sqrt(a / b): halfway there in the logarithm.
    const double step = std::sqrt(std::sqrt(a * tr / (b * tp)));
    const uint64_t most = std::max(o.maxPhotonsPerPass, ghost + kMinBalancedPhotons) - ghost;
    const double next =
        std::clamp(std::round(static_cast<double>(others) * std::clamp(step, 0.25, 4.0)),
                   static_cast<double>(kMinBalancedPhotons), static_cast<double>(most));
    return ghost + static_cast<uint64_t>(next);
}

uint64_t balancedVisiblePhotons(const RenderOptions& o, const RenderPass& pass,
                                const DetectorImage& target, const DetectorImage* visible,
                                int passes, double inverseSum) {
    const uint64_t now = pass.visiblePerSource;
    if (now == 0 || pass.visibleWork == 0) return now;
    const double most = static_cast<double>(std::max(o.maxPhotonsPerPass, kMinVisiblePhotons));
    auto within = [&](double n) {
        return static_cast<uint64_t>(
            std::clamp(std::round(n), static_cast<double>(kMinVisiblePhotons), most));
    };
    if (passes < 1 || !(inverseSum > 0.0)) return within(static_cast<double>(now));
    // One pass gives no variance: only whether the target holds visible light at all.
    if (passes < 2)
        return within(static_cast<double>(now) *
                      (visible && visible->totalFlux() != 0.0 ? 1.0 : 0.25));
    // The visible light's variance per pass at this pass's photons, over its mean's: K passes
    // of n_k photons leave (1 / K^2) sum sigma^2 / n_k; one pass of n, sigma^2 / n.
    const double n = static_cast<double>(pass.ghostPerSource + now);
    const double perPass = static_cast<double>(passes) / (n * inverseSum);
    const auto k = static_cast<uint64_t>(passes);
    double a = 0.0, b = 0.0;
    forEachLitPixel(target, k, [&](int p, double var, double w) {
        const double vis = visible ? std::clamp(visible->pixelVariance(p, k), 0.0, var) : 0.0;
        a += w * vis * perPass;
        b += w * (var - vis);
    });
    const double tv = static_cast<double>(pass.visibleWork);
    const double tr = static_cast<double>(pass.viewPointWork + pass.photonWork) - tv;
    double step = 4.0;
    if (!(a > 0.0)) {
        step = 0.25;
    } else if (b > 0.0 && tr > 0.0) {
        // Now T_v / T_r = tv / tr; the best, sqrt(a tv / (b tr)) (a and b at this split):
        // halfway there in the logarithm.
        step = std::sqrt(std::sqrt(a * tr / (b * tv)));
    }
    double next = static_cast<double>(now) * std::clamp(step, 0.25, 4.0);
    if (tr > 0.0) next = std::min(next, kMostVisibleWork * tr / tv * static_cast<double>(now));
    return within(next);
}

RenderPass Renderer::runPass(int k, double radiusMm, const std::vector<double>& learned,
                             uint64_t photonsPerSource, int64_t visiblePhotons,
                             const Deadline& deadline) const {
    if (k < 1) throw std::invalid_argument("Renderer::runPass: passes count from 1");
    if (deadline.set() && !ranks_.single())
        throw std::invalid_argument(
            "Renderer::runPass: a deadline inside a pass needs one process");
    if (!(radiusMm > 0.0)) throw std::invalid_argument("Renderer::runPass: radius must be > 0");
    RenderPass out;
    out.radiusMm = radiusMm;
    const int pixels = detector_.pixelCount();

    auto since = [](std::chrono::steady_clock::time_point t) {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    };
    // 1. Backward: visible, direct, view points.
    BackwardOptions bo = backwardOptions(k);
    bo.deadline = deadline;
    // The learned light: the aperture guide's bins, then the emission guide's, then the
    // scatter guide's (each only when on; empty before the first pass).
    auto learnedPart = [&](size_t from, size_t bins) {
        if (learned.empty()) return std::vector<double>(bins, 0.0);
        if (learned.size() < from + bins)
            throw std::invalid_argument("Renderer::runPass: " + std::to_string(learned.size()) +
                                        " learned values, fewer than the guides' bins");
        return std::vector<double>(learned.begin() + static_cast<std::ptrdiff_t>(from),
                                   learned.begin() + static_cast<std::ptrdiff_t>(from + bins));
    };
    ApertureGuide guide;
    if (options_.guideFraction > 0.0) {
        guide = ApertureGuide(detector_.geometry().pixelsX, detector_.geometry().pixelsY);
        guide.prepare(learnedPart(0, guide.bins()), options_.guideFraction);
        bo.guide = &guide;
    }
    EmissionGuide emission;
    const bool emissionGuided = options_.photonGuideFraction > 0.0;
    if (emissionGuided) {
        emission = EmissionGuide(ts_.sources.size(), detector_.geometry().pixelsX,
                                 detector_.geometry().pixelsY);
        emission.prepare(learnedPart(bo.guide ? guide.bins() : 0, emission.bins()),
                         options_.photonGuideFraction);
    }
    ScatterGuide scatter;
    const bool scatterGuided = options_.scatterGuideFraction > 0.0 || options_.weightWindow > 0.0;
    if (scatterGuided) {
        scatter = ScatterGuide(ts_.scene->bounds());
        scatter.prepare(
            learnedPart((bo.guide ? guide.bins() : 0) + (emissionGuided ? emission.bins() : 0),
                        scatter.bins()),
            options_.scatterGuideFraction, options_.weightWindow);
    }
    // 1 and 2 by tiles of the sensor (RenderOptions::tileRays): each tile's view points
    // gather the pass's photons, traced again for every tile; the backward images and sums
    // and the photon images add up over the tiles.
    RenderOptions po = options_;
    if (photonsPerSource > 0) po.photonsPerPass = photonsPerSource;
    if (visiblePhotons >= 0) po.visiblePhotonsPerPass = static_cast<uint64_t>(visiblePhotons);
    const int tile = options_.tilePixels(pixels);
    const bool tiled = tile < pixels;
    BackwardResult back;
    PhotonImages acc;
    uint64_t viewPoints = 0;
    for (int first = 0; first < pixels; first += tile) {
        const auto tb = std::chrono::steady_clock::now();
        traceBackward(ts_, detector_, aperture_, bo, first, std::min(pixels, first + tile), back);
        const auto tp = std::chrono::steady_clock::now();
        out.backwardSeconds += std::chrono::duration<double>(tp - tb).count();
        // 2. Forward photons gathered at the view points.
        const PhotonTile pt{first == 0, viewPoints, tiled};
        tracePhotons(ts_, detector_, back, po, judge_, k, radiusMm, pt, acc, ranks_,
                     connector_.any() ? &connector_ : nullptr, emissionGuided ? &emission : nullptr,
                     scatterGuided ? &scatter : nullptr,
                     partPhotons_.any() ? &partPhotons_ : nullptr, deadline);
        out.photonSeconds += since(tp);
        viewPoints += back.viewPoints.size();
    }
    if (tiled) {
        // Each photon's gathered light is its sum over the tiles.
        acc.gatheredSum = acc.gatheredSquares = 0.0;
        for (const double c : acc.perPhoton) {
            acc.gatheredSum += c;
            acc.gatheredSquares += c * c;
        }
        acc.perPhoton = {};
    }
    back.viewPoints = {};
    back.events = {};
    out.pixels[static_cast<int>(RenderComponent::Visible)] = back.visible.fluxes();
    out.pixels[static_cast<int>(RenderComponent::Direct)] = back.direct.fluxes();
    out.backwardRays = back.rays;
    out.backwardSegments = back.segments;
    out.connectionRays = back.connectionRays;
    out.viewPoints = viewPoints;
    const size_t criteria = judge_ ? static_cast<size_t>(judge_->count()) : 0;
    std::vector<double>& visible = out.pixels[static_cast<int>(RenderComponent::Visible)];
    for (int p = 0; p < pixels; ++p) visible[static_cast<size_t>(p)] += acc.visible[p];
    out.pixels[static_cast<int>(RenderComponent::Caustic)] = std::move(acc.caustic);
    out.pixels[static_cast<int>(RenderComponent::Secondary)] = std::move(acc.secondary);
    for (int p = 0; p < pixels; ++p) {
        const size_t i = static_cast<size_t>(p);
        out.pixels[static_cast<int>(RenderComponent::Caustic)][i] += back.caustic.flux(p);
        out.pixels[static_cast<int>(RenderComponent::Secondary)][i] += back.secondary.flux(p);
    }
    out.gatheredHalf = std::move(acc.gatheredHalf);
    // The light the pixel rays found behind followed lobes is not gathered: the same in both
    // estimates of the radius bias.
    for (int p = 0; p < pixels; ++p)
        out.gatheredHalf[static_cast<size_t>(p)] += back.caustic.flux(p) + back.secondary.flux(p);
    out.imageForming = back.imageForming.fluxes();
    for (int p = 0; p < pixels; ++p)
        out.imageForming[static_cast<size_t>(p)] += acc.imageForming[static_cast<size_t>(p)];
    out.photonParity = std::move(acc.parity);
    out.criteria.resize(criteria);
    out.criteriaGatheredHalf.resize(criteria);
    out.criteriaPhotonParity.resize(criteria);
    for (size_t c = 0; c < criteria; ++c) {
        auto& x = out.criteria[c];
        x[static_cast<int>(RenderComponent::Visible)] = std::move(back.visibleByCriterion[c]);
        x[static_cast<int>(RenderComponent::Direct)] = std::move(back.directByCriterion[c]);
        std::vector<double>& v = x[static_cast<int>(RenderComponent::Visible)];
        for (int p = 0; p < pixels; ++p) v[static_cast<size_t>(p)] += acc.by[c][0][p];
        x[static_cast<int>(RenderComponent::Caustic)] = std::move(acc.by[c][1]);
        x[static_cast<int>(RenderComponent::Secondary)] = std::move(acc.by[c][2]);
        for (int p = 0; p < pixels; ++p) {
            const size_t i = static_cast<size_t>(p);
            x[static_cast<int>(RenderComponent::Caustic)][i] += back.causticByCriterion[c][i];
            x[static_cast<int>(RenderComponent::Secondary)][i] += back.secondaryByCriterion[c][i];
        }
        out.criteriaGatheredHalf[c] = std::move(acc.by[c][3]);
        out.criteriaPhotonParity[c] = std::move(acc.by[c][4]);
        for (int p = 0; p < pixels; ++p) {
            const size_t i = static_cast<size_t>(p);
            out.criteriaGatheredHalf[c][i] +=
                back.causticByCriterion[c][i] + back.secondaryByCriterion[c][i];
        }
    }
    if (bo.guide) {
        out.learned = std::move(back.learned);
        for (size_t b = 0; b < out.learned.size(); ++b) out.learned[b] += acc.learned[b];
    }
    out.learned.insert(out.learned.end(), acc.emissionLearned.begin(), acc.emissionLearned.end());
    out.learned.insert(out.learned.end(), acc.scatterLearned.begin(), acc.scatterLearned.end());
    out.photons = acc.photons;
    out.gatheredSum = acc.gatheredSum;
    out.raySum = back.raySum;
    out.raySquares = back.raySquares;
    out.gatheredSquares = acc.gatheredSquares;
    out.photonSegments = acc.segments;
    out.gathers = acc.gathers;
    // The work of the two sides: the view points' (their backward segments, and one ray per
    // source and one along the sampled lobe that light them directly) and the photons'
    // (segments, gathers, the ghost photons' among them, and the probe rays that fitted the
    // gathering disks they reached: a disk is fitted when a photon first lands within it).
    out.photonsPerSource = po.photonsPerPass;
    out.viewPointWork = back.segments + viewPoints * (1 + ts_.sources.size());
    out.photonWork = acc.segments + acc.gathers + acc.diskRays;
    out.ghostWork = acc.ghostWork;
    out.ghostPerSource = po.ghostPhotons();
    out.visiblePerSource = acc.visibleWork > 0 ? po.visiblePhotonsPerPass : 0;
    out.visibleWork = acc.visibleWork;
    out.nextPhotonsPerSource = options_.balancePhotons ? balancedPhotons(options_, out) : 0;
    out.prunedPhotons = acc.pruned;
    out.prunedBranches = back.prunedBranches;
    // 3. Points on the small lit parts, traced to the pixels: caustic light, not gathered (the
    // same in both estimates of the radius bias).
    if (parts_.any()) {
        const auto t2 = std::chrono::steady_clock::now();
        const PartLight::Result lt = parts_.trace(
            detector_, options_.partSamples, passSeed(options_.seed, k, 4), judge_, options_.prune,
            ranks_, options_.partDirections, options_.partSplitByLight, deadline);
        std::vector<double>& caustic = out.pixels[static_cast<int>(RenderComponent::Caustic)];
        for (size_t i = 0; i < lt.pixels.size(); ++i) {
            caustic[i] += lt.pixels[i];
            out.gatheredHalf[i] += lt.pixels[i];
        }
        for (size_t c = 0; c < criteria; ++c)
            for (size_t i = 0; i < lt.pixels.size(); ++i) {
                out.criteria[c][static_cast<int>(RenderComponent::Caustic)][i] +=
                    lt.byCriterion[c][i];
                out.criteriaGatheredHalf[c][i] += lt.byCriterion[c][i];
            }
        out.raySum += lt.sum;
        out.raySquares += lt.squares;
        out.partSamples = lt.samples;
        out.partFound = lt.found;
        out.partRays = lt.rays;
        out.partSeconds = since(t2);
    }
    return out;
}

}  // namespace veil
