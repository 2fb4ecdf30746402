// Pictures: round axis ticks checked against a brute-force count of multiples, segment
// clipping, XML escaping, and SVG output that keeps text as <text> elements, is well-formed
// XML (checked by a small parser of our own) and lays the page out as the PNG does.

#include "analysis/pictures/picture.h"

#include <cairo.h>
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "tracer/runtime/rng.h"

namespace veil {
namespace {

// A fresh folder per test for files we write.
std::filesystem::path scratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::filesystem::path dir = std::filesystem::path(VEIL_BINARY_DIR) / "test_scratch" /
                                      "picture" /
                                      (std::string(info->test_suite_name()) + "." + info->name());
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    return dir;
}

// Axis Ticks Tests

// Multiples of `step` in [lo, hi], counted one by one.
int multiplesIn(double lo, double hi, double step) {
    int n = 0;
    for (double k = std::floor(lo / step) - 1; k * step <= hi + 1e-9 * step; ++k)
        if (k * step >= lo - 1e-9 * step) ++n;
    return n;
}

bool isOneTwoFive(double step) {
    const double e = std::floor(std::log10(step) + 1e-12);
    const double m = step / std::pow(10.0, e);
    return std::abs(m - 1.0) < 1e-9 || std::abs(m - 2.0) < 1e-9 || std::abs(m - 5.0) < 1e-9;
}

TEST(NiceTicks, AreRoundMultiplesInsideTheRangeWithTheSmallestStepThatFits) {
    for (uint64_t i = 0; i < 500; ++i) {
        CounterRng rng(7, i);
        const double centre = (rng.uniform() - 0.5) * std::pow(10.0, 6.0 * rng.uniform() - 2.0);
        const double width = std::pow(10.0, 8.0 * rng.uniform() - 3.0);
        const double lo = centre - rng.uniform() * width, hi = lo + width;
        const int maxCount = 2 + static_cast<int>(rng.next32() % 15);
        const Ticks t = niceTicks(lo, hi, maxCount);
        SCOPED_TRACE(::testing::Message()
                     << "[" << lo << ", " << hi << "] max " << maxCount << ": " << t);
        ASSERT_TRUE(isOneTwoFive(t.step));
        EXPECT_LE(static_cast<int>(t.values.size()), maxCount);
        EXPECT_EQ(static_cast<int>(t.values.size()), multiplesIn(lo, hi, t.step));
        for (size_t k = 0; k < t.values.size(); ++k) {
            const double v = t.values[k];
            EXPECT_GE(v, lo - 1e-9 * t.step);
            EXPECT_LE(v, hi + 1e-9 * t.step);
            EXPECT_NEAR(v / t.step, std::round(v / t.step), 1e-6);
            if (k > 0) {
                // Each value is k * step, rounded: exact to a few ulps of its size.
                EXPECT_NEAR(v - t.values[k - 1], t.step, 1e-9 * t.step + 1e-15 * std::abs(v));
            }
        }
        // The next smaller step of the 1-2-5 ladder gives too many ticks.
        const double e = std::floor(std::log10(t.step) + 1e-12);
        const double m = std::round(t.step / std::pow(10.0, e));
        const double smaller = m == 1   ? 0.5 * std::pow(10.0, e)
                               : m == 2 ? std::pow(10.0, e)
                                        : 2.0 * std::pow(10.0, e);
        EXPECT_GT(multiplesIn(lo, hi, smaller), maxCount);
    }
}

TEST(NiceTicks, DetectorSizedRanges) {
    const Ticks a = niceTicks(-32.0, 32.0, 14);
    EXPECT_EQ(a.step, 5.0);
    ASSERT_EQ(a.values.size(), 13u);
    EXPECT_EQ(a.values.front(), -30.0);
    EXPECT_EQ(a.values.back(), 30.0);
    const Ticks b = niceTicks(-1.75, 1.75, 14);
    EXPECT_EQ(b.step, 0.5);
    EXPECT_EQ(b.label(b.values.front()), "-1.5");
    // Ends on ticks are included.
    const Ticks c = niceTicks(-22.0, 22.0, 12);
    EXPECT_EQ(c.step, 5.0);
    EXPECT_EQ(c.values.size(), 9u);
    const Ticks d = niceTicks(-20.0, 20.0, 5);
    EXPECT_EQ(d.step, 10.0);
    EXPECT_EQ(d.values, (std::vector<double>{-20, -10, 0, 10, 20}));
    EXPECT_THROW(niceTicks(1.0, 1.0, 5), std::invalid_argument);
    EXPECT_THROW(niceTicks(0.0, 1.0, 1), std::invalid_argument);
}

TEST(NiceTicks, LabelsAreExactWithoutNegativeZero) {
    const Ticks t = niceTicks(-0.3, 0.3, 7);
    EXPECT_NEAR(t.step, 0.1, 1e-15);
    std::vector<std::string> labels;
    for (double v : t.values) labels.push_back(t.label(v));
    // One decimal on every tick of the axis; zero without a sign.
    EXPECT_EQ(labels,
              (std::vector<std::string>{"-0.3", "-0.2", "-0.1", "0.0", "0.1", "0.2", "0.3"}));
    EXPECT_EQ(t.label(-1e-17), "0.0");
    EXPECT_EQ(niceTicks(-5, 5, 3).label(-0.0), "0");
    EXPECT_EQ(niceTicks(-2000, 2000, 5).label(-1000), "-1000");
    EXPECT_EQ(niceTicks(0.0, 0.05, 6).label(0.02), "0.02");
}

TEST(NiceLength, IsTheLargestOneTwoFiveBelow) {
    EXPECT_EQ(niceLength(84.0), 50.0);
    EXPECT_EQ(niceLength(100.0), 100.0);
    EXPECT_EQ(niceLength(99.9), 50.0);
    EXPECT_EQ(niceLength(19.99), 10.0);
    EXPECT_NEAR(niceLength(0.3), 0.2, 1e-15);
    EXPECT_THROW(niceLength(0.0), std::invalid_argument);
}

TEST(ClipSegment, KeepsThePartInsideTheRectangle) {
    Vec2 a(-10, 0), b(10, 0);
    ASSERT_TRUE(clipSegment(a, b, -1, 2, -1, 1));
    EXPECT_EQ(a, Vec2(-1, 0));
    EXPECT_EQ(b, Vec2(2, 0));
    Vec2 c(0, 0), d(4, 4);  // leaves through the top at y = 1
    ASSERT_TRUE(clipSegment(c, d, -1, 2, -1, 1));
    EXPECT_EQ(c, Vec2(0, 0));
    EXPECT_EQ(d, Vec2(1, 1));
    Vec2 e(5, 5), f(6, 7);  // outside
    EXPECT_FALSE(clipSegment(e, f, -1, 2, -1, 1));
}

// SVG Tests

TEST(XmlEscape, EscapesMarkupDropsControlsAndRepairsUtf8) {
    EXPECT_EQ(xmlEscape("a<b & c>d \"q\" 'x'"), "a&lt;b &amp; c&gt;d &quot;q&quot; &apos;x&apos;");
    EXPECT_EQ(xmlEscape("W/mm\u00b2 \u00b1 1 %"), "W/mm\u00b2 \u00b1 1 %");  // UTF-8 kept
    EXPECT_EQ(xmlEscape(std::string("a\x01\x1f"
                                    "b\tc\n",
                                    7)),
              "ab\tc\n");
    EXPECT_EQ(xmlEscape("x\xff y"), "x\xEF\xBF\xBD y");            // a stray byte
    EXPECT_EQ(xmlEscape("\xC3"), "\xEF\xBF\xBD");                  // a cut sequence
    EXPECT_EQ(xmlEscape("\xC0\xAF"), "\xEF\xBF\xBD\xEF\xBF\xBD");  // an overlong '/'
    EXPECT_EQ(xmlEscape("\xED\xA0\x80"), "\xEF\xBF\xBD\xEF\xBF\xBD\xEF\xBF\xBD");  // surrogate
}

// A small XML well-formedness check: one root element, every tag closed in order, attributes
// quoted and unique, '<' never and '&' only as a predefined or numeric entity in text and
// attribute values. Returns "" or what is wrong.
std::string xmlProblem(const std::string& x) {
    size_t i = 0;
    const size_t n = x.size();
    std::vector<std::string> open;
    bool rootSeen = false;
    auto entityAt = [&](size_t k) {
        static const std::regex entity("^&(amp|lt|gt|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);");
        return std::regex_search(x.substr(k, 12), entity);
    };
    auto isName = [](char c) {
        return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':' ||
               c == '.';
    };
    if (x.compare(0, 5, "<?xml") == 0) {
        i = x.find("?>");
        if (i == std::string::npos) return "unclosed prolog";
        i += 2;
    }
    while (i < n) {
        if (x[i] != '<') {
            if (x[i] == '&' && !entityAt(i)) return "bare & at " + std::to_string(i);
            if (x[i] == '>') return "bare > at " + std::to_string(i);
            if (open.empty() && !std::isspace(static_cast<unsigned char>(x[i])))
                return "text outside the root at " + std::to_string(i);
            ++i;
            continue;
        }
        const bool closing = i + 1 < n && x[i + 1] == '/';
        size_t k = i + (closing ? 2 : 1);
        const size_t nameStart = k;
        while (k < n && isName(x[k])) ++k;
        const std::string name = x.substr(nameStart, k - nameStart);
        if (name.empty()) return "bad tag at " + std::to_string(i);
        if (closing) {
            if (open.empty() || open.back() != name) return "mismatched </" + name + ">";
            open.pop_back();
            while (k < n && std::isspace(static_cast<unsigned char>(x[k]))) ++k;
            if (k >= n || x[k] != '>') return "bad closing tag " + name;
            i = k + 1;
            continue;
        }
        if (open.empty() && rootSeen) return "second root <" + name + ">";
        std::set<std::string> attributes;
        for (;;) {
            while (k < n && std::isspace(static_cast<unsigned char>(x[k]))) ++k;
            if (k >= n) return "unclosed <" + name + ">";
            if (x[k] == '>' || (x[k] == '/' && k + 1 < n && x[k + 1] == '>')) break;
            const size_t a = k;
            while (k < n && isName(x[k])) ++k;
            const std::string attribute = x.substr(a, k - a);
            if (attribute.empty() || k + 1 >= n || x[k] != '=' || x[k + 1] != '"')
                return "bad attribute in <" + name + "> at " + std::to_string(a);
            if (!attributes.insert(attribute).second) return "attribute twice: " + attribute;
            k += 2;
            for (; k < n && x[k] != '"'; ++k) {
                if (x[k] == '<') return "< in an attribute of <" + name + ">";
                if (x[k] == '&' && !entityAt(k)) return "bare & in an attribute of <" + name + ">";
            }
            if (k >= n) return "unclosed attribute in <" + name + ">";
            ++k;
        }
        if (x[k] == '/') {
            if (open.empty()) rootSeen = true;
            i = k + 2;
        } else {
            open.push_back(name);
            rootSeen = true;
            i = k + 1;
        }
    }
    if (!open.empty()) return "unclosed <" + open.back() + ">";
    return rootSeen ? "" : "no root element";
}

TEST(XmlCheck, CatchesWhatItShould) {
    EXPECT_EQ(xmlProblem("<a x=\"1\"><b/>t &amp; u</a>"), "");
    EXPECT_NE(xmlProblem("<a><b></a>"), "");
    EXPECT_NE(xmlProblem("<a>x & y</a>"), "");
    EXPECT_NE(xmlProblem("<a x=\"<\"/>"), "");
    EXPECT_NE(xmlProblem("<a/><b/>"), "");
    EXPECT_NE(xmlProblem("<a x=1/>"), "");
}

Picture samplePicture(const std::string& title) {
    Picture pic(-10.0, 90.0, -20.0, 20.0);
    pic.polyline({Vec2(-10, 0), Vec2(90, 0)}, Color::hex(0x888888), 0.6, true);
    pic.polygon({Vec2(0, -10), Vec2(10, -10), Vec2(10, 10), Vec2(0, 10)}, Color::hex(0xff0000),
                Color::hex(0x000000), 1.0);
    pic.arrow(Vec2(-5, 15), Vec2(0, 15), Color::hex(0xe8710a), 1.0);
    pic.dot(Vec2(50, 5), 3.0, Color::hex(0xe8710a), Color::hex(0x000000));
    pic.text(5, 12, "L1 & <L2>", Color::hex(0x1f3f6f), 10.0);
    pic.title(title);
    pic.scaleBar();
    pic.legend(
        {{"glass", LegendEntry::Swatch::Fill, Color::hex(0xcfe6ff), Color::hex(0x1f5fa8), 0.8},
         {"source", LegendEntry::Swatch::Arrow, {}, Color::hex(0xe8710a), 1.0}});
    return pic;
}

TEST(PictureSvg, KeepsTextAsTextAndIsWellFormedXml) {
    const std::string title = "Tessar 50 mm f/3.5 \"A & B\" <test>";
    const Picture pic = samplePicture(title);
    const std::filesystem::path path = scratchDir() / "sample.svg";
    pic.writeSvg(path);
    std::ifstream in(path);
    const std::string svg((std::istreambuf_iterator<char>(in)), {});
    EXPECT_EQ(svg, pic.svg());
    EXPECT_EQ(xmlProblem(svg), "") << svg;
    const std::string escaped = "Tessar 50 mm f/3.5 &quot;A &amp; B&quot; &lt;test&gt;";
    EXPECT_NE(svg.find("<title>" + escaped + "</title>"), std::string::npos);
    EXPECT_TRUE(std::regex_search(svg, std::regex("<text [^>]*>" + escaped + "</text>"))) << svg;
    for (const char* text : {"L1 &amp; &lt;L2&gt;", "20 mm", "glass", "source"})
        EXPECT_TRUE(
            std::regex_search(svg, std::regex(std::string("<text [^>]*>") + text + "</text>")))
            << text;
    // No glyph outlines (what Cairo's SVG surface writes for text).
    EXPECT_EQ(svg.find("glyph"), std::string::npos);
    EXPECT_EQ(svg.find("<symbol"), std::string::npos);
}

TEST(PictureSvg, PageSizeFollowsTheRequestedWidth) {
    const Picture pic = samplePicture("t");
    const double h = pic.pageHeightPt();
    // Model 100 x 40 mm on 920 pt: 368 pt, plus margins (80) and the title band (30).
    EXPECT_NEAR(h, 40.0 * 9.2 + 80.0 + 30.0, 1e-9);
    const std::string svg = pic.svg(500.0);
    EXPECT_NE(svg.find("width=\"500pt\""), std::string::npos);
    EXPECT_NE(svg.find("viewBox=\"0 0 1000 478\""), std::string::npos) << svg.substr(0, 300);
    EXPECT_NE(svg.find("height=\"239pt\""), std::string::npos);
}

TEST(PictureSvg, OpaqueLinesOfOneStyleShareAPath) {
    Picture pic(0, 10, 0, 10);
    const Color blue = Color::hex(0x0000ff);
    pic.polyline({Vec2(0, 0), Vec2(1, 1)}, blue, 0.5);
    pic.polyline({Vec2(2, 2), Vec2(3, 3)}, blue, 0.5);
    pic.polyline({Vec2(4, 4), Vec2(5, 5)}, Color::hex(0xff0000), 0.5);
    pic.polyline({Vec2(6, 6), Vec2(7, 7)}, Color::hex(0xff0000, 0.5), 0.5);
    pic.polyline({Vec2(8, 8), Vec2(9, 9)}, Color::hex(0xff0000, 0.5), 0.5);
    const std::string svg = pic.svg();
    auto count = [&](const std::string& what) {
        size_t n = 0;
        for (size_t p = svg.find(what); p != std::string::npos; p = svg.find(what, p + 1)) ++n;
        return n;
    };
    EXPECT_EQ(count("<path "), 4u);  // blue twice in one, red, two transparent
    EXPECT_EQ(count("stroke=\"#0000ff\""), 1u);
    EXPECT_EQ(count("stroke-opacity=\"0.5\""), 2u);
    EXPECT_EQ(xmlProblem(svg), "");
}

TEST(PicturePng, DrawsModelPointsWhereTheSvgDoes) {
    const Picture pic = samplePicture("t");
    const std::filesystem::path path = scratchDir() / "sample.png";
    pic.writePng(path, 2000);
    cairo_surface_t* s = cairo_image_surface_create_from_png(path.c_str());
    ASSERT_EQ(cairo_surface_status(s), CAIRO_STATUS_SUCCESS);
    EXPECT_EQ(cairo_image_surface_get_width(s), 2000);
    EXPECT_EQ(cairo_image_surface_get_height(s),
              static_cast<int>(std::ceil(2.0 * pic.pageHeightPt())));
    cairo_surface_flush(s);
    auto rgb = [&](const Vec2& pagePt) {
        const unsigned char* d = cairo_image_surface_get_data(s);
        const int stride = cairo_image_surface_get_stride(s);
        const auto v = *reinterpret_cast<const uint32_t*>(
            d + static_cast<int>(2.0 * pagePt.y) * stride + 4 * static_cast<int>(2.0 * pagePt.x));
        return v & 0xFFFFFF;
    };
    EXPECT_EQ(rgb(pic.pagePoint(Vec2(5, 0.5))), 0xff0000u);   // inside the red square
    EXPECT_EQ(rgb(pic.pagePoint(Vec2(30, -15))), 0xffffffu);  // empty model space
    EXPECT_EQ(rgb(pic.pagePoint(Vec2(50, 5))), 0xe8710au);    // the dot's centre
    // The same square in the SVG, at the same page points.
    const Vec2 corner = pic.pagePoint(Vec2(0, -10));
    char buf[64];
    std::snprintf(buf, sizeof buf, "%g,%g", corner.x, corner.y);
    EXPECT_NE(pic.svg().find(buf), std::string::npos) << buf;
    cairo_surface_destroy(s);
}

TEST(PictureLegend, WrapsIntoMoreRowsWhenItDoesNotFit) {
    Picture one = samplePicture("t");
    Picture many = samplePicture("t");
    std::vector<LegendEntry> entries;
    for (int i = 0; i < 30; ++i)
        entries.push_back({"a rather long legend label " + std::to_string(i),
                           LegendEntry::Swatch::Line,
                           {},
                           Color::hex(0x000000),
                           1.0});
    many.legend(entries);
    EXPECT_GT(many.pageHeightPt(), one.pageHeightPt() + 16.0);
    const std::string svg = many.svg();
    EXPECT_EQ(xmlProblem(svg), "");
    for (int i = 0; i < 30; ++i)
        EXPECT_NE(svg.find(">a rather long legend label " + std::to_string(i) + "</text>"),
                  std::string::npos);
    EXPECT_GT(Picture::textWidthPt("mechanics", 10.0), Picture::textWidthPt("glass", 10.0));
}

TEST(Picture, WritesAtomicallyAndReportsBadPaths) {
    const std::filesystem::path dir = scratchDir();
    const Picture pic = samplePicture("t");
    EXPECT_THROW(pic.writeSvg(dir / "missing" / "x.svg"), std::runtime_error);
    EXPECT_THROW(pic.writePng(dir / "missing" / "x.png"), std::runtime_error);
    EXPECT_TRUE(std::filesystem::is_empty(dir));
}

}  // namespace
}  // namespace veil
