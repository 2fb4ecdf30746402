#pragma once
// Detector images on disk: OpenEXR for the numbers, PNG for a look.
//
// OpenEXR (scan lines, ZIP compressed, lossless). One layer per DetectorImage (one per
// criterion or component later), all on the same pixel grid. A layer named "" writes plain
// channel names; a layer named "ghosts" writes "ghosts.value" and so on. Channels, 32-bit
// float, first scan line = top edge of the detector (+y, see tracer/records/detector.h):
//
//   value       flux per pixel (fluxUnit: W or lm), the sum estimator of the pixel
//   irradiance  value / pixel area (fluxUnit/mm^2)
//   variance    estimated variance of value (fluxUnit^2), N/(N-1) (S2 - S1^2/N) over the
//               emittedRays N of the run; the variance of irradiance is this / area^2
//   count       rays that contributed to the pixel (exact up to 2^24 as a float)
//
// Stored scaled. Dark runs (0.1 % mounts, many bounces) give fluxes of 1e-25 W and
// variances of 1e-50 W^2, below float's smallest value (1.4e-45), so value, irradiance and
// variance are each stored divided by a power of two of their own, per layer:
//
//   physical = stored * veil[.layer].<channel>Scale      (count is stored as is)
//
// The scale puts the channel's largest value in [0.5, 1), where an image viewer shows it
// near white; when that would push its smallest non-zero value below float's normal range
// (more than ~38 decades below), the scale is lowered as far as the largest value allows,
// so any channel spanning up to 2^253 (~76 decades) keeps float precision (relative 2^-24)
// in every pixel. Beyond that (never seen in practice), a non-zero value too small for the
// float is stored as the smallest positive float: it reads back non-zero, as an upper bound.
// Readers of files without the scale attributes (written before them) take scale 1.
//
// Header attributes besides the standard ones (pixelAspectRatio = pixel width / height):
//
//   veil.detector          string   detector name
//   veil.fluxUnit          string   "W" or "lm"
//   veil.irradianceUnit    string   "W/mm^2" or "lm/mm^2"
//   veil.emittedRays       double   N (exact below 2^53)
//   veil.detectorSizeMm    v2d      width, height
//   veil.pixelSizeMm       v2d      pixel width, height
//   veil[.layer].totalFlux           double   the layer's total flux
//   veil[.layer].totalRelativeError  double   its relative standard error (inf if no flux)
//   veil[.layer].valueScale          double   power of two, stored value -> fluxUnit
//   veil[.layer].irradianceScale     double   power of two, stored irradiance -> fluxUnit/mm^2
//   veil[.layer].varianceScale       double   power of two, stored variance -> fluxUnit^2
//
// PNG preview: the chosen quantity in false colour on a log scale spanning `decades` below
// the maximum (values below the range take the lowest colour, zero is black), detector
// pixels drawn as blocks in their physical aspect, axes ticked in detector-local mm (round
// steps, niceTicks) and labelled "x (mm)" and "y (mm)", a colour bar with ticks at powers of
// ten labelled with the quantity and its unit ("irradiance (W/mm²)" or "flux per pixel
// (W)"), an orientation mark (+x right, +y up, +z toward the viewer), and notes below: the
// grid, the maximum, the total with its relative error, and the view.
//
// Orientation: the image is drawn as the detector's local frame is laid out (tracer/
// detector.h): column 0 (local x = -width/2) at the left, row 0 (local y = +height/2) at the
// top, so +x points right and +y up, and with a right-handed frame local +z points out of
// the picture toward the viewer. The sensitive side faces local -z, toward the lens, so the
// picture shows the detector as seen from behind it (from its +z side), looking back toward
// the lens (seen from the lens, left and right would swap).
//
// The colour map is viridis (van der Walt and Smith, matplotlib) sampled at 9 anchors and
// interpolated linearly: perceptually ordered, its lightness rises monotonically from dark
// violet to yellow, and it stays distinct from the black of empty pixels.
//
// Both are written to "<path>.tmp" and renamed, so a failed write never leaves a partial
// file under the final name; the temporary is removed on failure.

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "analysis/pictures/picture.h"

namespace veil {

class DetectorImage;

// OpenEXR Output

struct ImageLayer {
    std::string name;  // "" for plain channel names
    const DetectorImage* image = nullptr;
};

struct ExrInfo {
    std::string fluxUnit = "W";  // "W" (radiometric) or "lm" (photometric)
    uint64_t emittedRays = 0;    // N of the run, for the variance channel and the headers
};

// Throws std::invalid_argument for no layers, layers on different pixel grids, duplicate or
// unusable layer names (a '.' inside is fine, an empty name only as the single layer);
// std::runtime_error naming the path when the file cannot be written.
void writeDetectorExr(const std::filesystem::path& path, const std::vector<ImageLayer>& layers,
                      const ExrInfo& info);
void writeDetectorExr(const std::filesystem::path& path, const DetectorImage& image,
                      const ExrInfo& info);

// A file written by writeDetectorExr(), read back in physical units: the stored floats
// times their scales, as doubles (a variance of 1e-60 W^2 is no float).
struct ExrLayer {
    std::string name;
    // Row-major, row 0 at the top: fluxUnit, fluxUnit/mm^2, fluxUnit^2, rays.
    std::vector<double> value, irradiance, variance, count;
    double totalFlux = 0.0;
    double totalRelativeError = 0.0;
    // The scales found in the file (1 when absent).
    double valueScale = 1.0, irradianceScale = 1.0, varianceScale = 1.0;
};
struct DetectorExr {
    int width = 0, height = 0;  // pixels
    std::string detector, fluxUnit, irradianceUnit;
    double emittedRays = 0.0;
    Vec2 detectorSizeMm{0.0}, pixelSizeMm{0.0};
    float pixelAspectRatio = 1.0f;
    std::vector<ExrLayer> layers;  // in channel-name order

    const ExrLayer* layer(const std::string& name) const;
};
std::ostream& operator<<(std::ostream& os, const DetectorExr& e);

// Throws std::runtime_error naming the path when the file cannot be read or lacks a
// channel of the four of one of its layers.
DetectorExr readDetectorExr(const std::filesystem::path& path);

// What writeDetectorExr() would write and readDetectorExr() read back, in memory and without
// the float rounding of the file (scales 1): the images of a run handed to Python as values.
// Layers in the order given. Throws std::invalid_argument as writeDetectorExr() does.
DetectorExr detectorLayers(const std::vector<ImageLayer>& layers, const ExrInfo& info);

// PNG Preview

enum class PreviewQuantity {
    Irradiance,  // flux per mm^2 (fluxUnit/mm^2)
    Flux,        // flux per pixel (fluxUnit)
};

// The colour scale of a preview: log10 of the quantity from lo to hi.
//   fixed range (lo, hi > 0): that range.
//   decades > 0: hi the largest value of the range's light, lo hi 10^-decades.
//   auto (neither; the default): hi the value that only the brightest kAutoTopShare of the lit
//     pixels exceed (single bright pixels of a Monte Carlo image, a source's image in the
//     frame, do not set the scale), lo the lit pixels' kAutoBottomQuantile, at least
//     kAutoMinDecades and at most kAutoMaxDecades below hi: a near-uniform veil spans the
//     colour map instead of one flat colour at the top of a 3-decade bar.
// Pixels above hi show in its colour, those below lo in the lowest; the notes count those
// above.
struct PreviewScale {
    static constexpr double kAutoTopShare = 5e-4;
    static constexpr double kAutoBottomQuantile = 0.01;
    static constexpr double kAutoMinDecades = 0.1;
    static constexpr double kAutoMaxDecades = 4.0;
    double decades = 0.0;
    double lo = 0.0, hi = 0.0;
    bool fixed() const { return hi > 0.0; }
    // std::invalid_argument unless decades >= 0 (finite), and a fixed range has
    // 0 < lo < hi, both finite.
    void check() const;
};

struct PreviewOptions {
    PreviewQuantity quantity = PreviewQuantity::Irradiance;
    PreviewScale scale;          // auto by default
    std::string fluxUnit = "W";  // unit of the source flux: "W" or "lm"
    int imageSizePx = 800;       // longer side of the detector area in the PNG
    std::string title;           // empty: "Detector <name>"
    uint64_t emittedRays = 0;    // > 0 adds the total flux and its relative error
    // The light that sets the scale (null: the image): the light the run asked for, so that a
    // source's own image in the frame does not black out its stray light. `rangeName` names
    // it in the notes.
    const DetectorImage* rangeImage = nullptr;
    std::string rangeName;
};

// Where things are in the PNG, in PNG pixels (origin top left): the detector area, the
// colour bar, the axis ticks, the orientation mark, and the value range shown.
struct PreviewLayout {
    int widthPx = 0, heightPx = 0;
    double imageX = 0, imageY = 0, imageW = 0, imageH = 0;
    double barX = 0, barY = 0, barW = 0, barH = 0;
    double maxValue = 0.0;  // the top of the colour bar (PreviewScale); 0: nothing lit
    double minValue = 0.0;  // the bottom of the colour bar
    double imageMax = 0.0;  // the image's largest value
    int above = 0;          // pixels above maxValue
    double widthMm = 0.0, heightMm = 0.0;  // the detector
    Ticks xTicks, yTicks;                  // detector-local mm
    double markX = 0, markY = 0;           // origin of the orientation mark's arrows
    std::string title;                     // at the top
    std::vector<std::string> notes;        // lines below: grid and values, the view
    // The PNG position of a detector-local coordinate (mm): x = -width/2 at the image's
    // left edge, y = +height/2 at its top edge.
    double xPx(double xMm) const { return imageX + (xMm / widthMm + 0.5) * imageW; }
    double yPx(double yMm) const { return imageY + (0.5 - yMm / heightMm) * imageH; }
};
PreviewLayout previewLayout(const DetectorImage& image, const PreviewOptions& options = {});

// Throws std::invalid_argument for a bad scale (PreviewScale::check) or imageSizePx < 16,
// std::runtime_error naming the path when the file cannot be written.
void writeDetectorPng(const std::filesystem::path& path, const DetectorImage& image,
                      const PreviewOptions& options = {});

// The colour map at t in [0, 1] (clamped), opaque.
Color falseColour(double t);
// The colour of one value: black for value <= 0 (or NaN), falseColour of its position on
// the log scale [minValue, maxValue] otherwise (clamped at both ends).
Color previewColour(double value, double minValue, double maxValue);
// The displayed quantity of one pixel.
double previewValue(const DetectorImage& image, int pixel, PreviewQuantity quantity);
// The colour bar's label: "irradiance (W/mm²)" or "flux per pixel (W)".
std::string previewLabel(PreviewQuantity quantity, const std::string& fluxUnit);

}  // namespace veil
