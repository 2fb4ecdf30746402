#include "tracer/records/detector.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <stdexcept>

#include "geometry/scene.h"
#include "lensdata/toml_document.h"
#include "tracer/runtime/rng.h"

namespace veil {

namespace {

constexpr int kDefaultPixelsLongSide = 256;
constexpr int kMaxPixelsPerSide = 16384;

// [a, b] of two numbers in `range`.
Vec2 readPair(const TomlValue& v, const NumberRange& range, std::string_view what) {
    if (!v.isArray()) v.failExpected(what);
    const std::vector<TomlValue> items = v.asArray();
    if (items.size() != 2) v.failExpected(what);
    return Vec2(items[0].asNumber(range), items[1].asNumber(range));
}

DetectorSpec readOne(const TomlTable& t) {
    DetectorSpec s;
    s.loc = t.loc();
    s.nameLoc = s.loc;
    s.objectLoc = s.loc;
    if (const std::optional<TomlValue> name = t.get("name")) {
        s.name = name->asString();
        s.nameLoc = name->loc();
        if (s.name.empty()) name->fail(name->path() + " must not be empty");
    }
    if (const std::optional<TomlValue> size = t.get("size_mm"))
        s.sizeMm = readPair(*size, NumberRange{0.0, kMaxDetectorSizeMm, true, false},
                            "a pair [width, height] of numbers");
    if (const std::optional<TomlValue> pixels = t.get("pixels")) {
        if (!pixels->isArray() || pixels->asArray().size() != 2)
            pixels->failExpected("a pair [columns, rows] of integers");
        const std::vector<TomlValue> n = pixels->asArray();
        const NumberRange range = NumberRange::between(1, kMaxPixelsPerSide);
        s.pixelsX = static_cast<int>(n[0].asInteger(range));
        s.pixelsY = static_cast<int>(n[1].asInteger(range));
        if (int64_t(s.pixelsX) * s.pixelsY > kMaxDetectorPixels)
            pixels->fail(pixels->path() + " asks for " +
                         std::to_string(int64_t(s.pixelsX) * s.pixelsY) + " pixels (at most " +
                         std::to_string(kMaxDetectorPixels) + ")");
    }
    if (const std::optional<TomlValue> center = t.get("center_mm"))
        s.centerMm = readPair(*center, NumberRange::any(), "a pair [x, y] of numbers");
    const std::optional<TomlValue> z = t.get("z_mm");
    if (z) s.zMm = z->asNumber();
    if (const std::optional<TomlValue> object = t.get("object")) {
        s.object = object->asString();
        s.objectLoc = object->loc();
        if (s.object.empty()) object->fail(object->path() + " must not be empty");
        if (z)
            z->fail("a detector with object = '" + s.object +
                    "' lies on that object; z_mm places a free detector (give one of them)");
    }
    if (s.zMm) {
        if (s.name.empty())
            t.fail("missing key 'name' in " + t.displayName() +
                   " (a free detector placed with z_mm needs a name)");
        if (!s.sizeMm)
            t.fail("missing key 'size_mm' in " + t.displayName() +
                   " (a free detector placed with z_mm needs its [width, height] in mm)");
    }
    return s;
}

// The box of a face's aperture, full width and height (mm); nullopt when there is none.
std::optional<Vec2> apertureBox(const SceneObject& o) {
    const FaceGeometry* face = std::get_if<FaceGeometry>(&o.geometry);
    if (!face) return std::nullopt;
    const SurfacePatch* patch = std::get_if<SurfacePatch>(face);
    if (!patch) return std::nullopt;
    if (const auto* r = std::get_if<RectangularAperture>(&patch->aperture))
        return Vec2(2.0 * r->halfWidthMm, 2.0 * r->halfHeightMm);
    const double d = 2.0 * apertureBoundingRadius(patch->aperture);
    return Vec2(d, d);
}

void defaultPixels(DetectorGeometry& g, int nx, int ny) {
    if (nx > 0 && ny > 0) {
        g.pixelsX = nx;
        g.pixelsY = ny;
        return;
    }
    const double longSide = std::max(g.widthMm, g.heightMm);
    auto along = [&](double side) {
        return std::max(1, static_cast<int>(std::lround(kDefaultPixelsLongSide * side / longSide)));
    };
    g.pixelsX = along(g.widthMm);
    g.pixelsY = along(g.heightMm);
}

// Pixels much wider than high (or the reverse) make no image a reader can show, and OpenEXR
// refuses their aspect ratio only when the image is written, after the whole trace.
void requireSquarishPixels(const DetectorGeometry& g, const DetectorSpec& spec) {
    const double aspect = (g.widthMm / g.pixelsX) / (g.heightMm / g.pixelsY);
    if (aspect >= 1.0 / kMaxPixelAspect && aspect <= kMaxPixelAspect) return;
    std::ostringstream m;
    m << "detector '" << g.name << "': its pixels are " << g.widthMm / g.pixelsX << " x "
      << g.heightMm / g.pixelsY << " mm (size_mm " << g.widthMm << " x " << g.heightMm << " over "
      << g.pixelsX << " x " << g.pixelsY << " pixels), " << std::max(aspect, 1.0 / aspect)
      << " times longer one way than the other; at most " << kMaxPixelAspect
      << ": give size_mm closer to the pixels' shape, or pixels";
    throw ParseError(spec.loc, m.str());
}

}  // namespace

std::ostream& operator<<(std::ostream& os, const DetectorSpec& s) {
    os << "DetectorSpec{name '" << s.name << "', size ";
    if (s.sizeMm)
        os << *s.sizeMm << " mm";
    else
        os << "from the object";
    os << ", pixels " << s.pixelsX << " x " << s.pixelsY << ", centre " << s.centerMm << " mm, ";
    if (s.zMm)
        os << "free at z " << *s.zMm << " mm";
    else
        os << "on '" << (s.object.empty() ? std::string("sensor") : s.object) << "'";
    return os << "}";
}

std::vector<DetectorSpec> readDetectors(TomlDocument& doc) {
    std::vector<DetectorSpec> specs;
    const std::optional<TomlValue> entry = doc.root().get("detector");
    if (!entry) return specs;
    if (entry->isTable()) {
        specs.push_back(readOne(entry->asTable()));
    } else if (entry->isArray()) {
        for (const TomlValue& item : entry->asArray()) {
            if (!item.isTable()) item.failExpected("a table [[detector]]");
            specs.push_back(readOne(item.asTable()));
        }
    } else {
        entry->failExpected("a table [detector] or an array of tables [[detector]]");
    }
    std::map<std::string, FileLoc> seen;
    for (const DetectorSpec& s : specs) {
        if (s.name.empty()) continue;  // implicit names are checked once placed
        if (auto [it, inserted] = seen.emplace(s.name, s.nameLoc); !inserted)
            throw ParseError(
                s.nameLoc, "detector name '" + s.name + "' is already used at " + it->second.str());
    }
    return specs;
}

std::ostream& operator<<(std::ostream& os, const DetectorGeometry& g) {
    return os << "DetectorGeometry{'" << g.name << "', " << g.widthMm << " x " << g.heightMm
              << " mm, " << g.pixelsX << " x " << g.pixelsY << " pixels, object " << g.object
              << ", " << g.frame << "}";
}

DetectorGeometry placeDetector(const DetectorSpec& spec, const Scene& scene) {
    DetectorGeometry g;
    if (spec.zMm) {
        g.name = spec.name;
        g.frame = Frame::alongAxis(*spec.zMm);
        g.frame.translation.x = spec.centerMm.x;
        g.frame.translation.y = spec.centerMm.y;
        g.widthMm = spec.sizeMm->x;
        g.heightMm = spec.sizeMm->y;
        defaultPixels(g, spec.pixelsX, spec.pixelsY);
        requireSquarishPixels(g, spec);
        return g;
    }
    const std::string objectName = spec.object.empty() ? std::string("sensor") : spec.object;
    const SceneObject* o = scene.find(objectName);
    if (!o) {
        if (spec.object.empty())
            throw ModelError("sensor",
                             "the scene has no image surface 'sensor' for the default detector "
                             "(give object or z_mm)");
        throw ParseError(spec.objectLoc,
                         "detector object '" + spec.object + "' is not an object of the scene");
    }
    g.name = spec.name.empty() ? o->name : spec.name;
    g.object = o->id;
    g.frame.rotation = o->frame.rotation;
    g.frame.translation = o->frame.toGlobalPoint(Vec3(spec.centerMm, 0.0));
    if (const FaceGeometry* face = std::get_if<FaceGeometry>(&o->geometry))
        if (const SurfacePatch* patch = std::get_if<SurfacePatch>(face)) {
            g.aperture = patch->aperture;
            g.apertureOffsetMm = spec.centerMm;
        }
    std::optional<Vec2> size = spec.sizeMm;
    if (!size) {
        size = apertureBox(*o);
        if (!size || !(size->x > 0.0) || !(size->y > 0.0))
            throw ModelError(o->name, "detector '" + g.name +
                                          "': the size cannot be taken from this object (" +
                                          std::string(toString(o->kind)) + "); give size_mm");
    }
    g.widthMm = size->x;
    g.heightMm = size->y;
    defaultPixels(g, spec.pixelsX, spec.pixelsY);
    if (int64_t(g.pixelsX) * g.pixelsY > kMaxDetectorPixels)
        throw ParseError(spec.loc, "detector '" + g.name + "' has " + std::to_string(g.pixelsX) +
                                       " x " + std::to_string(g.pixelsY) + " pixels, more than " +
                                       std::to_string(kMaxDetectorPixels) + " in all");
    requireSquarishPixels(g, spec);
    return g;
}

std::vector<DetectorGeometry> placeDetectors(const std::vector<DetectorSpec>& specs,
                                             const Scene& scene) {
    std::vector<DetectorGeometry> out;
    if (specs.empty()) {
        out.push_back(placeDetector(DetectorSpec{}, scene));
        return out;
    }
    std::map<std::string, FileLoc> seen;
    for (const DetectorSpec& s : specs) {
        DetectorGeometry g = placeDetector(s, scene);
        if (auto [it, inserted] = seen.emplace(g.name, s.nameLoc); !inserted)
            throw ParseError(s.nameLoc, "detector name '" + g.name + "' is already used at " +
                                            it->second.str() + " (give the detectors names)");
        if (g.object < 0 && scene.find(g.name))
            throw ParseError(s.nameLoc, "free detector '" + g.name +
                                            "' has the name of a scene object; choose another");
        out.push_back(std::move(g));
    }
    return out;
}

SceneObject detectorSceneObject(const DetectorGeometry& g) {
    SceneObject o;
    o.name = g.name;
    o.kind = ObjectKind::Detector;
    o.part = g.name;
    o.frame = g.frame;
    o.geometry = FaceGeometry{
        SurfacePatch{PlaneShape{}, RectangularAperture{0.5 * g.widthMm, 0.5 * g.heightMm}}};
    return o;
}

// DetectorImage Method Definitions

DetectorImage::DetectorImage(DetectorGeometry geometry) : geometry_(std::move(geometry)) {
    if (geometry_.pixelsX < 1 || geometry_.pixelsY < 1 || !(geometry_.widthMm > 0.0) ||
        !(geometry_.heightMm > 0.0))
        throw std::invalid_argument("DetectorImage: empty detector '" + geometry_.name + "'");
    const size_t n = static_cast<size_t>(geometry_.pixelCount());
    flux_.assign(n, 0.0);
    flux2_.assign(n, 0.0);
    count_.assign(n, 0);
}

DetectorImage DetectorImage::grid(DetectorGeometry geometry) {
    DetectorImage out(std::move(geometry));
    // Released, not only cleared: a template keeps no memory for sums.
    std::vector<double>().swap(out.flux_);
    std::vector<double>().swap(out.flux2_);
    std::vector<uint64_t>().swap(out.count_);
    return out;
}

DetectorImage::DetectorImage(const DetectorImage& other)
    : geometry_(other.geometry_),
      flux_(other.flux_),
      flux2_(other.flux2_),
      count_(other.count_),
      totalFlux_(other.totalFlux_),
      totalFlux2_(other.totalFlux2_),
      totalCount_(other.totalCount_) {
    if (!other.hasSums() && geometry_.pixelCount() > 0) {  // a template's copy: zero sums
        const size_t n = static_cast<size_t>(geometry_.pixelCount());
        flux_.assign(n, 0.0);
        flux2_.assign(n, 0.0);
        count_.assign(n, 0);
    }
}

DetectorImage& DetectorImage::operator=(const DetectorImage& other) {
    if (this != &other) *this = DetectorImage(other);
    return *this;
}

std::optional<int> DetectorImage::pixelOf(const Vec3& globalPoint) const {
    const Vec3 p = geometry_.frame.toLocalPoint(globalPoint);
    return pixelOfLocal(p.x, p.y);
}

std::optional<int> DetectorImage::pixelOfLocal(double xMm, double yMm) const {
    const double halfW = 0.5 * geometry_.widthMm, halfH = 0.5 * geometry_.heightMm;
    // Written so that NaN fails too.
    if (!(std::abs(xMm) <= halfW) || !(std::abs(yMm) <= halfH)) return std::nullopt;
    const int nx = geometry_.pixelsX, ny = geometry_.pixelsY;
    // A first guess from the grid coordinates, clamped so that the outer edges (and rounding
    // just inside them) stay on the detector, then one step to honour the exact edges: the
    // guess is off by at most one pixel.
    const double s = (xMm + halfW) * nx / geometry_.widthMm;
    const double t = (halfH - yMm) * ny / geometry_.heightMm;
    int column = std::clamp(static_cast<int>(std::floor(s)), 0, nx - 1);
    int row = std::clamp(static_cast<int>(std::floor(t)), 0, ny - 1);
    if (column > 0 && xMm < xEdge(column))
        --column;
    else if (column < nx - 1 && xMm >= xEdge(column + 1))
        ++column;
    if (row > 0 && yMm > yEdge(row))
        --row;
    else if (row < ny - 1 && yMm <= yEdge(row + 1))
        ++row;
    return pixelIndex(column, row);
}

Vec2 DetectorImage::pixelCentreLocal(int pixel) const {
    const int column = pixel % geometry_.pixelsX, row = pixel / geometry_.pixelsX;
    return Vec2(-0.5 * geometry_.widthMm + (column + 0.5) * geometry_.pixelWidthMm(),
                0.5 * geometry_.heightMm - (row + 0.5) * geometry_.pixelHeightMm());
}

void DetectorImage::add(int pixel, double flux) {
    const RayContribution::Entry one{pixel, flux};
    addRay(&one, &one + 1);
}

namespace {

// Sorts entries [from, end) by pixel and sums each pixel's run in place; the entries are then
// the ray's sums, one per pixel in ascending order. Stable: equal pixels keep the order they
// were recorded in, so the sums do not depend on the sort implementation.
void reduceRay(std::vector<RayContribution::Entry>& entries, size_t from) {
    std::stable_sort(entries.begin() + static_cast<std::ptrdiff_t>(from), entries.end(),
                     [](const auto& a, const auto& b) { return a.pixel < b.pixel; });
    size_t out = from;
    for (size_t i = from; i < entries.size();) {
        const int pixel = entries[i].pixel;
        double sum = 0.0;
        for (; i < entries.size() && entries[i].pixel == pixel; ++i) sum += entries[i].flux;
        entries[out++] = {pixel, sum};
    }
    entries.resize(out);
}

}  // namespace

void DetectorLog::add(RayContribution& ray) {
    if (ray.empty()) return;
    const size_t from = sums_.size();
    sums_.insert(sums_.end(), ray.entries().begin(), ray.entries().end());
    reduceRay(sums_, from);
    rayEnds_.push_back(sums_.size());
    ray.clear();
}

void DetectorImage::add(RayContribution& ray) {
    if (ray.empty()) return;
    std::vector<RayContribution::Entry> sums = ray.entries();
    reduceRay(sums, 0);
    addRay(sums.data(), sums.data() + sums.size());
    ray.clear();
}

void DetectorImage::add(const DetectorLog& log) {
    size_t begin = 0;
    for (const size_t end : log.rayEnds_) {
        addRay(log.sums_.data() + begin, log.sums_.data() + end);
        begin = end;
    }
}

void DetectorImage::addRay(const RayContribution::Entry* first,
                           const RayContribution::Entry* last) {
    double rayTotal = 0.0;
    for (const RayContribution::Entry* e = first; e != last; ++e) {
        if (static_cast<unsigned>(e->pixel) >= flux_.size())
            throw std::out_of_range("DetectorImage::add: pixel " + std::to_string(e->pixel) +
                                    " outside detector '" + geometry_.name + "'");
        flux_[e->pixel] += e->flux;
        flux2_[e->pixel] += e->flux * e->flux;
        ++count_[e->pixel];
        rayTotal += e->flux;
    }
    totalFlux_ += rayTotal;
    totalFlux2_ += rayTotal * rayTotal;
    ++totalCount_;
}

void DetectorImage::merge(const DetectorImage& other) {
    if (other.pixelsX() != pixelsX() || other.pixelsY() != pixelsY())
        throw std::invalid_argument("DetectorImage::merge: '" + other.geometry_.name + "' (" +
                                    std::to_string(other.pixelsX()) + " x " +
                                    std::to_string(other.pixelsY()) + ") into '" + geometry_.name +
                                    "' (" + std::to_string(pixelsX()) + " x " +
                                    std::to_string(pixelsY()) + ")");
    for (size_t i = 0; i < flux_.size(); ++i) {
        flux_[i] += other.flux_[i];
        flux2_[i] += other.flux2_[i];
        count_[i] += other.count_[i];
    }
    totalFlux_ += other.totalFlux_;
    totalFlux2_ += other.totalFlux2_;
    totalCount_ += other.totalCount_;
}

DetectorImage DetectorImage::scaled(double factor) const {
    DetectorImage out = *this;
    for (size_t i = 0; i < flux_.size(); ++i) {
        out.flux_[i] *= factor;
        out.flux2_[i] *= factor * factor;
    }
    out.totalFlux_ *= factor;
    out.totalFlux2_ *= factor * factor;
    return out;
}

DetectorImage DetectorImage::fromSums(DetectorGeometry geometry, std::vector<double> flux,
                                      std::vector<double> fluxSquared, std::vector<uint64_t> counts,
                                      double totalFlux, double totalFluxSquared,
                                      uint64_t totalCount) {
    DetectorImage out(std::move(geometry));
    const size_t n = out.flux_.size();
    if (flux.size() != n || fluxSquared.size() != n || counts.size() != n)
        throw std::invalid_argument("DetectorImage::fromSums: " + std::to_string(flux.size()) +
                                    " sums for " + std::to_string(n) + " pixels of '" +
                                    out.geometry_.name + "'");
    out.flux_ = std::move(flux);
    out.flux2_ = std::move(fluxSquared);
    out.count_ = std::move(counts);
    out.totalFlux_ = totalFlux;
    out.totalFlux2_ = totalFluxSquared;
    out.totalCount_ = totalCount;
    return out;
}

void DetectorImage::clear() {
    std::fill(flux_.begin(), flux_.end(), 0.0);
    std::fill(flux2_.begin(), flux2_.end(), 0.0);
    std::fill(count_.begin(), count_.end(), 0);
    totalFlux_ = totalFlux2_ = 0.0;
    totalCount_ = 0;
}

double DetectorImage::pixelVariance(int pixel, uint64_t emittedRays) const {
    return sumEstimatorVariance(flux_[pixel], flux2_[pixel], emittedRays);
}

double DetectorImage::pixelRelativeError(int pixel, uint64_t emittedRays) const {
    if (flux_[pixel] == 0.0) return std::numeric_limits<double>::infinity();
    return std::sqrt(pixelVariance(pixel, emittedRays)) / std::abs(flux_[pixel]);
}

double DetectorImage::totalVariance(uint64_t emittedRays) const {
    return sumEstimatorVariance(totalFlux_, totalFlux2_, emittedRays);
}

double DetectorImage::totalRelativeError(uint64_t emittedRays) const {
    if (totalFlux_ == 0.0) return std::numeric_limits<double>::infinity();
    return std::sqrt(totalVariance(emittedRays)) / std::abs(totalFlux_);
}

bool DetectorImage::sameSums(const DetectorImage& other) const {
    return flux_ == other.flux_ && flux2_ == other.flux2_ && count_ == other.count_ &&
           totalFlux_ == other.totalFlux_ && totalFlux2_ == other.totalFlux2_ &&
           totalCount_ == other.totalCount_;
}

std::ostream& operator<<(std::ostream& os, const DetectorImage& image) {
    return os << "DetectorImage{'" << image.geometry().name << "', " << image.pixelsX() << " x "
              << image.pixelsY() << " pixels, total flux " << image.totalFlux() << " from "
              << image.totalCount() << " rays}";
}

// Detector Emission

double ExitAperture::areaMm2() const { return std::numbers::pi * radiusMm * radiusMm; }

std::ostream& operator<<(std::ostream& os, const ExitAperture& a) {
    return os << "ExitAperture{centre " << a.centerMm << " mm, normal " << a.normal << ", radius "
              << a.radiusMm << " mm}";
}

std::ostream& operator<<(std::ostream& os, const PixelRay& r) {
    return os << "PixelRay{pixel " << r.pixel << ", " << r.ray << ", to " << r.aperturePointMm
              << " at " << r.distanceMm << " mm, cos " << r.cosPixel << " / " << r.cosAperture
              << ", pdf " << r.pdf << " /(mm^2 sr), W_e " << r.importance << "}";
}

namespace {

// Unit vectors perpendicular to unit n, (u, v, n) right-handed.
void apertureBasis(const Vec3& n, Vec3& u, Vec3& v) {
    const Vec3 ref = std::abs(n.x) < 0.9 ? Vec3(1.0, 0.0, 0.0) : Vec3(0.0, 1.0, 0.0);
    u = glm::normalize(ref - glm::dot(ref, n) * n);
    v = glm::cross(n, u);
}

// The density of a pixel ray from its geometry (see the header comment).
double pixelRayDensity(const DetectorImage& image, const ExitAperture& a, double distanceMm,
                       double cosAperture) {
    if (!(cosAperture > 0.0)) return 0.0;
    return distanceMm * distanceMm / (image.geometry().pixelAreaMm2() * a.areaMm2() * cosAperture);
}

}  // namespace

PixelRay samplePixelRay(const DetectorImage& image, int pixel, const ExitAperture& aperture,
                        CounterRng& rng) {
    std::array<double, kPixelRayUniforms> u;
    for (double& x : u) x = rng.uniform();
    return samplePixelRay(image, pixel, aperture, u);
}

PixelRay samplePixelRay(const DetectorImage& image, int pixel, const ExitAperture& aperture,
                        const std::array<double, kPixelRayUniforms>& u) {
    const DetectorGeometry& g = image.geometry();
    const int column = pixel % g.pixelsX, row = pixel / g.pixelsX;
    // Between the pixel's edges, so that the point belongs to it by the boundary rule (the
    // lower x edge and the upper y edge are the pixel's own).
    const double x = image.xEdge(column) + u[0] * (image.xEdge(column + 1) - image.xEdge(column));
    const double y = image.yEdge(row) - u[1] * (image.yEdge(row) - image.yEdge(row + 1));
    PixelRay r;
    r.pixel = pixel;
    r.ray.origin = g.frame.toGlobalPoint(Vec3(x, y, 0.0));
    Vec3 au, av;
    apertureBasis(aperture.normal, au, av);
    const double rho = aperture.radiusMm * std::sqrt(u[2]), phi = 2.0 * std::numbers::pi * u[3];
    r.aperturePointMm = aperture.centerMm + rho * std::cos(phi) * au + rho * std::sin(phi) * av;
    const Vec3 d = r.aperturePointMm - r.ray.origin;
    r.distanceMm = glm::length(d);
    r.ray.direction = d / r.distanceMm;
    r.cosPixel = glm::dot(r.ray.direction, g.normal());
    r.cosAperture = std::abs(glm::dot(r.ray.direction, aperture.normal));
    r.pdf = pixelRayDensity(image, aperture, r.distanceMm, r.cosAperture);
    // W_e: the sensitive side, and only where the detector's object is (a square grid over a
    // round sensor has corners that record nothing).
    r.importance = r.cosPixel > 0.0 && g.sensitiveAt(x, y) ? 1.0 : 0.0;
    return r;
}

double pixelRayPdf(const DetectorImage& image, int pixel, const ExitAperture& aperture,
                   const Ray& ray) {
    if (image.pixelOf(ray.origin) != pixel) return 0.0;
    const double along = glm::dot(ray.direction, aperture.normal);
    if (along == 0.0) return 0.0;
    const double t = glm::dot(aperture.centerMm - ray.origin, aperture.normal) / along;
    if (!(t > 0.0)) return 0.0;
    const Vec3 q = ray.origin + t * ray.direction - aperture.centerMm;
    if (glm::dot(q, q) > aperture.radiusMm * aperture.radiusMm) return 0.0;
    return pixelRayDensity(image, aperture, t, std::abs(along));
}

double pixelImportance(const DetectorImage& image, int pixel, const Ray& ray) {
    if (image.pixelOf(ray.origin) != pixel) return 0.0;
    const DetectorGeometry& g = image.geometry();
    const Vec3 local = g.frame.toLocalPoint(ray.origin);
    if (!g.sensitiveAt(local.x, local.y)) return 0.0;
    return glm::dot(ray.direction, g.normal()) > 0.0 ? 1.0 : 0.0;
}

std::array<Vec3, 4> pixelCornersGlobal(const DetectorImage& image, int pixel) {
    const DetectorGeometry& g = image.geometry();
    const int c = pixel % g.pixelsX, r = pixel / g.pixelsX;
    auto corner = [&](int k, int j) {
        return g.frame.toGlobalPoint(Vec3(image.xEdge(k), image.yEdge(j), 0.0));
    };
    return {corner(c, r), corner(c + 1, r), corner(c + 1, r + 1), corner(c, r + 1)};
}

double sumEstimatorVariance(double sum, double sumSquares, uint64_t n) {
    if (n < 2) return sumSquares > 0.0 ? std::numeric_limits<double>::infinity() : 0.0;
    const double nd = static_cast<double>(n);
    const double v = nd / (nd - 1.0) * (sumSquares - sum * sum / nd);
    return v > 0.0 ? v : 0.0;
}

}  // namespace veil
