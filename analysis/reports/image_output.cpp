#include "analysis/reports/image_output.h"

#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <ImfVecAttribute.h>
#include <cairo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>

#include "lensdata/output_file.h"
#include "tracer/records/detector.h"

namespace veil {

namespace {

constexpr std::array<const char*, 4> kFields = {"value", "irradiance", "variance", "count"};

std::string channelName(const std::string& layer, const char* field) {
    return layer.empty() ? std::string(field) : layer + "." + field;
}

std::string attributeName(const std::string& layer, const std::string& what) {
    return layer.empty() ? "veil." + what : "veil." + layer + "." + what;
}

// Stored Scales (rules in the header comment)

// The exponent k of the scale 2^k a channel is divided by before it becomes float. Zero and
// non-finite values take no part; an empty channel gets k = 0.
int scaleExponent(const std::vector<double>& x) {
    double largest = 0.0, smallest = std::numeric_limits<double>::infinity();
    for (double v : x) {
        const double a = std::abs(v);
        if (!(a > 0.0) || !std::isfinite(a)) continue;
        largest = std::max(largest, a);
        smallest = std::min(smallest, a);
    }
    if (largest == 0.0) return 0;
    int eLargest = 0, eSmallest = 0;  // a value lies in [2^(e-1), 2^e)
    std::frexp(largest, &eLargest);
    std::frexp(smallest, &eSmallest);
    // Largest in [0.5, 1) (k = eLargest), unless the smallest would then fall below float's
    // normal range: it stays >= 2^-126 for k <= eSmallest + 125, and the largest stays
    // < 2^127 (finite after rounding) for k >= eLargest - 127.
    const int k = std::max(eLargest - 127, std::min(eLargest, eSmallest + 125));
    // 2^k must be a finite, non-zero double for the header attribute.
    return std::clamp(k, std::numeric_limits<double>::min_exponent - 53,
                      std::numeric_limits<double>::max_exponent - 1);
}

// x / 2^k as float; a non-zero x that underflows becomes the smallest positive float (of
// its sign), so a pixel with flux never reads back as empty.
float storedValue(double x, int k) {
    const float f = static_cast<float>(std::ldexp(x, -k));
    if (f == 0.0f && x != 0.0)
        return std::copysign(std::numeric_limits<float>::denorm_min(), static_cast<float>(x));
    return f;
}

// The Viridis Colour Map

// matplotlib's viridis at t = 0, 1/8, ..., 1.
constexpr std::array<unsigned, 9> kViridis = {0x440154, 0x472d7b, 0x3b528b, 0x2c728e, 0x21918c,
                                              0x28ae80, 0x5ec962, 0xaddc30, 0xfde725};

uint8_t toByte(double c) {
    return static_cast<uint8_t>(std::lround(std::clamp(c, 0.0, 1.0) * 255.0));
}

// "10" with a raised exponent, left-aligned at (x, baseline y); returns the width drawn.
double drawPowerOfTen(cairo_t* cr, double x, double y, int exponent, double sizePt) {
    cairo_set_font_size(cr, sizePt);
    cairo_text_extents_t base;
    cairo_text_extents(cr, "10", &base);
    cairo_move_to(cr, x, y);
    cairo_show_text(cr, "10");
    const std::string e = std::to_string(exponent);
    cairo_set_font_size(cr, 0.7 * sizePt);
    cairo_text_extents_t sup;
    cairo_text_extents(cr, e.c_str(), &sup);
    cairo_move_to(cr, x + base.x_advance + 1.0, y - 0.45 * sizePt);
    cairo_show_text(cr, e.c_str());
    return base.x_advance + 1.0 + sup.x_advance;
}

std::string unitOf(PreviewQuantity q, const std::string& fluxUnit) {
    return q == PreviewQuantity::Irradiance ? fluxUnit + "/mm\u00b2" : fluxUnit + " per pixel";
}

// Text centred on (x, y) and turned a quarter turn counter-clockwise (reading upward).
void showUpward(cairo_t* cr, double x, double y, const std::string& text) {
    cairo_text_extents_t ext;
    cairo_text_extents(cr, text.c_str(), &ext);
    cairo_save(cr);
    cairo_translate(cr, x, y);
    cairo_rotate(cr, -0.5 * M_PI);
    cairo_move_to(cr, -0.5 * ext.x_advance, 0.0);
    cairo_show_text(cr, text.c_str());
    cairo_restore(cr);
}

// Text with its anchor at (x, baseline y): 0 left, 0.5 centre, 1 right.
void showAnchored(cairo_t* cr, double x, double y, const std::string& text, double anchor) {
    cairo_text_extents_t ext;
    cairo_text_extents(cr, text.c_str(), &ext);
    cairo_move_to(cr, x - anchor * ext.x_advance, y);
    cairo_show_text(cr, text.c_str());
}

void arrowTo(cairo_t* cr, double x0, double y0, double x1, double y1) {
    const double dx = x1 - x0, dy = y1 - y0, len = std::hypot(dx, dy);
    const double ux = dx / len, uy = dy / len, head = 7.0;
    cairo_move_to(cr, x0, y0);
    cairo_line_to(cr, x1 - 0.9 * head * ux, y1 - 0.9 * head * uy);
    cairo_stroke(cr);
    cairo_move_to(cr, x1, y1);
    cairo_line_to(cr, x1 - head * ux - 0.4 * head * uy, y1 - head * uy + 0.4 * head * ux);
    cairo_line_to(cr, x1 - head * ux + 0.4 * head * uy, y1 - head * uy - 0.4 * head * ux);
    cairo_close_path(cr);
    cairo_fill(cr);
}

std::string formatNumber(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", v);
    return buf;
}

// PNG layout constants (PNG pixels).
constexpr double kMargin = 20.0;
constexpr double kYAxisSpace = 62.0;  // rotated "y (mm)" and the y tick labels
constexpr double kTitleSpace = 44.0;
constexpr double kXAxisSpace = 50.0;   // x tick labels and "x (mm)" below the image
constexpr double kMarkSpace = 76.0;    // the orientation mark below the colour bar
constexpr double kFooterSpace = 52.0;  // two lines of notes
constexpr double kBarGap = 30.0;
constexpr double kBarWidth = 24.0;
constexpr double kLabelSpace = 96.0;  // tick labels and the rotated quantity label
constexpr double kMinBarHeight = 200.0;
constexpr double kTickLength = 5.0;
constexpr double kLabelSize = 12.0;
constexpr double kNoteSize = 12.0;
constexpr double kTitleSize = 15.0;

double textWidth(const std::string& s, double sizePx) { return Picture::textWidthPt(s, sizePx); }

// Layers one file can hold: at least one, each with an image, on one pixel grid, with
// distinct usable names (an empty name only alone).
void checkLayers(const std::vector<ImageLayer>& layers) {
    if (layers.empty()) throw std::invalid_argument("detector image layers: no layers");
    std::set<std::string> names;
    for (const ImageLayer& l : layers) {
        if (!l.image) throw std::invalid_argument("detector image layers: layer without an image");
        if (l.name.empty() && layers.size() > 1)
            throw std::invalid_argument("detector image layers: several layers need names");
        if (!l.name.empty() && (l.name.front() == '.' || l.name.back() == '.'))
            throw std::invalid_argument("detector image layers: bad layer name '" + l.name + "'");
        if (!names.insert(l.name).second)
            throw std::invalid_argument("detector image layers: layer '" + l.name + "' twice");
        if (l.image->pixelsX() != layers[0].image->pixelsX() ||
            l.image->pixelsY() != layers[0].image->pixelsY())
            throw std::invalid_argument("detector image layers: layers on different pixel grids");
    }
}

}  // namespace

// OpenEXR Output Definitions

void writeDetectorExr(const std::filesystem::path& path, const DetectorImage& image,
                      const ExrInfo& info) {
    writeDetectorExr(path, {ImageLayer{"", &image}}, info);
}

void writeDetectorExr(const std::filesystem::path& path, const std::vector<ImageLayer>& layers,
                      const ExrInfo& info) {
    checkLayers(layers);
    const DetectorImage& first = *layers[0].image;
    const DetectorGeometry& g = first.geometry();
    const int width = first.pixelsX(), height = first.pixelsY();
    const size_t n = static_cast<size_t>(first.pixelCount());
    const float aspect = static_cast<float>(g.pixelWidthMm() / g.pixelHeightMm());

    Imf::Header header(width, height, aspect);
    header.compression() = Imf::ZIP_COMPRESSION;
    header.insert("veil.detector", Imf::StringAttribute(g.name));
    header.insert("veil.fluxUnit", Imf::StringAttribute(info.fluxUnit));
    header.insert("veil.irradianceUnit", Imf::StringAttribute(info.fluxUnit + "/mm^2"));
    header.insert("veil.emittedRays", Imf::DoubleAttribute(static_cast<double>(info.emittedRays)));
    header.insert("veil.detectorSizeMm", Imf::V2dAttribute(Imath::V2d(g.widthMm, g.heightMm)));
    header.insert("veil.pixelSizeMm",
                  Imf::V2dAttribute(Imath::V2d(g.pixelWidthMm(), g.pixelHeightMm())));
    Imf::addComments(header, "veil detector image: value = flux per pixel [" + info.fluxUnit +
                                 "], irradiance = value / pixel area [" + info.fluxUnit +
                                 "/mm^2], variance = variance of value [" + info.fluxUnit +
                                 "^2], count = rays per pixel; value, irradiance and variance "
                                 "are stored divided by veil[.layer].<channel>Scale");

    // Float copies of every channel, kept alive until writePixels() is done.
    std::vector<std::vector<float>> data;
    data.reserve(layers.size() * kFields.size());
    Imf::FrameBuffer frame;
    std::vector<double> x(n);
    for (const ImageLayer& l : layers) {
        const DetectorImage& im = *l.image;
        header.insert(attributeName(l.name, "totalFlux"), Imf::DoubleAttribute(im.totalFlux()));
        header.insert(attributeName(l.name, "totalRelativeError"),
                      Imf::DoubleAttribute(im.totalRelativeError(info.emittedRays)));
        for (const char* field : kFields) {
            const std::string f = field;
            for (size_t i = 0; i < n; ++i) {
                const int p = static_cast<int>(i);
                if (f == "value")
                    x[i] = im.flux(p);
                else if (f == "irradiance")
                    x[i] = im.irradiance(p);
                else if (f == "variance")
                    x[i] = im.pixelVariance(p, info.emittedRays);
                else
                    x[i] = static_cast<double>(im.count(p));
            }
            // Counts are integers, exact as floats up to 2^24: stored unscaled.
            const int k = f == "count" ? 0 : scaleExponent(x);
            if (f != "count")
                header.insert(attributeName(l.name, f + "Scale"),
                              Imf::DoubleAttribute(std::ldexp(1.0, k)));
            std::vector<float>& v = data.emplace_back(n);
            for (size_t i = 0; i < n; ++i) v[i] = storedValue(x[i], k);
            const std::string channel = channelName(l.name, field);
            header.channels().insert(channel, Imf::Channel(Imf::FLOAT));
            frame.insert(channel, Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(v.data()),
                                             sizeof(float), sizeof(float) * width));
        }
    }

    const std::filesystem::path tmp = temporaryFor(path);
    try {
        Imf::OutputFile file(tmp.c_str(), header);
        file.setFrameBuffer(frame);
        file.writePixels(height);
    } catch (const std::exception& e) {
        removeQuietly(tmp);
        throw std::runtime_error("cannot write " + path.string() + ": " + e.what());
    }
    commitFile(tmp, path);
}

DetectorExr detectorLayers(const std::vector<ImageLayer>& layers, const ExrInfo& info) {
    checkLayers(layers);
    const DetectorImage& first = *layers[0].image;
    const DetectorGeometry& g = first.geometry();
    DetectorExr out;
    out.width = first.pixelsX();
    out.height = first.pixelsY();
    out.pixelAspectRatio = static_cast<float>(g.pixelWidthMm() / g.pixelHeightMm());
    out.detector = g.name;
    out.fluxUnit = info.fluxUnit;
    out.irradianceUnit = info.fluxUnit + "/mm^2";
    out.emittedRays = static_cast<double>(info.emittedRays);
    out.detectorSizeMm = Vec2(g.widthMm, g.heightMm);
    out.pixelSizeMm = Vec2(g.pixelWidthMm(), g.pixelHeightMm());
    const int n = first.pixelCount();
    for (const ImageLayer& l : layers) {
        const DetectorImage& im = *l.image;
        ExrLayer& e = out.layers.emplace_back();
        e.name = l.name;
        e.totalFlux = im.totalFlux();
        e.totalRelativeError = im.totalRelativeError(info.emittedRays);
        for (int p = 0; p < n; ++p) {
            e.value.push_back(im.flux(p));
            e.irradiance.push_back(im.irradiance(p));
            e.variance.push_back(im.pixelVariance(p, info.emittedRays));
            e.count.push_back(static_cast<double>(im.count(p)));
        }
    }
    return out;
}

const ExrLayer* DetectorExr::layer(const std::string& name) const {
    for (const ExrLayer& l : layers)
        if (l.name == name) return &l;
    return nullptr;
}

std::ostream& operator<<(std::ostream& os, const DetectorExr& e) {
    os << "DetectorExr{'" << e.detector << "', " << e.width << " x " << e.height << " pixels, "
       << e.detectorSizeMm.x << " x " << e.detectorSizeMm.y << " mm, " << e.emittedRays << " rays, "
       << e.fluxUnit << ", layers";
    for (const ExrLayer& l : e.layers) os << " '" << l.name << "'";
    return os << "}";
}

DetectorExr readDetectorExr(const std::filesystem::path& path) {
    DetectorExr out;
    try {
        Imf::InputFile file(path.c_str());
        const Imf::Header& h = file.header();
        const Imath::Box2i dw = h.dataWindow();
        out.width = dw.max.x - dw.min.x + 1;
        out.height = dw.max.y - dw.min.y + 1;
        out.pixelAspectRatio = h.pixelAspectRatio();
        auto string = [&](const char* name) {
            const auto* a = h.findTypedAttribute<Imf::StringAttribute>(name);
            return a ? a->value() : std::string();
        };
        auto number = [&](const std::string& name) {
            const auto* a = h.findTypedAttribute<Imf::DoubleAttribute>(name);
            return a ? a->value() : std::numeric_limits<double>::quiet_NaN();
        };
        auto vec2 = [&](const char* name) {
            const auto* a = h.findTypedAttribute<Imf::V2dAttribute>(name);
            return a ? Vec2(a->value().x, a->value().y) : Vec2(0.0);
        };
        out.detector = string("veil.detector");
        out.fluxUnit = string("veil.fluxUnit");
        out.irradianceUnit = string("veil.irradianceUnit");
        out.emittedRays = number("veil.emittedRays");
        out.detectorSizeMm = vec2("veil.detectorSizeMm");
        out.pixelSizeMm = vec2("veil.pixelSizeMm");

        // Layers: every channel "<layer>.<field>" or "<field>" with a known field.
        std::map<std::string, std::set<std::string>> found;
        for (auto it = h.channels().begin(); it != h.channels().end(); ++it) {
            const std::string name = it.name();
            const size_t dot = name.rfind('.');
            const std::string layer = dot == std::string::npos ? "" : name.substr(0, dot);
            const std::string field = dot == std::string::npos ? name : name.substr(dot + 1);
            if (std::find(kFields.begin(), kFields.end(), field) != kFields.end())
                found[layer].insert(field);
        }
        const size_t n = static_cast<size_t>(out.width) * out.height;
        out.layers.reserve(found.size());
        // The floats as stored, kFields.size() channels per layer in layer order; reserved,
        // so the buffers handed to the frame buffer never move.
        std::vector<std::vector<float>> stored;
        stored.reserve(found.size() * kFields.size());
        Imf::FrameBuffer frame;
        for (const auto& entry : found) {
            // Named, not a structured binding: the lambda below captures it (clang 14).
            const auto& layer = entry.first;
            const auto& fields = entry.second;
            if (fields.size() != kFields.size())
                throw std::runtime_error("layer '" + layer + "' lacks some of the channels " +
                                         "value, irradiance, variance, count");
            ExrLayer& l = out.layers.emplace_back();
            l.name = layer;
            l.totalFlux = number(attributeName(layer, "totalFlux"));
            l.totalRelativeError = number(attributeName(layer, "totalRelativeError"));
            // Files written before the scales existed hold physical values: scale 1.
            auto scale = [&](const char* what) {
                const double s = number(attributeName(layer, what));
                return std::isnan(s) ? 1.0 : s;
            };
            l.valueScale = scale("valueScale");
            l.irradianceScale = scale("irradianceScale");
            l.varianceScale = scale("varianceScale");
            for (size_t f = 0; f < kFields.size(); ++f) {
                std::vector<float>& v = stored.emplace_back(n, 0.0f);
                frame.insert(channelName(layer, kFields[f]),
                             Imf::Slice::Make(Imf::FLOAT, v.data(), dw, sizeof(float),
                                              sizeof(float) * out.width));
            }
        }
        file.setFrameBuffer(frame);
        file.readPixels(dw.min.y, dw.max.y);

        // Physical values: the scales are powers of two, so the products are exact.
        for (size_t i = 0; i < out.layers.size(); ++i) {
            ExrLayer& l = out.layers[i];
            const std::array<std::vector<double>*, 4> targets = {&l.value, &l.irradiance,
                                                                 &l.variance, &l.count};
            const std::array<double, 4> scales = {l.valueScale, l.irradianceScale, l.varianceScale,
                                                  1.0};
            for (size_t f = 0; f < kFields.size(); ++f) {
                const std::vector<float>& v = stored[i * kFields.size() + f];
                targets[f]->resize(n);
                for (size_t p = 0; p < n; ++p)
                    (*targets[f])[p] = static_cast<double>(v[p]) * scales[f];
            }
        }
    } catch (const std::exception& e) {
        throw std::runtime_error("cannot read " + path.string() + ": " + e.what());
    }
    return out;
}

// PNG Preview Definitions

Color falseColour(double t) {
    if (!(t > 0.0)) t = 0.0;  // NaN too
    if (t > 1.0) t = 1.0;
    const double x = t * (kViridis.size() - 1);
    const size_t i = std::min(static_cast<size_t>(x), kViridis.size() - 2);
    const double f = x - static_cast<double>(i);
    const Color a = Color::hex(kViridis[i]), b = Color::hex(kViridis[i + 1]);
    return {a.r + f * (b.r - a.r), a.g + f * (b.g - a.g), a.b + f * (b.b - a.b), 1.0};
}

Color previewColour(double value, double minValue, double maxValue) {
    if (!(value > 0.0) || !(maxValue > 0.0) || !(minValue > 0.0)) return {0.0, 0.0, 0.0, 1.0};
    if (!(maxValue > minValue)) return falseColour(value >= maxValue ? 1.0 : 0.0);
    return falseColour(std::log10(value / minValue) / std::log10(maxValue / minValue));
}

void PreviewScale::check() const {
    if (!(decades >= 0.0 && std::isfinite(decades)))
        throw std::invalid_argument("preview decades must be > 0 (or 0: chosen from the light)");
    if (fixed() || lo != 0.0) {
        if (!(lo > 0.0 && hi > lo && std::isfinite(hi)))
            throw std::invalid_argument("a preview range needs 0 < low < high, both finite");
    }
}

double previewValue(const DetectorImage& image, int pixel, PreviewQuantity quantity) {
    return quantity == PreviewQuantity::Irradiance ? image.irradiance(pixel) : image.flux(pixel);
}

std::string previewLabel(PreviewQuantity quantity, const std::string& fluxUnit) {
    return quantity == PreviewQuantity::Irradiance ? "irradiance (" + fluxUnit + "/mm\u00b2)"
                                                   : "flux per pixel (" + fluxUnit + ")";
}

PreviewLayout previewLayout(const DetectorImage& image, const PreviewOptions& options) {
    options.scale.check();
    if (options.imageSizePx < 16)
        throw std::invalid_argument("writeDetectorPng: imageSizePx must be >= 16");
    const DetectorGeometry& g = image.geometry();
    PreviewLayout l;
    const double size = options.imageSizePx;
    if (g.widthMm >= g.heightMm) {
        l.imageW = size;
        l.imageH = std::max(1.0, std::round(size * g.heightMm / g.widthMm));
    } else {
        l.imageH = size;
        l.imageW = std::max(1.0, std::round(size * g.widthMm / g.heightMm));
    }
    l.imageX = kMargin + kYAxisSpace;
    l.imageY = kTitleSpace;
    l.barX = l.imageX + l.imageW + kBarGap;
    l.barY = l.imageY;
    l.barW = kBarWidth;
    l.barH = std::max(l.imageH, kMinBarHeight);
    l.widthPx = static_cast<int>(l.barX + l.barW + kLabelSpace);
    l.markX = l.barX + 10.0;
    l.markY = l.barY + l.barH + 50.0;
    const double content =
        std::max(l.imageY + l.imageH + kXAxisSpace, l.barY + l.barH + kMarkSpace);
    l.heightPx = static_cast<int>(content + kFooterSpace);
    l.title = options.title.empty() ? "Detector " + g.name : options.title;
    // Axes: at most one tick per 55 px.
    l.widthMm = g.widthMm;
    l.heightMm = g.heightMm;
    l.xTicks = niceTicks(-0.5 * g.widthMm, 0.5 * g.widthMm, std::max(2, int(l.imageW / 55.0)));
    l.yTicks = niceTicks(-0.5 * g.heightMm, 0.5 * g.heightMm, std::max(2, int(l.imageH / 55.0)));
    for (int p = 0; p < image.pixelCount(); ++p)
        l.imageMax = std::max(l.imageMax, previewValue(image, p, options.quantity));
    // The scale (PreviewScale), from the range's light.
    const PreviewScale& sc = options.scale;
    const DetectorImage& from = options.rangeImage ? *options.rangeImage : image;
    std::vector<double> lit;
    for (int p = 0; p < from.pixelCount(); ++p) {
        const double v = previewValue(from, p, options.quantity);
        if (v > 0.0 && std::isfinite(v)) lit.push_back(v);
    }
    std::sort(lit.begin(), lit.end());
    if (sc.fixed()) {
        l.maxValue = sc.hi;
        l.minValue = sc.lo;
    } else if (!lit.empty()) {
        const size_t n = lit.size();
        if (sc.decades > 0.0) {
            l.maxValue = lit.back();
            l.minValue = l.maxValue * std::pow(10.0, -sc.decades);
        } else {
            const size_t top = n - 1 - static_cast<size_t>(PreviewScale::kAutoTopShare * n);
            const size_t bottom = static_cast<size_t>(PreviewScale::kAutoBottomQuantile * n);
            l.maxValue = lit[top];
            const double decades =
                std::clamp(std::log10(l.maxValue / lit[std::min(bottom, top)]),
                           PreviewScale::kAutoMinDecades, PreviewScale::kAutoMaxDecades);
            l.minValue = l.maxValue * std::pow(10.0, -decades);
        }
    }
    if (l.maxValue > 0.0)
        for (int p = 0; p < image.pixelCount(); ++p)
            if (previewValue(image, p, options.quantity) > l.maxValue) ++l.above;

    // Notes below: the grid and the values, then the view; the page widens to hold them.
    std::ostringstream values;
    values << formatNumber(g.widthMm) << " x " << formatNumber(g.heightMm) << " mm, "
           << image.pixelsX() << " x " << image.pixelsY() << " pixels; ";
    const std::string unit = unitOf(options.quantity, options.fluxUnit);
    if (l.imageMax > 0.0) {
        values << "max " << formatNumber(l.imageMax) << " " << unit;
        if (l.maxValue > 0.0) {
            values << "; scale " << formatNumber(l.minValue) << " to " << formatNumber(l.maxValue)
                   << " ("
                   << (sc.fixed() ? std::string("--range")
                       : sc.decades > 0.0
                           ? formatNumber(sc.decades) + " decades"
                           : "auto, " + formatNumber(std::log10(l.maxValue / l.minValue)) +
                                 " decades")
                   << (options.rangeImage && !options.rangeName.empty()
                           ? " of the " + options.rangeName
                           : std::string())
                   << ")";
            if (l.above > 0) values << ", " << l.above << " pixels above";
        }
    } else {
        values << "no flux";
    }
    if (options.emittedRays > 0)
        values << "; total " << formatNumber(image.totalFlux()) << " " << options.fluxUnit
               << " \u00b1 " << formatNumber(100.0 * image.totalRelativeError(options.emittedRays))
               << " %";
    l.notes = {values.str(),
               "Seen from behind the detector (from its local +z side), looking back at the lens"};
    double widest = textWidth(l.title, kTitleSize);
    for (const std::string& n : l.notes) widest = std::max(widest, textWidth(n, kNoteSize));
    l.widthPx = std::max(l.widthPx, static_cast<int>(std::ceil(2.0 * kMargin + widest)));
    return l;
}

namespace {

// The detector pixels, one image pixel each (to be scaled up without smoothing).
cairo_surface_t* detectorPixels(const DetectorImage& image, const PreviewOptions& options,
                                const PreviewLayout& l) {
    const int nx = image.pixelsX(), ny = image.pixelsY();
    cairo_surface_t* pixels = cairo_image_surface_create(CAIRO_FORMAT_RGB24, nx, ny);
    cairo_surface_flush(pixels);
    unsigned char* data = cairo_image_surface_get_data(pixels);
    const int stride = cairo_image_surface_get_stride(pixels);
    for (int row = 0; row < ny; ++row) {
        auto* line = reinterpret_cast<uint32_t*>(data + static_cast<size_t>(row) * stride);
        for (int column = 0; column < nx; ++column) {
            const double v = previewValue(image, image.pixelIndex(column, row), options.quantity);
            const Color c = previewColour(v, l.minValue, l.maxValue);
            line[column] = (0xFFu << 24) | (uint32_t(toByte(c.r)) << 16) |
                           (uint32_t(toByte(c.g)) << 8) | uint32_t(toByte(c.b));
        }
    }
    cairo_surface_mark_dirty(pixels);

    return pixels;
}

// The detector area, scaled up without smoothing, and its frame.
void drawDetectorArea(cairo_t* cr, cairo_surface_t* pixels, const DetectorImage& image,
                      const PreviewLayout& l) {
    const int nx = image.pixelsX(), ny = image.pixelsY();
    cairo_save(cr);
    cairo_rectangle(cr, l.imageX, l.imageY, l.imageW, l.imageH);
    cairo_clip(cr);
    cairo_translate(cr, l.imageX, l.imageY);
    cairo_scale(cr, l.imageW / nx, l.imageH / ny);
    cairo_set_source_surface(cr, pixels, 0.0, 0.0);
    cairo_pattern_set_filter(cairo_get_source(cr), CAIRO_FILTER_NEAREST);
    cairo_paint(cr);
    cairo_restore(cr);
    cairo_set_source_rgb(cr, 0.5, 0.5, 0.5);
    cairo_set_line_width(cr, 1.0);
    cairo_rectangle(cr, l.imageX - 0.5, l.imageY - 0.5, l.imageW + 1.0, l.imageH + 1.0);
    cairo_stroke(cr);

}

// Axes in detector-local mm: ticks outside the image, labels, axis names.
void drawAxes(cairo_t* cr, const PreviewLayout& l) {
    cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
    cairo_set_line_width(cr, 1.0);
    cairo_set_font_size(cr, kLabelSize);
    const double bottom = l.imageY + l.imageH, left = l.imageX;
    for (double x : l.xTicks.values) {
        const double px = std::round(l.xPx(x)) + 0.5;
        cairo_move_to(cr, px, bottom + 0.5);
        cairo_line_to(cr, px, bottom + 0.5 + kTickLength);
        cairo_stroke(cr);
        showAnchored(cr, px, bottom + kTickLength + 14.0, l.xTicks.label(x), 0.5);
    }
    for (double y : l.yTicks.values) {
        const double py = std::round(l.yPx(y)) + 0.5;
        cairo_move_to(cr, left - 0.5, py);
        cairo_line_to(cr, left - 0.5 - kTickLength, py);
        cairo_stroke(cr);
        showAnchored(cr, left - kTickLength - 4.0, py + 0.36 * kLabelSize, l.yTicks.label(y), 1.0);
    }
    showAnchored(cr, l.imageX + 0.5 * l.imageW, bottom + kTickLength + 36.0, "x (mm)", 0.5);
    showUpward(cr, kMargin + 8.0, l.imageY + 0.5 * l.imageH, "y (mm)");

}

// Orientation mark: +x right, +y up, +z toward the viewer (a dot in a circle).
void drawOrientationMark(cairo_t* cr, const PreviewLayout& l) {
    const double x0 = l.markX, y0 = l.markY, len = 34.0;
    cairo_set_line_width(cr, 1.5);
    arrowTo(cr, x0, y0, x0 + len, y0);
    arrowTo(cr, x0, y0, x0, y0 - len);
    cairo_set_line_width(cr, 1.2);
    cairo_new_path(cr);
    cairo_arc(cr, x0, y0, 4.5, 0.0, 2.0 * M_PI);
    cairo_set_source_rgb(cr, 1.0, 1.0, 1.0);
    cairo_fill_preserve(cr);
    cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
    cairo_stroke(cr);
    cairo_arc(cr, x0, y0, 1.5, 0.0, 2.0 * M_PI);
    cairo_fill(cr);
    cairo_set_font_size(cr, kLabelSize);
    showAnchored(cr, x0 + len + 4.0, y0 + 0.36 * kLabelSize, "+x", 0.0);
    showAnchored(cr, x0 + 6.0, y0 - len + 6.0, "+y", 0.0);
    showAnchored(cr, x0 - 6.0, y0 + 19.0, "+z toward you", 0.0);
}

// The colour bar, one row of PNG pixels per step (top = maximum), its ticks at the powers of
// ten inside [minValue, maxValue] and the quantity with its unit, reading upward.
void drawColourBar(cairo_t* cr, const PreviewLayout& l, const PreviewOptions& options) {
    cairo_set_line_width(cr, 1.0);
    const int barRows = static_cast<int>(l.barH);
    for (int i = 0; i < barRows; ++i) {
        const Color c = falseColour(1.0 - (i + 0.5) / barRows);
        cairo_set_source_rgb(cr, c.r, c.g, c.b);
        cairo_rectangle(cr, l.barX, l.barY + i, l.barW, 1.0);
        cairo_fill(cr);
    }
    cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
    cairo_rectangle(cr, l.barX - 0.5, l.barY - 0.5, l.barW + 1.0, l.barH + 1.0);
    cairo_stroke(cr);

    // Ticks at the powers of ten inside [minValue, maxValue]; on a scale of less than
    // kLinearTicksBelow decades, at round values instead.
    constexpr double kLinearTicksBelow = 1.5;
    const double labelSize = kLabelSize;
    cairo_set_line_width(cr, 1.0);
    if (l.maxValue > 0.0 && l.maxValue > l.minValue) {
        const double top = std::log10(l.maxValue);
        const double decades = top - std::log10(l.minValue);
        auto tick = [&](double y) {
            cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
            cairo_move_to(cr, l.barX + l.barW, y);
            cairo_line_to(cr, l.barX + l.barW + 5.0, y);
            cairo_stroke(cr);
        };
        int drawn = 0;
        if (decades < kLinearTicksBelow) {
            const Ticks t = niceTicks(l.minValue, l.maxValue, 6);
            cairo_set_font_size(cr, labelSize);
            for (double v : t.values) {
                if (!(v > 0.0)) continue;
                const double y = l.barY + l.barH * (top - std::log10(v)) / decades;
                tick(y);
                cairo_move_to(cr, l.barX + l.barW + 8.0, y + 0.35 * labelSize);
                cairo_show_text(cr, formatNumber(v).c_str());
                ++drawn;
            }
        } else {
            const int kHi = static_cast<int>(std::floor(top));
            const int kLo = static_cast<int>(std::ceil(top - decades));
            // At most about 12 labels: every step-th power.
            const int step = std::max(1, (kHi - kLo + 12) / 12);
            for (int k = kHi; k >= kLo; --k) {
                const double y = l.barY + l.barH * (top - k) / decades;
                tick(y);
                if ((kHi - k) % step == 0) {
                    drawPowerOfTen(cr, l.barX + l.barW + 8.0, y + 0.35 * labelSize, k, labelSize);
                    ++drawn;
                }
            }
        }
        if (drawn == 0) {
            cairo_set_font_size(cr, labelSize);
            cairo_move_to(cr, l.barX + l.barW + 8.0, l.barY + 0.35 * labelSize);
            cairo_show_text(cr, formatNumber(l.maxValue).c_str());
        }
    }
    // The quantity and its unit along the bar, reading upward.
    cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
    cairo_set_font_size(cr, 13.0);
    showUpward(cr, l.barX + l.barW + kLabelSpace - 20.0, l.barY + 0.5 * l.barH,
               previewLabel(options.quantity, options.fluxUnit));

}

void drawTitleAndNotes(cairo_t* cr, const PreviewLayout& l) {
    cairo_set_font_size(cr, kTitleSize);
    cairo_move_to(cr, kMargin, 27.0);
    cairo_show_text(cr, l.title.c_str());
    cairo_set_font_size(cr, kNoteSize);
    for (size_t i = 0; i < l.notes.size(); ++i) {
        cairo_move_to(cr, kMargin, l.heightPx - kFooterSpace + 20.0 + 17.0 * i);
        cairo_show_text(cr, l.notes[i].c_str());
    }

}

}  // namespace

void writeDetectorPng(const std::filesystem::path& path, const DetectorImage& image,
                      const PreviewOptions& options) {
    const PreviewLayout l = previewLayout(image, options);
    cairo_surface_t* pixels = detectorPixels(image, options, l);
    cairo_surface_t* s = cairo_image_surface_create(CAIRO_FORMAT_RGB24, l.widthPx, l.heightPx);
    cairo_t* cr = cairo_create(s);
    cairo_set_source_rgb(cr, 1.0, 1.0, 1.0);
    cairo_paint(cr);
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    drawDetectorArea(cr, pixels, image, l);
    drawAxes(cr, l);
    drawOrientationMark(cr, l);
    drawColourBar(cr, l, options);
    drawTitleAndNotes(cr, l);
    cairo_destroy(cr);
    cairo_surface_destroy(pixels);
    const std::filesystem::path tmp = temporaryFor(path);
    const cairo_status_t status = cairo_surface_write_to_png(s, tmp.c_str());
    cairo_surface_destroy(s);
    if (status != CAIRO_STATUS_SUCCESS) {
        removeQuietly(tmp);
        throw std::runtime_error("cannot write " + path.string() + ": " +
                                 cairo_status_to_string(status));
    }
    commitFile(tmp, path);
}

}  // namespace veil
