// Detector images on disk: EXR round trips that are exact for float values and keep float
// precision far below float's range (dark runs), PNG previews that decode to the expected
// size and colours, and no file left under a temporary name.

#include "analysis/reports/image_output.h"

#include <cairo.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "tracer/records/detector.h"
#include "tracer/runtime/rng.h"

namespace veil {
namespace {

// A fresh folder per test for files we write.
std::filesystem::path scratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::filesystem::path dir = std::filesystem::path(VEIL_BINARY_DIR) / "test_scratch" /
                                      "image_output" /
                                      (std::string(info->test_suite_name()) + "." + info->name());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

std::vector<std::string> filesIn(const std::filesystem::path& dir) {
    std::vector<std::string> names;
    for (const auto& e : std::filesystem::directory_iterator(dir))
        names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
}

// 7 x 5 pixels on 3.5 x 2 mm (non-square pixels of 0.5 x 0.4 mm).
DetectorGeometry grid() {
    DetectorGeometry g;
    g.name = "sensor";
    g.widthMm = 3.5;
    g.heightMm = 2.0;
    g.pixelsX = 7;
    g.pixelsY = 5;
    return g;
}

// Random contributions over many decades, some pixels left empty.
DetectorImage randomImage(uint64_t seed, uint64_t rays) {
    DetectorImage im(grid());
    for (uint64_t i = 0; i < rays; ++i) {
        CounterRng rng(seed, i);
        const int pixel = static_cast<int>(rng.next32() % 30);  // pixels 30..34 stay empty
        im.add(pixel, std::pow(10.0, -12.0 * rng.uniform()) * rng.uniform());
    }
    return im;
}

// OpenEXR Tests

TEST(DetectorExr, RoundTripIsExactForFloats) {
    const std::filesystem::path dir = scratchDir();
    const uint64_t n = 5000;
    const DetectorImage im = randomImage(1, 400);
    const std::filesystem::path path = dir / "sensor.exr";
    writeDetectorExr(path, im, {"lm", n});
    EXPECT_EQ(filesIn(dir), std::vector<std::string>{"sensor.exr"});

    const DetectorExr e = readDetectorExr(path);
    EXPECT_EQ(e.width, 7);
    EXPECT_EQ(e.height, 5);
    EXPECT_EQ(e.detector, "sensor");
    EXPECT_EQ(e.fluxUnit, "lm");
    EXPECT_EQ(e.irradianceUnit, "lm/mm^2");
    EXPECT_EQ(e.emittedRays, 5000.0);
    EXPECT_EQ(e.detectorSizeMm, Vec2(3.5, 2.0));
    EXPECT_EQ(e.pixelSizeMm, Vec2(0.5, 0.4));
    EXPECT_FLOAT_EQ(e.pixelAspectRatio, 1.25f);
    ASSERT_EQ(e.layers.size(), 1u);
    const ExrLayer& l = e.layers[0];
    EXPECT_EQ(l.name, "");
    EXPECT_EQ(l.totalFlux, im.totalFlux());
    EXPECT_EQ(l.totalRelativeError, im.totalRelativeError(n));
    for (int p = 0; p < im.pixelCount(); ++p) {
        EXPECT_EQ(l.value[p], static_cast<float>(im.flux(p))) << p;
        EXPECT_EQ(l.irradiance[p], static_cast<float>(im.flux(p) / 0.2)) << p;
        EXPECT_EQ(l.variance[p], static_cast<float>(im.pixelVariance(p, n))) << p;
        EXPECT_EQ(l.count[p], static_cast<float>(im.count(p))) << p;
    }
    EXPECT_EQ(l.value[30], 0.0f);
    EXPECT_GT(l.value[0], 0.0f);
}

TEST(DetectorExr, LayersKeepTheirNames) {
    const std::filesystem::path dir = scratchDir();
    const DetectorImage direct = randomImage(2, 300), ghosts = randomImage(3, 50);
    const std::filesystem::path path = dir / "layers.exr";
    writeDetectorExr(path, {{"direct", &direct}, {"ghosts.L1-L2", &ghosts}}, {"W", 1000});
    const DetectorExr e = readDetectorExr(path);
    ASSERT_EQ(e.layers.size(), 2u);
    const ExrLayer* d = e.layer("direct");
    const ExrLayer* g = e.layer("ghosts.L1-L2");
    ASSERT_TRUE(d && g);
    EXPECT_EQ(e.layer("other"), nullptr);
    EXPECT_EQ(d->totalFlux, direct.totalFlux());
    EXPECT_EQ(g->totalFlux, ghosts.totalFlux());
    for (int p = 0; p < direct.pixelCount(); ++p) {
        EXPECT_EQ(d->value[p], static_cast<float>(direct.flux(p)));
        EXPECT_EQ(g->value[p], static_cast<float>(ghosts.flux(p)));
        EXPECT_EQ(g->count[p], static_cast<float>(ghosts.count(p)));
    }
    EXPECT_EQ(filesIn(dir), std::vector<std::string>{"layers.exr"});
}

// Every pixel with rays reads back non-zero and within float rounding of the double it was
// written from (round to nearest is off by 2^-24 relative at most; we allow epsilon, 2^-23):
// value, irradiance and variance. Empty pixels read back 0.
void expectFloatPrecision(const ExrLayer& l, const DetectorImage& im, uint64_t n) {
    const double tolerance = std::numeric_limits<float>::epsilon();
    const double area = im.geometry().pixelAreaMm2();
    int hits = 0;
    for (int p = 0; p < im.pixelCount(); ++p) {
        EXPECT_EQ(l.count[p], static_cast<double>(im.count(p))) << p;
        if (im.count(p) == 0) {
            EXPECT_EQ(l.value[p], 0.0) << p;
            continue;
        }
        ++hits;
        const double value = im.flux(p), variance = im.pixelVariance(p, n);
        ASSERT_GT(value, 0.0) << p;
        ASSERT_GT(variance, 0.0) << p;
        EXPECT_NEAR(l.value[p], value, tolerance * value) << p;
        EXPECT_NEAR(l.irradiance[p], value / area, tolerance * value / area) << p;
        EXPECT_NEAR(l.variance[p], variance, tolerance * variance) << p;
    }
    EXPECT_GT(hits, 0);
}

bool isPowerOfTwo(double s) {
    int e = 0;
    return s > 0.0 && std::frexp(s, &e) == 0.5;
}

// A 0.1 %-mount run: fluxes around 1e-30 W, variances around 1e-60 W^2. As plain floats the
// variances (below float's 1.4e-45) would all be 0; scaled, every pixel keeps its digits.
TEST(DetectorExr, DarkImagesKeepEveryHitToFloatPrecision) {
    const std::filesystem::path dir = scratchDir();
    const uint64_t n = 100000;
    DetectorImage im(grid());
    for (uint64_t i = 0; i < 600; ++i) {
        CounterRng rng(4, i);
        const int pixel = static_cast<int>(rng.next32() % 30);  // pixels 30..34 stay empty
        im.add(pixel, 1e-30 * (0.5 + rng.uniform()));
    }
    for (int p = 0; p < 30; ++p) {
        ASSERT_GT(im.count(p), 0u) << p;
        // The data really is out of float's reach without a scale.
        ASSERT_EQ(static_cast<float>(im.pixelVariance(p, n)), 0.0f) << p;
    }
    const std::filesystem::path path = dir / "dark.exr";
    writeDetectorExr(path, {{"direct", &im}, {"ghosts", &im}}, {"W", n});
    const DetectorExr e = readDetectorExr(path);
    ASSERT_EQ(e.layers.size(), 2u);
    for (const ExrLayer& l : e.layers) {
        expectFloatPrecision(l, im, n);
        // The scales are powers of two putting each channel's largest value in [0.5, 1).
        for (auto [scale, channel] :
             {std::pair{l.valueScale, &l.value}, std::pair{l.irradianceScale, &l.irradiance},
              std::pair{l.varianceScale, &l.variance}}) {
            EXPECT_TRUE(isPowerOfTwo(scale)) << scale;
            const double stored = *std::max_element(channel->begin(), channel->end()) / scale;
            EXPECT_GE(stored, 0.5);
            EXPECT_LT(stored, 1.0);
        }
        EXPECT_LT(l.varianceScale, 1e-55);
    }
}

// Twelve decades in one layer, at a dark level (1e-18 .. 1e-30 W, variances down to 1e-60
// W^2), and 60 decades (1 W next to 1e-60 W) where a scale that only puts the largest value
// near 1 would lose the smallest: each keeps float precision.
TEST(DetectorExr, WideDynamicRangesKeepFloatPrecision) {
    const std::filesystem::path dir = scratchDir();
    const uint64_t n = 1000;
    DetectorImage mixed(grid());
    for (int p = 0; p < 30; ++p) {
        const double decade = -18.0 - 12.0 * p / 29.0;
        mixed.add(p, std::pow(10.0, decade));
        mixed.add(p, 0.3 * std::pow(10.0, decade));  // a second ray: a variance below S1^2
    }
    EXPECT_NEAR(mixed.flux(0) / mixed.flux(29), 1e12, 1e-3 * 1e12);
    DetectorImage extreme(grid());
    extreme.add(0, 1.0);
    extreme.add(1, 1e-60);
    extreme.add(2, 3e-35);
    const std::filesystem::path path = dir / "wide.exr";
    writeDetectorExr(path, {{"mixed", &mixed}, {"extreme", &extreme}}, {"W", n});
    const DetectorExr e = readDetectorExr(path);
    const ExrLayer* m = e.layer("mixed");
    const ExrLayer* x = e.layer("extreme");
    ASSERT_TRUE(m && x);
    expectFloatPrecision(*m, mixed, n);
    const double tolerance = std::numeric_limits<float>::epsilon();
    for (int p : {0, 1, 2})
        EXPECT_NEAR(x->value[p], extreme.flux(p), tolerance * extreme.flux(p)) << p;
    EXPECT_EQ(x->value[3], 0.0);
}

// Beyond float's whole range (here 120 decades) the smallest value cannot keep its digits,
// but a pixel with rays still reads back as non-empty (the smallest float, an upper bound).
TEST(DetectorExr, ValuesBeyondFloatRangeStayNonZero) {
    const std::filesystem::path dir = scratchDir();
    DetectorImage im(grid());
    im.add(0, 1e10);
    im.add(1, 1e-110);
    const std::filesystem::path path = dir / "beyond.exr";
    writeDetectorExr(path, im, {"W", 10});
    const DetectorExr e = readDetectorExr(path);
    ASSERT_EQ(e.layers.size(), 1u);
    const ExrLayer& l = e.layers[0];
    EXPECT_NEAR(l.value[0], 1e10, 1e10 * std::numeric_limits<float>::epsilon());
    EXPECT_GT(l.value[1], 0.0);
    EXPECT_LT(l.value[1], 1e-60);  // the smallest float: ~83 decades below the maximum
    EXPECT_GT(l.variance[1], 0.0);
    EXPECT_EQ(l.value[2], 0.0);
}

TEST(DetectorExr, BadRequestsAndUnwritablePathsThrowAndLeaveNothing) {
    const std::filesystem::path dir = scratchDir();
    const DetectorImage a(grid());
    DetectorGeometry other = grid();
    other.pixelsX = 8;
    const DetectorImage b(other);
    EXPECT_THROW(writeDetectorExr(dir / "x.exr", std::vector<ImageLayer>{}, {}),
                 std::invalid_argument);
    EXPECT_THROW(writeDetectorExr(dir / "x.exr", {{"a", &a}, {"b", &b}}, {}),
                 std::invalid_argument);
    EXPECT_THROW(writeDetectorExr(dir / "x.exr", {{"a", &a}, {"a", &a}}, {}),
                 std::invalid_argument);
    EXPECT_THROW(writeDetectorExr(dir / "x.exr", {{"", &a}, {"b", &a}}, {}), std::invalid_argument);
    EXPECT_THROW(writeDetectorExr(dir / "missing" / "x.exr", a, {}), std::runtime_error);
    EXPECT_THROW(readDetectorExr(dir / "missing.exr"), std::runtime_error);
    // A file in the way of the final name's folder entry: the rename fails.
    std::filesystem::create_directories(dir / "taken.exr" / "inside");
    EXPECT_THROW(writeDetectorExr(dir / "taken.exr", a, {}), std::runtime_error);
    EXPECT_EQ(filesIn(dir), std::vector<std::string>{"taken.exr"});
}

// Colour Map Tests

double luminance(const Color& c) {
    auto linear = [](double v) {
        return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);
    };
    return 0.2126 * linear(c.r) + 0.7152 * linear(c.g) + 0.0722 * linear(c.b);
}

TEST(FalseColour, IsPerceptuallyOrderedAndDistinctFromBlack) {
    double previous = -1.0;
    for (int i = 0; i <= 1000; ++i) {
        const double y = luminance(falseColour(i / 1000.0));
        EXPECT_GT(y, previous) << i;
        previous = y;
    }
    EXPECT_GT(luminance(falseColour(0.0)), 0.015);  // the darkest colour is not black
    const Color top = falseColour(1.0), bottom = falseColour(0.0);
    EXPECT_NEAR(top.r, 0xfd / 255.0, 1e-12);
    EXPECT_NEAR(top.g, 0xe7 / 255.0, 1e-12);
    EXPECT_NEAR(bottom.b, 0x54 / 255.0, 1e-12);
    EXPECT_NEAR(falseColour(2.0).r, top.r, 0.0);
    EXPECT_NEAR(falseColour(std::nan("")).b, bottom.b, 0.0);

    // Log scale: a value 3 decades below the maximum sits half way on a 6-decade scale.
    const Color mid = previewColour(1e-3, 1e-6, 1.0), half = falseColour(0.5);
    EXPECT_NEAR(mid.g, half.g, 1e-12);
    EXPECT_NEAR(previewColour(1e-9, 1e-6, 1.0).b, bottom.b, 1e-12);  // below: lowest colour
    EXPECT_NEAR(previewColour(7.0, 1e-6, 1.0).r, top.r, 1e-12);      // above: the top colour
    for (double v : {0.0, -1.0, std::nan("")}) {
        const Color c = previewColour(v, 1e-6, 1.0);
        EXPECT_EQ(c.r + c.g + c.b, 0.0) << v;
    }
}

// PNG Tests

struct Rgb {
    int r, g, b;
};
Rgb pixelAt(cairo_surface_t* s, double x, double y) {
    const unsigned char* data = cairo_image_surface_get_data(s);
    const int stride = cairo_image_surface_get_stride(s);
    const uint32_t v = *reinterpret_cast<const uint32_t*>(data + static_cast<int>(y) * stride +
                                                          4 * static_cast<int>(x));
    return {int((v >> 16) & 0xFF), int((v >> 8) & 0xFF), int(v & 0xFF)};
}
void expectColour(const Rgb& got, const Color& want, const std::string& where) {
    EXPECT_NEAR(got.r, want.r * 255.0, 1.0) << where;
    EXPECT_NEAR(got.g, want.g * 255.0, 1.0) << where;
    EXPECT_NEAR(got.b, want.b * 255.0, 1.0) << where;
}

TEST(DetectorPng, DecodesToTheLayoutWithTheExpectedColours) {
    const std::filesystem::path dir = scratchDir();
    DetectorImage im(grid());
    const double area = 0.2;
    im.add(im.pixelIndex(0, 0), 1.0 * area);   // the maximum irradiance, 1
    im.add(im.pixelIndex(3, 2), 1e-3 * area);  // half way down 6 decades
    im.add(im.pixelIndex(6, 4), 1e-8 * area);  // below the range
    PreviewOptions o;
    o.fluxUnit = "W";
    o.emittedRays = 100;
    o.scale.decades = 6.0;
    const std::filesystem::path path = dir / "sensor.png";
    writeDetectorPng(path, im, o);
    EXPECT_EQ(filesIn(dir), std::vector<std::string>{"sensor.png"});

    // Signature and IHDR size (big-endian width and height at bytes 16 and 20).
    std::ifstream in(path, std::ios::binary);
    std::vector<unsigned char> head(24);
    in.read(reinterpret_cast<char*>(head.data()), 24);
    ASSERT_TRUE(in);
    const std::vector<unsigned char> signature = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    EXPECT_EQ(std::vector<unsigned char>(head.begin(), head.begin() + 8), signature);
    auto be32 = [&](int i) {
        return (head[i] << 24) | (head[i + 1] << 16) | (head[i + 2] << 8) | head[i + 3];
    };
    const PreviewLayout l = previewLayout(im, o);
    EXPECT_EQ(be32(16), l.widthPx);
    EXPECT_EQ(be32(20), l.heightPx);
    EXPECT_EQ(l.imageW, 800.0);
    EXPECT_NEAR(l.imageH, 800.0 * 2.0 / 3.5, 0.5);  // physical aspect
    EXPECT_DOUBLE_EQ(l.maxValue, 1.0);
    EXPECT_NEAR(l.minValue, 1e-6, 1e-18);

    // Decoded by Cairo: colours at the centres of detector pixels.
    cairo_surface_t* s = cairo_image_surface_create_from_png(path.c_str());
    ASSERT_EQ(cairo_surface_status(s), CAIRO_STATUS_SUCCESS);
    EXPECT_EQ(cairo_image_surface_get_width(s), l.widthPx);
    EXPECT_EQ(cairo_image_surface_get_height(s), l.heightPx);
    cairo_surface_flush(s);
    auto centre = [&](int column, int row) {
        return pixelAt(s, l.imageX + (column + 0.5) * l.imageW / 7.0,
                       l.imageY + (row + 0.5) * l.imageH / 5.0);
    };
    expectColour(centre(0, 0), falseColour(1.0), "maximum");
    expectColour(centre(3, 2), falseColour(0.5), "1e-3 of the maximum");
    expectColour(centre(6, 4), falseColour(0.0), "below the range");
    expectColour(centre(1, 0), {0, 0, 0, 1}, "empty pixel");
    // The colour bar is linear in log(value): the maximum at the top edge, the bottom of
    // the range at the bottom edge.
    for (int row : {0, 1, static_cast<int>(l.barH / 2), static_cast<int>(l.barH) - 1}) {
        const double t = 1.0 - (row + 0.5) / l.barH;
        expectColour(pixelAt(s, l.barX + l.barW / 2, l.barY + row), falseColour(t),
                     "bar row " + std::to_string(row));
    }
    cairo_surface_destroy(s);
}

bool dark(const Rgb& c) { return c.r < 100 && c.g < 100 && c.b < 100; }
bool white(const Rgb& c) { return c.r > 240 && c.g > 240 && c.b > 240; }

TEST(DetectorPng, AxesAreTickedInDetectorMillimetres) {
    const std::filesystem::path dir = scratchDir();
    DetectorGeometry g = grid();  // 3.5 x 2 mm
    DetectorImage im(g);
    im.add(im.pixelIndex(3, 2), 1.0);
    PreviewOptions o;
    const PreviewLayout l = previewLayout(im, o);
    // Round steps (niceTicks) over the detector's local extent, x across, y down.
    EXPECT_EQ(l.xTicks.step, 0.5);
    EXPECT_EQ(l.xTicks.values.front(), -1.5);
    EXPECT_EQ(l.xTicks.values.back(), 1.5);
    EXPECT_EQ(l.yTicks.values.front(), -1.0);
    EXPECT_EQ(l.yTicks.values.back(), 1.0);
    // Local x = -width/2 at the image's left edge, y = +height/2 at its top (row 0).
    EXPECT_DOUBLE_EQ(l.xPx(-1.75), l.imageX);
    EXPECT_DOUBLE_EQ(l.xPx(1.75), l.imageX + l.imageW);
    EXPECT_DOUBLE_EQ(l.yPx(1.0), l.imageY);
    EXPECT_DOUBLE_EQ(l.yPx(-1.0), l.imageY + l.imageH);

    const std::filesystem::path path = dir / "ticks.png";
    writeDetectorPng(path, im, o);
    cairo_surface_t* s = cairo_image_surface_create_from_png(path.c_str());
    ASSERT_EQ(cairo_surface_status(s), CAIRO_STATUS_SUCCESS);
    cairo_surface_flush(s);
    // A tick mark just outside the image at every tick, white half way between ticks.
    const double below = l.imageY + l.imageH + 3.0, left = l.imageX - 3.0;
    for (double x : l.xTicks.values) {
        EXPECT_TRUE(dark(pixelAt(s, std::round(l.xPx(x)), below))) << "x tick " << x;
        EXPECT_TRUE(white(pixelAt(s, std::round(l.xPx(x + 0.5 * l.xTicks.step)), below)))
            << "between x ticks " << x;
    }
    for (double y : l.yTicks.values) {
        EXPECT_TRUE(dark(pixelAt(s, left, std::round(l.yPx(y))))) << "y tick " << y;
        if (y < l.yTicks.values.back()) {
            EXPECT_TRUE(white(pixelAt(s, left, std::round(l.yPx(y + 0.5 * l.yTicks.step)))))
                << "between y ticks " << y;
        }
    }
    // The orientation mark: arrows from its origin toward +x (right) and +y (up).
    EXPECT_TRUE(dark(pixelAt(s, l.markX + 20.0, l.markY)));
    EXPECT_TRUE(dark(pixelAt(s, l.markX, l.markY - 20.0)));
    EXPECT_TRUE(white(pixelAt(s, l.markX - 20.0, l.markY)));
    EXPECT_TRUE(white(pixelAt(s, l.markX, l.markY + 28.0)));
    EXPECT_LT(l.markY + 30.0, l.heightPx);
    EXPECT_LT(l.markX + 60.0, l.widthPx);
    cairo_surface_destroy(s);
}

TEST(DetectorPng, TheColourBarNamesTheQuantityAndItsUnit) {
    EXPECT_EQ(previewLabel(PreviewQuantity::Irradiance, "W"), "irradiance (W/mm\u00b2)");
    EXPECT_EQ(previewLabel(PreviewQuantity::Irradiance, "lm"), "irradiance (lm/mm\u00b2)");
    EXPECT_EQ(previewLabel(PreviewQuantity::Flux, "W"), "flux per pixel (W)");
    // The notes state the view and the values with their unit; the page is wide enough.
    DetectorImage im(grid());
    im.add(0, 0.2);
    PreviewOptions o;
    o.fluxUnit = "lm";
    o.emittedRays = 10;
    const PreviewLayout l = previewLayout(im, o);
    ASSERT_EQ(l.notes.size(), 2u);
    EXPECT_NE(l.notes[0].find("max 1 lm/mm\u00b2"), std::string::npos) << l.notes[0];
    EXPECT_NE(l.notes[0].find("(auto, 0.1 decades)"), std::string::npos) << l.notes[0];
    EXPECT_NE(l.notes[1].find("behind the detector"), std::string::npos);
    EXPECT_EQ(l.title, "Detector sensor");
    for (const std::string& n : l.notes) EXPECT_GT(l.widthPx, Picture::textWidthPt(n, 12.0));
}

TEST(DetectorPng, EmptyImagesAndOptions) {
    const std::filesystem::path dir = scratchDir();
    DetectorGeometry tall = grid();
    tall.widthMm = 1.0;
    tall.heightMm = 4.0;
    const DetectorImage empty(tall);
    PreviewOptions o;
    o.quantity = PreviewQuantity::Flux;
    o.imageSizePx = 300;
    o.scale.decades = 2.5;
    writeDetectorPng(dir / "empty.png", empty, o);
    const PreviewLayout l = previewLayout(empty, o);
    EXPECT_EQ(l.imageH, 300.0);
    EXPECT_EQ(l.imageW, 75.0);
    EXPECT_EQ(l.maxValue, 0.0);
    cairo_surface_t* s = cairo_image_surface_create_from_png((dir / "empty.png").c_str());
    ASSERT_EQ(cairo_surface_status(s), CAIRO_STATUS_SUCCESS);
    cairo_surface_flush(s);
    expectColour(pixelAt(s, l.imageX + l.imageW / 2, l.imageY + l.imageH / 2), {0, 0, 0, 1},
                 "no flux");
    cairo_surface_destroy(s);

    for (const PreviewScale bad :
         {PreviewScale{-1.0, 0.0, 0.0}, PreviewScale{0.0, 2.0, 1.0}, PreviewScale{0.0, 0.0, 1.0},
          PreviewScale{0.0, 1.0, 0.0}, PreviewScale{std::nan(""), 0.0, 0.0}}) {
        o.scale = bad;
        EXPECT_THROW(writeDetectorPng(dir / "bad.png", empty, o), std::invalid_argument);
    }
    o.scale = {};
    EXPECT_THROW(writeDetectorPng(dir / "missing" / "x.png", empty, o), std::runtime_error);
    EXPECT_EQ(filesIn(dir), std::vector<std::string>{"empty.png"});
}

// The automatic scale: a source's image in the frame, or a few bright single pixels, do not
// set the top; a near-uniform veil spans the colour map; the light the run asked for sets the
// scale of an image that holds more.
TEST(DetectorPng, TheAutomaticScaleFollowsTheBulkOfTheLight) {
    DetectorGeometry g = grid();  // 7 x 5 pixels
    g.pixelsX = 100;
    g.pixelsY = 100;
    g.widthMm = 10.0;
    g.heightMm = 10.0;
    const double area = 0.01;
    // A veil from 0.9 to 1.1 across the detector, and 4 pixels of a source's image at 1e6.
    DetectorImage veil(g), withImage(g);
    for (int p = 0; p < veil.pixelCount(); ++p) {
        const double v = 0.9 + 0.2 * (p % 100) / 99.0;
        veil.add(p, v * area);
        withImage.add(p, v * area);
    }
    for (int p : {5050, 5051, 5150, 5151}) withImage.add(p, 1e6 * area);
    PreviewOptions o;
    const PreviewLayout l = previewLayout(veil, o);
    // The top at the veil's brightest (only 5 pixels in 1e4 could be above it), the bottom at its
    // 1st percentile: log10(1.1 / 0.902) = 0.086 decades, widened to the least, 0.1.
    EXPECT_NEAR(l.maxValue, 1.1, 0.003);
    EXPECT_NEAR(std::log10(l.maxValue / l.minValue), PreviewScale::kAutoMinDecades, 1e-12);
    // The veil's darkest and brightest columns lie near the two ends of the colour map.
    const double tLo = std::log10(0.9 / l.minValue) / std::log10(l.maxValue / l.minValue);
    EXPECT_LT(tLo, 0.25);
    EXPECT_EQ(l.above, 0);
    // The same veil with the source's image: the image is 4 pixels above the scale, which the
    // veil still spans.
    const PreviewLayout li = previewLayout(withImage, o);
    EXPECT_NEAR(li.maxValue, 1.1, 0.003);
    EXPECT_EQ(li.above, 4);
    EXPECT_NEAR(li.imageMax, 1e6 + 1.0, 1.0);
    // When the image covers more than the share the top ignores, the light asked for (the
    // veil, as rangeImage) still sets it; the notes say so.
    DetectorImage bigImage = withImage;
    for (int p = 0; p < 400; ++p) bigImage.add(p, 1e6 * area);
    EXPECT_GT(previewLayout(bigImage, o).maxValue, 1e5);
    PreviewOptions asked = o;
    asked.rangeImage = &veil;
    asked.rangeName = "stray light";
    const PreviewLayout lb = previewLayout(bigImage, asked);
    EXPECT_NEAR(lb.maxValue, 1.1, 0.003);
    EXPECT_EQ(lb.above, 404);
    EXPECT_NE(lb.notes[0].find("of the stray light"), std::string::npos) << lb.notes[0];
    EXPECT_NE(lb.notes[0].find("404 pixels above"), std::string::npos) << lb.notes[0];
    // A fixed range is used as given; a fixed number of decades below the brightest pixel.
    PreviewOptions fixed = o;
    fixed.scale.lo = 0.5;
    fixed.scale.hi = 2.0;
    const PreviewLayout lf = previewLayout(withImage, fixed);
    EXPECT_EQ(lf.minValue, 0.5);
    EXPECT_EQ(lf.maxValue, 2.0);
    EXPECT_NE(lf.notes[0].find("--range"), std::string::npos) << lf.notes[0];
    PreviewOptions three = o;
    three.scale.decades = 3.0;
    const PreviewLayout l3 = previewLayout(withImage, three);
    EXPECT_NEAR(l3.maxValue, 1e6 + 1.0, 1.0);
    EXPECT_NEAR(l3.minValue, l3.maxValue * 1e-3, 1e-6);
    EXPECT_EQ(l3.above, 0);
    // Monte Carlo noise over many decades: at most kAutoMaxDecades.
    DetectorImage sparse(g);
    for (int p = 0; p < sparse.pixelCount(); ++p) sparse.add(p, std::pow(10.0, -(p % 9)) * area);
    const PreviewLayout ls = previewLayout(sparse, o);
    EXPECT_NEAR(std::log10(ls.maxValue / ls.minValue), PreviewScale::kAutoMaxDecades, 1e-12);
}

}  // namespace
}  // namespace veil
