#pragma once
// Rectangular irradiance detectors: where they sit (DetectorSpec -> DetectorGeometry) and what
// they accumulate (DetectorImage), with the Monte Carlo error of every pixel and of the total.
//
// Frames and pixels. A detector is a rectangle of widthMm x heightMm centred on the origin of
// its own frame, in the frame's x-y plane; its sensitive side faces local -z, toward light
// that travels along +z (the default detector sits at the image plane, where light arrives
// travelling +z). A point is mapped to a pixel by projecting it along the local z axis, so a
// detector attached to a curved image surface records hits by their local (x, y).
//
//              local +y
//        row 0  +---+---+---+---+          pixel index = row * pixelsX + column
//               |0,0|1,0|   |   |  (col,row) column 0 at local x = -width/2, growing with +x
//        row 1  +---+---+---+---+          row 0 at local y = +height/2, growing toward -y
//               |   |   |   |   |          (the first scan line of an image file is the top
//               +---+---+---+---+ local +x  edge, +y, seen with +x to the right)
//
// Boundary rule. Pixel edges are the doubles xEdge(k) = -width/2 + k * (width / pixelsX) and
// yEdge(j) = height/2 - j * (height / pixelsY), computed in double as written; column k holds
// xEdge(k) <= x < xEdge(k + 1) and row j holds yEdge(j + 1) < y <= yEdge(j). So a point on
// the line between two pixels belongs to the pixel with the larger index (to the right in x,
// below in y), and a corner shared by four pixels to the lower right one. The outer edges
// are inside: x = +width/2 goes to the last column, y = -height/2 to the last row. Points
// with |x| > width/2 or |y| > height/2 (or NaN) are outside (nullopt). The rule holds for
// any pitch; where the pitch is a binary fraction (8 mm / 16 pixels) the edges are also the
// exact real-number edges.
//
// Statistics. A run emits N rays (counting rays that never reach the detector). Ray i
// deposits x_i in a pixel (0 when it misses it; the sum over all of its split children when
// several land there). The pixel value is the sum estimator F = sum x_i = N mean(x), and its
// variance is estimated from the two sums the pixel keeps, S1 = sum x_i and S2 = sum x_i^2:
//
//     Var(F) = N^2 Var(mean x) = N s^2 = N / (N - 1) * (S2 - S1^2 / N)
//
// (s^2 the unbiased sample variance of the x_i, zeros included). The same formula with the
// per-ray totals on the whole detector gives the variance of the total flux. S2 must be
// summed per emitted ray, not per hit: two children of one ray that land in the same pixel
// are one sample x_i = a + b, and (a + b)^2 != a^2 + b^2. With ray splitting, collect what
// one emitted ray deposits in a RayContribution and flush it once with add(RayContribution&).
// add(pixel, flux) treats each call as the whole contribution of one emitted ray.
//
// Reductions. Floating-point sums depend on their order, so for images that are bitwise the
// same for any thread count, add the rays of fixed blocks in a fixed order, never in
// completion order. A block traced on its own thread keeps a DetectorLog (its rays' sums, in
// order; memory with the hits) that is added to the one image in block order; merge() adds
// whole images element-wise (for checkpoints and passes), at pixel-count memory each.

#include <array>
#include <cstdint>
#include <optional>
#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "geometry/aperture.h"
#include "geometry/frame.h"
#include "geometry/scene.h"
#include "lensdata/errors.h"
#include "tracer/runtime/ranks.h"

namespace veil {

class CounterRng;
class TomlDocument;

// One [detector] (or [[detector]] entry) as read, before it is placed in a scene. See
// docs/format.md for the keys.
//
// Placement: with zMm, a free flat detector at global z = zMm, centred at centerMm (global
// x, y), axes along the global ones; it is not part of the scene until the caller adds
// detectorSceneObject(). Otherwise the detector lies on a scene object (`object`, or the
// image surface `sensor` when empty): its grid is the object's local x-y plane (global for
// imported meshes, which are stored in global coordinates), centred at centerMm there, and
// it records the hits on that object.
struct DetectorSpec {
    std::string name;              // empty: the name of the object it lies on
    std::optional<Vec2> sizeMm;    // width (x), height (y); empty: the object's aperture box
    int pixelsX = 0, pixelsY = 0;  // 0: 256 along the longer side, near-square pixels
    std::optional<double> zMm;     // a free detector's plane (global z)
    Vec2 centerMm{0.0};
    std::string object;  // the scene object it lies on; empty: "sensor" (unless zMm)
    FileLoc loc;         // the table, for errors about the whole entry
    FileLoc nameLoc;     // its name value (or the table when the name is implicit)
    FileLoc objectLoc;   // its object value (or the table)
};
std::ostream& operator<<(std::ostream& os, const DetectorSpec& s);

// Reads [detector] (one table) or [[detector]] (an array of tables), marking the keys used
// for TomlDocument::checkAllUsed(). Empty when neither is present. ParseErrors at the value
// at fault: sizes that are not two numbers > 0, pixel counts that are not integers in
// [1, 16384] or that exceed kMaxDetectorPixels together, both z_mm and object, a free
// detector without name or size_mm, a name used twice.
std::vector<DetectorSpec> readDetectors(TomlDocument& doc);

// Largest pixelsX * pixelsY accepted (32 Mpx: 768 MB per image with its three sums).
inline constexpr int64_t kMaxDetectorPixels = int64_t(1) << 25;
// A detector's size_mm lies in (0, 1e9] mm, and its pixels (size over pixel count) are at most
// this many times longer one way than the other: ParseError at the detector's table, when
// the scene is built (OpenEXR refuses such images only when they are written).
inline constexpr double kMaxDetectorSizeMm = 1e9;
inline constexpr double kMaxPixelAspect = 1000.0;

// A detector placed in a scene: everything pixelOf() needs.
struct DetectorGeometry {
    std::string name;
    Frame frame;  // local to global; the grid is centred on the local origin in the x-y plane
    double widthMm = 0.0, heightMm = 0.0;
    int pixelsX = 0, pixelsY = 0;
    // The scene object whose hits it records; -1 for a free detector that is not in the scene
    // yet (add detectorSceneObject() and store the id addObject() returns here).
    int object = -1;
    // On an object with an aperture (the sensor's disc): that aperture, in the detector's own
    // (x, y) shifted by `apertureOffsetMm` (the detector's centre on the object). Only points
    // inside it are sensitive, as only light hitting the object is recorded: the renderer's
    // pixel rays start there, not in the grid's corners beyond a round sensor.
    std::optional<Aperture> aperture;
    Vec2 apertureOffsetMm{0.0};

    int pixelCount() const { return pixelsX * pixelsY; }
    // Whether the detector records light at local (x, y): inside its object's aperture.
    bool sensitiveAt(double xMm, double yMm) const {
        return !aperture ||
               apertureContains(*aperture, xMm + apertureOffsetMm.x, yMm + apertureOffsetMm.y);
    }
    double pixelWidthMm() const { return widthMm / pixelsX; }
    double pixelHeightMm() const { return heightMm / pixelsY; }
    double pixelAreaMm2() const { return pixelWidthMm() * pixelHeightMm(); }
    // Unit normal of the sensitive side, global: the frame's -z axis.
    Vec3 normal() const { return frame.toGlobalDirection(Vec3(0.0, 0.0, -1.0)); }
    // The grid's corners, global, in order around it (local (-w, -h), (w, -h), (w, h),
    // (-w, h) over 2), at local z = zMm.
    std::array<Vec3, 4> corners(double zMm = 0.0) const {
        const double w = 0.5 * widthMm, h = 0.5 * heightMm;
        return {frame.toGlobalPoint({-w, -h, zMm}), frame.toGlobalPoint({w, -h, zMm}),
                frame.toGlobalPoint({w, h, zMm}), frame.toGlobalPoint({-w, h, zMm})};
    }
};
std::ostream& operator<<(std::ostream& os, const DetectorGeometry& g);

// Places one spec in a built scene. Errors: a ParseError at `object` when no scene object
// has that name, a ModelError naming the object when the default image surface `sensor` is
// missing or when the size cannot be taken from the object (a mesh or a lens edge, an
// aperture of zero size): give size_mm then.
DetectorGeometry placeDetector(const DetectorSpec& spec, const Scene& scene);
// Places every spec; no specs gives the default detector (DetectorSpec{}: on `sensor`, the
// box of its aperture, 256 x 256 pixels). ParseError when two detectors end up with the same
// name or a free detector takes the name of a scene object.
std::vector<DetectorGeometry> placeDetectors(const std::vector<DetectorSpec>& specs,
                                             const Scene& scene);
// The scene object of a free detector: a flat rectangle in its frame, kind Detector, air on
// both sides, named after the detector. Its face normal is the frame's +z (SurfacePatch
// convention), so light travelling +z meets it from the back, on the sensitive side.
SceneObject detectorSceneObject(const DetectorGeometry& g);

// What one emitted ray (with all its split children) deposits on one detector, collected
// while the ray is traced and flushed once with DetectorImage::add(RayContribution&).
class RayContribution {
  public:
    struct Entry {
        int pixel = 0;
        double flux = 0.0;
    };
    void add(int pixel, double flux) { entries_.push_back({pixel, flux}); }
    bool empty() const { return entries_.empty(); }
    size_t size() const { return entries_.size(); }
    void clear() { entries_.clear(); }
    const std::vector<Entry>& entries() const { return entries_; }

  private:
    std::vector<Entry> entries_;
};

// What a run of emitted rays deposits on one detector, ray after ray, each ray already
// reduced to one sum per pixel (as DetectorImage::add(RayContribution&) reduces it). Adding
// a log to an image gives bitwise the image that adding its rays one by one would. A
// traced block of rays keeps its log (memory with its hits, not with the pixel count) and
// the logs are added to one image in block order: pixels x blocks never held at once.
class DetectorLog {
  public:
    // Appends one ray (nothing when it is empty) and clears it.
    void add(RayContribution& ray);
    bool empty() const { return rayEnds_.empty(); }
    size_t rays() const { return rayEnds_.size(); }
    size_t entries() const { return sums_.size(); }
    void clear() {
        sums_.clear();
        rayEnds_.clear();
    }
    // As bytes, between ranks (tracer/runtime/ranks.h).
    void pack(ByteWriter& w) const {
        w.putVector(sums_);
        w.putVector(rayEnds_);
    }
    static DetectorLog unpack(ByteReader& r) {
        DetectorLog log;
        log.sums_ = r.getVector<RayContribution::Entry>();
        log.rayEnds_ = r.getVector<size_t>();
        return log;
    }

  private:
    friend class DetectorImage;
    std::vector<RayContribution::Entry> sums_;  // per ray, one per pixel, ascending pixel
    std::vector<size_t> rayEnds_;               // end of each ray's sums in sums_
};

// Per pixel sums of flux (W or lm, the source's unit), of squared per-ray flux and the
// number of rays that contributed, plus the same three for the whole detector.
class DetectorImage {
  public:
    DetectorImage() = default;
    explicit DetectorImage(DetectorGeometry geometry);
    // A template: the grid without memory for sums (SceneTransport::images, whose copies are the
    // accumulators of a run). Copying a template gives a zero image with its sums allocated;
    // the template's own sums must not be read (hasSums() is false).
    static DetectorImage grid(DetectorGeometry geometry);
    DetectorImage(const DetectorImage& other);
    DetectorImage& operator=(const DetectorImage& other);
    DetectorImage(DetectorImage&&) noexcept = default;
    DetectorImage& operator=(DetectorImage&&) noexcept = default;
    bool hasSums() const { return !flux_.empty(); }

    const DetectorGeometry& geometry() const { return geometry_; }
    int pixelsX() const { return geometry_.pixelsX; }
    int pixelsY() const { return geometry_.pixelsY; }
    int pixelCount() const { return geometry_.pixelCount(); }

    // DetectorImage Pixel Mapping (rules in the header comment)
    std::optional<int> pixelOf(const Vec3& globalPoint) const;
    std::optional<int> pixelOfLocal(double xMm, double yMm) const;
    int pixelIndex(int column, int row) const { return row * geometry_.pixelsX + column; }
    // Centre of a pixel in the detector's local x, y (mm).
    Vec2 pixelCentreLocal(int pixel) const;
    // The pixel edges of the boundary rule (local mm): columns k = 0..pixelsX, rows
    // j = 0..pixelsY.
    double xEdge(int k) const {
        return -0.5 * geometry_.widthMm + k * (geometry_.widthMm / geometry_.pixelsX);
    }
    double yEdge(int j) const {
        return 0.5 * geometry_.heightMm - j * (geometry_.heightMm / geometry_.pixelsY);
    }

    // DetectorImage Accumulation
    // One emitted ray's whole contribution to one pixel (no other deposit of that ray here).
    void add(int pixel, double flux);
    // Flushes one emitted ray: entries of the same pixel are summed (in the order they were
    // recorded), then each pixel gets its sum, its square and one count; the totals get the
    // ray's sum over the detector and its square. Clears `ray`. Nothing happens when empty.
    void add(RayContribution& ray);
    // Every ray of a log, in its order (the same as adding them one by one).
    void add(const DetectorLog& log);
    // Element-wise sum. Throws std::invalid_argument when the pixel grids differ.
    void merge(const DetectorImage& other);
    void clear();
    // Every flux times factor, every squared flux times factor^2, counts kept: the image of
    // the estimator factor * F (a mean over n passes: factor 1 / n, variances with N = n are
    // then those of the mean).
    DetectorImage scaled(double factor) const;
    // An image with the given sums (a checkpoint read back). Throws std::invalid_argument
    // when a vector's size is not the geometry's pixel count.
    static DetectorImage fromSums(DetectorGeometry geometry, std::vector<double> flux,
                                  std::vector<double> fluxSquared, std::vector<uint64_t> counts,
                                  double totalFlux, double totalFluxSquared, uint64_t totalCount);

    // DetectorImage Sums
    double flux(int pixel) const { return flux_[pixel]; }
    double fluxSquared(int pixel) const { return flux2_[pixel]; }
    uint64_t count(int pixel) const { return count_[pixel]; }
    const std::vector<double>& fluxes() const { return flux_; }
    const std::vector<double>& fluxesSquared() const { return flux2_; }
    const std::vector<uint64_t>& counts() const { return count_; }
    double totalFlux() const { return totalFlux_; }
    double totalFluxSquared() const { return totalFlux2_; }
    uint64_t totalCount() const { return totalCount_; }  // rays that reached the detector
    // Flux per pixel area, flux unit per mm^2.
    double irradiance(int pixel) const { return flux_[pixel] / geometry_.pixelAreaMm2(); }

    // DetectorImage Statistics, for a run of emittedRays rays (formula in the header comment)
    double pixelVariance(int pixel, uint64_t emittedRays) const;
    double pixelRelativeError(int pixel, uint64_t emittedRays) const;
    double totalVariance(uint64_t emittedRays) const;
    // sqrt(totalVariance) / totalFlux; infinity when nothing was detected.
    double totalRelativeError(uint64_t emittedRays) const;

    // Exactly equal sums and counts (the geometry is not compared).
    bool sameSums(const DetectorImage& other) const;

  private:
    // Adds one ray's sums (one entry per pixel) to the pixels and the totals.
    void addRay(const RayContribution::Entry* first, const RayContribution::Entry* last);

    DetectorGeometry geometry_;
    std::vector<double> flux_, flux2_;
    std::vector<uint64_t> count_;
    double totalFlux_ = 0.0, totalFlux2_ = 0.0;
    uint64_t totalCount_ = 0;
};
std::ostream& operator<<(std::ostream& os, const DetectorImage& image);

// Detector Emission
//
// For the backward and bidirectional passes the detector is an endpoint that emits importance
// (DESIGN.md, "Endpoints"): a pixel sends rays toward the exit aperture of the lens, from a
// point uniform in the pixel toward a point uniform on the aperture disk.
//
// Importance. A pixel records flux (DetectorImage sums W or lm per pixel), so its importance
// is W_e(x, w) = 1 for x in the pixel where the detector is sensitive (inside its object's
// aperture: sensitiveAt) and w leaving the sensitive side (dot(w, normal()) > 0, w pointing
// back along the arriving light), 0 otherwise: dimensionless, and the flux the
// pixel records is
//     Phi_pixel = integral over the pixel of integral over the hemisphere of
//                 W_e(x, w) L(x, -w) cos(theta_pixel) dw dA,
// L the radiance arriving at x travelling along -w. (For irradiance divide by
// pixelAreaMm2(), as DetectorImage::irradiance() does.) A backward ray estimates it as
// W_e L cos(theta_pixel) / pdf.
//
// Measure. pdf is per mm^2 of the pixel times per steradian at the pixel point:
//     pdf = 1 / A_pixel * 1 / A_aperture * d^2 / cos(theta_aperture),
// d the distance from the pixel point to the aperture point and theta_aperture the angle
// between the ray and the aperture's normal (the area-to-solid-angle Jacobian). The etendue
// of the pixel through the disk is then the expectation of cos(theta_pixel) / pdf.

// A disk the pixel rays aim at (global mm): typically the clear aperture of the last lens
// element. The side the normal points to does not matter.
struct ExitAperture {
    Vec3 centerMm{0.0};
    Vec3 normal{0.0, 0.0, 1.0};  // unit
    double radiusMm = 0.0;
    double areaMm2() const;
};
std::ostream& operator<<(std::ostream& os, const ExitAperture& a);

struct PixelRay {
    Ray ray;  // global: origin in the pixel, unit direction toward aperturePointMm
    int pixel = 0;
    Vec3 aperturePointMm{0.0};
    double distanceMm = 0.0;   // from the origin to aperturePointMm
    double cosPixel = 0.0;     // dot(direction, normal()); <= 0: aperture behind the detector
    double cosAperture = 0.0;  // |dot(direction, aperture normal)|
    double pdf = 0.0;          // per mm^2 per sr (see above); 0 when cosAperture = 0
    double importance = 0.0;   // W_e: 1 when cosPixel > 0 and the origin is sensitive, else 0
};
std::ostream& operator<<(std::ostream& os, const PixelRay& r);

// Uniforms samplePixelRay() draws from the stream: two for the pixel point, two for the
// aperture point, in that order.
inline constexpr int kPixelRayUniforms = 4;

// A ray from `pixel` of the image's grid (0 <= pixel < pixelCount()) through the aperture.
PixelRay samplePixelRay(const DetectorImage& image, int pixel, const ExitAperture& aperture,
                        CounterRng& rng);
// The same from given uniforms in [0, 1) (the pixel point's two, then the aperture point's:
// equal areas of the unit square map to equal areas of the pixel and of the disk), so a pass
// can stratify them; the pdf is the same.
PixelRay samplePixelRay(const DetectorImage& image, int pixel, const ExitAperture& aperture,
                        const std::array<double, kPixelRayUniforms>& u);
// The pdf samplePixelRay() gives `ray` (origin on the detector plane, unit direction): 0 when
// the origin is not in `pixel` or the ray misses the aperture disk.
double pixelRayPdf(const DetectorImage& image, int pixel, const ExitAperture& aperture,
                   const Ray& ray);
// W_e of a ray leaving the detector (see above) for `pixel`: 1 when its origin falls in that
// pixel (pixelOf), on the detector's object (sensitiveAt), and it leaves the sensitive side,
// else 0.
double pixelImportance(const DetectorImage& image, int pixel, const Ray& ray);
// The pixel's corners in global coordinates: (xEdge(c), yEdge(r)), (xEdge(c + 1), yEdge(r)),
// (xEdge(c + 1), yEdge(r + 1)), (xEdge(c), yEdge(r + 1)) for column c and row r, i.e. top
// left, top right, bottom right, bottom left as the image is shown.
std::array<Vec3, 4> pixelCornersGlobal(const DetectorImage& image, int pixel);

// Variance of the sum estimator F = sum x_i over n samples from S1 = sum x_i and
// S2 = sum x_i^2: n / (n - 1) * (S2 - S1^2 / n), clamped at 0 against rounding. With fewer
// than two samples it is unknown: infinity when S2 > 0, else 0.
double sumEstimatorVariance(double sum, double sumSquares, uint64_t n);

}  // namespace veil
