#include "analysis/pictures/picture.h"

#include <cairo.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "lensdata/output_file.h"

namespace veil {

// Colours and Ticks

std::ostream& operator<<(std::ostream& os, const Color& c) {
    char buf[16];
    auto byte = [](double v) {
        return static_cast<int>(std::lround(std::clamp(v, 0.0, 1.0) * 255));
    };
    std::snprintf(buf, sizeof buf, "#%02x%02x%02x", byte(c.r), byte(c.g), byte(c.b));
    os << buf;
    if (c.a < 1.0) os << "/" << c.a;
    return os;
}

std::string Ticks::label(double value) const {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.*f", decimals, value);
    std::string s = buf;
    // "-0", "-0.0": a tick at zero has no sign.
    if (s.front() == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
    return s;
}

std::ostream& operator<<(std::ostream& os, const Ticks& t) {
    os << "Ticks{step " << t.step << ":";
    for (double v : t.values) os << " " << t.label(v);
    return os << "}";
}

Ticks niceTicks(double lo, double hi, int maxCount) {
    if (!(lo < hi) || !std::isfinite(lo) || !std::isfinite(hi) || maxCount < 2)
        throw std::invalid_argument("niceTicks: need lo < hi, both finite, and maxCount >= 2");
    // Start from a step a little below the range / maxCount and go up the 1-2-5 ladder until
    // the ticks fit.
    int e = static_cast<int>(std::floor(std::log10((hi - lo) / maxCount))) - 1;
    for (;; ++e) {
        for (int m : {1, 2, 5}) {
            const double step = m * std::pow(10.0, e);
            const double eps = 1e-9 * step;
            const double first = std::ceil((lo - eps) / step), last = std::floor((hi + eps) / step);
            if (last - first + 1 > maxCount) continue;
            Ticks t;
            t.step = step;
            t.decimals = std::max(0, -e);
            for (double k = first; k <= last; ++k) t.values.push_back(k * step);
            return t;
        }
    }
}

double niceLength(double length) {
    if (!(length > 0.0) || !std::isfinite(length))
        throw std::invalid_argument("niceLength: need a finite length > 0");
    const double decade = std::pow(10.0, std::floor(std::log10(length)));
    double best = decade;
    for (double m : {2.0, 5.0, 10.0})
        if (m * decade <= length * (1.0 + 1e-12)) best = m * decade;
    return best;
}

bool clipSegment(Vec2& a, Vec2& b, double zMin, double zMax, double yMin, double yMax) {
    double t0 = 0.0, t1 = 1.0;
    const Vec2 d = b - a;
    const double p[4] = {-d.x, d.x, -d.y, d.y};
    const double q[4] = {a.x - zMin, zMax - a.x, a.y - yMin, yMax - a.y};
    for (int i = 0; i < 4; ++i) {
        if (p[i] == 0.0) {
            if (q[i] < 0.0) return false;
            continue;
        }
        const double t = q[i] / p[i];
        if (p[i] < 0.0)
            t0 = std::max(t0, t);
        else
            t1 = std::min(t1, t);
        if (t0 > t1) return false;
    }
    const Vec2 a0 = a;
    a = a0 + t0 * d;
    b = a0 + t1 * d;
    return true;
}

// XML Text

std::string xmlEscape(const std::string& s) {
    std::string out;
    out.reserve(s.size());
    const auto* p = reinterpret_cast<const unsigned char*>(s.data());
    const size_t n = s.size();
    for (size_t i = 0; i < n;) {
        const unsigned char c = p[i];
        if (c < 0x80) {
            switch (c) {
                case '&':
                    out += "&amp;";
                    break;
                case '<':
                    out += "&lt;";
                    break;
                case '>':
                    out += "&gt;";
                    break;
                case '"':
                    out += "&quot;";
                    break;
                case '\'':
                    out += "&apos;";
                    break;
                default:
                    // XML 1.0 allows tab, newline and carriage return of the C0 controls.
                    if (c >= 0x20 || c == '\t' || c == '\n' || c == '\r') out += char(c);
            }
            ++i;
            continue;
        }
        // A UTF-8 sequence: its length from the lead byte, continuation bytes 10xxxxxx,
        // no overlong forms, no surrogates, nothing above U+10FFFF.
        int len = 0;
        uint32_t cp = 0;
        if ((c & 0xE0) == 0xC0) {
            len = 2;
            cp = c & 0x1F;
        } else if ((c & 0xF0) == 0xE0) {
            len = 3;
            cp = c & 0x0F;
        } else if ((c & 0xF8) == 0xF0) {
            len = 4;
            cp = c & 0x07;
        }
        bool ok = len > 0 && i + len <= n;
        for (int k = 1; ok && k < len; ++k) {
            ok = (p[i + k] & 0xC0) == 0x80;
            cp = (cp << 6) | (p[i + k] & 0x3F);
        }
        static constexpr uint32_t kMin[5] = {0, 0, 0x80, 0x800, 0x10000};
        ok = ok && cp >= kMin[len] && cp <= 0x10FFFF && !(cp >= 0xD800 && cp <= 0xDFFF) &&
             cp != 0xFFFE && cp != 0xFFFF;
        if (ok) {
            out.append(s, i, len);
            i += len;
        } else {
            out += "\xEF\xBF\xBD";  // U+FFFD
            ++i;
        }
    }
    return out;
}

namespace {

// Page Canvases
//
// Both writers draw the same page (points, origin top left, y down) through this small
// interface: line, polygon, disk, text.

void setColor(cairo_t* cr, const Color& c) { cairo_set_source_rgba(cr, c.r, c.g, c.b, c.a); }

const char* const kFontFamily = "sans-serif";
constexpr double kHaloPt = 2.5;  // width of the white outline under haloed text
const char* const kSvgFontFamily = "DejaVu Sans, Verdana, Arial, sans-serif";

class CairoCanvas {
  public:
    explicit CairoCanvas(cairo_t* cr) : cr_(cr) {
        cairo_set_line_join(cr_, CAIRO_LINE_JOIN_ROUND);
        cairo_set_line_cap(cr_, CAIRO_LINE_CAP_ROUND);
        cairo_select_font_face(cr_, kFontFamily, CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    }
    void line(const std::vector<Vec2>& pts, Color stroke, double width, bool dashed) {
        if (pts.size() < 2) return;
        path(pts);
        setColor(cr_, stroke);
        cairo_set_line_width(cr_, width);
        if (dashed) {
            const double dash[] = {6.0, 3.0};
            cairo_set_dash(cr_, dash, 2, 0.0);
        }
        cairo_stroke(cr_);
        cairo_set_dash(cr_, nullptr, 0, 0.0);
    }
    void polygon(const std::vector<Vec2>& pts, Color fill, Color stroke, double width) {
        if (pts.size() < 3) return;
        path(pts);
        cairo_close_path(cr_);
        setColor(cr_, fill);
        if (width > 0.0) {
            cairo_fill_preserve(cr_);
            setColor(cr_, stroke);
            cairo_set_line_width(cr_, width);
            cairo_stroke(cr_);
        } else {
            cairo_fill(cr_);
        }
    }
    void disk(Vec2 c, double r, Color fill, Color stroke, double width) {
        cairo_new_path(cr_);
        cairo_arc(cr_, c.x, c.y, r, 0.0, 2.0 * M_PI);
        setColor(cr_, fill);
        cairo_fill_preserve(cr_);
        setColor(cr_, stroke);
        cairo_set_line_width(cr_, width);
        cairo_stroke(cr_);
    }
    void text(Vec2 p, const std::string& s, Color c, double size, TextAnchor anchor,
              bool halo = false) {
        cairo_set_font_size(cr_, size);
        cairo_text_extents_t ext;
        cairo_text_extents(cr_, s.c_str(), &ext);
        if (anchor == TextAnchor::Middle) p.x -= 0.5 * ext.x_advance;
        if (anchor == TextAnchor::End) p.x -= ext.x_advance;
        if (halo) {
            cairo_new_path(cr_);
            cairo_move_to(cr_, p.x, p.y);
            cairo_text_path(cr_, s.c_str());
            cairo_set_source_rgb(cr_, 1.0, 1.0, 1.0);
            cairo_set_line_width(cr_, kHaloPt);
            cairo_stroke(cr_);
        }
        setColor(cr_, c);
        cairo_move_to(cr_, p.x, p.y);
        cairo_show_text(cr_, s.c_str());
    }
    void title(const std::string&) {}

  private:
    void path(const std::vector<Vec2>& pts) {
        cairo_new_path(cr_);
        cairo_move_to(cr_, pts[0].x, pts[0].y);
        for (size_t i = 1; i < pts.size(); ++i) cairo_line_to(cr_, pts[i].x, pts[i].y);
    }
    cairo_t* cr_;
};

// A page coordinate with at most two decimals (1/100 pt), no trailing zeros, no "-0".
std::string num(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", v);
    std::string s = buf;
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
    if (s == "-0") s = "0";
    return s;
}

std::string hexColour(const Color& c) {
    std::ostringstream os;
    os << Color{c.r, c.g, c.b, 1.0};
    return os.str();
}

class SvgCanvas {
  public:
    SvgCanvas(std::ostream& os) : os_(os) {}
    ~SvgCanvas() { flush(); }

    void line(const std::vector<Vec2>& pts, Color stroke, double width, bool dashed) {
        if (pts.size() < 2) return;
        // Consecutive opaque lines of one style become one <path>; with transparency they
        // stay apart, because overlaps inside one path would not blend twice.
        const std::string style = strokeStyle(stroke, width, dashed);
        if (style != pendingStyle_ || stroke.a < 1.0) flush();
        for (size_t i = 0; i < pts.size(); ++i) {
            if (!pendingData_.empty()) pendingData_ += ' ';
            pendingData_ += i == 0 ? 'M' : 'L';
            pendingData_ += num(pts[i].x);
            pendingData_ += ' ';
            pendingData_ += num(pts[i].y);
        }
        pendingStyle_ = style;
        if (stroke.a < 1.0) flush();
    }
    void polygon(const std::vector<Vec2>& pts, Color fill, Color stroke, double width) {
        if (pts.size() < 3) return;
        flush();
        os_ << "<polygon points=\"";
        for (size_t i = 0; i < pts.size(); ++i)
            os_ << (i ? " " : "") << num(pts[i].x) << ',' << num(pts[i].y);
        os_ << "\"" << fillStyle(fill);
        if (width > 0.0) os_ << strokeStyle(stroke, width, false);
        os_ << "/>\n";
    }
    void disk(Vec2 c, double r, Color fill, Color stroke, double width) {
        flush();
        os_ << "<circle cx=\"" << num(c.x) << "\" cy=\"" << num(c.y) << "\" r=\"" << num(r) << "\""
            << fillStyle(fill) << strokeStyle(stroke, width, false) << "/>\n";
    }
    void text(Vec2 p, const std::string& s, Color c, double size, TextAnchor anchor,
              bool halo = false) {
        flush();
        os_ << "<text x=\"" << num(p.x) << "\" y=\"" << num(p.y) << "\" font-size=\"" << num(size)
            << "\"" << fillStyle(c);
        if (anchor == TextAnchor::Middle) os_ << " text-anchor=\"middle\"";
        if (anchor == TextAnchor::End) os_ << " text-anchor=\"end\"";
        if (halo)
            os_ << " stroke=\"#ffffff\" stroke-width=\"" << num(kHaloPt)
                << "\" paint-order=\"stroke\"";
        os_ << ">" << xmlEscape(s) << "</text>\n";
    }
    void title(const std::string& s) {
        if (!s.empty()) os_ << "<title>" << xmlEscape(s) << "</title>\n";
    }

  private:
    static std::string strokeStyle(Color c, double width, bool dashed) {
        std::string s = " stroke=\"" + hexColour(c) + "\" stroke-width=\"" + num(width) + "\"";
        if (c.a < 1.0) s += " stroke-opacity=\"" + num(c.a) + "\"";
        if (dashed) s += " stroke-dasharray=\"6 3\"";
        return s;
    }
    static std::string fillStyle(Color c) {
        std::string s = " fill=\"" + hexColour(c) + "\"";
        if (c.a < 1.0) s += " fill-opacity=\"" + num(c.a) + "\"";
        return s;
    }
    void flush() {
        if (pendingData_.empty()) return;
        os_ << "<path d=\"" << pendingData_ << "\" fill=\"none\"" << pendingStyle_ << "/>\n";
        pendingData_.clear();
        pendingStyle_.clear();
    }
    std::ostream& os_;
    std::string pendingData_, pendingStyle_;
};

// Arrow heads and legend swatches, drawn the same way on both canvases.
template <class Canvas>
void drawArrow(Canvas& c, Vec2 a, Vec2 b, Color stroke, double width, double head) {
    const Vec2 d = b - a;
    const double len = glm::length(d);
    if (!(len > 0.0)) return;
    const Vec2 u = d / len, n(-u.y, u.x);
    const double h = std::min(head, 0.6 * len);  // short arrows keep a shaft
    const Vec2 base = b - h * u;
    c.line({a, base + 0.1 * h * u}, stroke, width, false);
    c.polygon({b, base + 0.38 * h * n, base - 0.38 * h * n}, stroke, stroke, 0.0);
}

constexpr double kSwatchPt = 22.0;
constexpr double kLegendTextPt = 10.0;
constexpr double kLegendRowPt = 16.0;
constexpr double kScaleBarTextPt = 11.0;

double legendEntryWidth(const LegendEntry& e) {
    return kSwatchPt + 5.0 + Picture::textWidthPt(e.label, kLegendTextPt) + 16.0;
}

template <class Canvas>
void drawSwatch(Canvas& c, const LegendEntry& e, double x, double baseline) {
    const double mid = baseline - 3.5;
    switch (e.swatch) {
        case LegendEntry::Swatch::Fill:
            c.polygon({Vec2(x, mid - 5), Vec2(x + kSwatchPt, mid - 5), Vec2(x + kSwatchPt, mid + 5),
                       Vec2(x, mid + 5)},
                      e.fill, e.stroke, e.widthPt);
            break;
        case LegendEntry::Swatch::Line:
        case LegendEntry::Swatch::DashedLine:
            c.line({Vec2(x, mid), Vec2(x + kSwatchPt, mid)}, e.stroke, e.widthPt,
                   e.swatch == LegendEntry::Swatch::DashedLine);
            break;
        case LegendEntry::Swatch::Arrow:
            drawArrow(c, Vec2(x, mid), Vec2(x + kSwatchPt, mid), e.stroke, e.widthPt, 7.0);
            break;
        case LegendEntry::Swatch::Dot:
            c.disk(Vec2(x + 0.5 * kSwatchPt, mid), 3.0, e.fill, e.stroke, 0.6);
            break;
    }
}

}  // namespace

// Picture Public Methods

Picture::Picture(double zMin, double zMax, double yMin, double yMax)
    : zMin_(zMin), zMax_(zMax), yMin_(yMin), yMax_(yMax) {
    if (!(zMax > zMin) || !(yMax > yMin)) throw std::invalid_argument("Picture: empty extent");
}

Picture::Command Picture::make(Command::Kind kind, std::vector<Vec2> points, Color stroke,
                               Color fill, double width) {
    Command c;
    c.kind = kind;
    c.points = std::move(points);
    c.stroke = stroke;
    c.fill = fill;
    c.width = width;
    return c;
}

void Picture::polyline(const std::vector<Vec2>& zy, Color stroke, double widthPt, bool dashed) {
    Command c = make(Command::Polyline, zy, stroke, {}, widthPt);
    c.dashed = dashed;
    commands_.push_back(std::move(c));
}

void Picture::polygon(const std::vector<Vec2>& zy, Color fill, Color stroke, double widthPt) {
    commands_.push_back(make(Command::Polygon, zy, stroke, fill, widthPt));
}

void Picture::arrow(Vec2 from, Vec2 to, Color stroke, double widthPt, double headPt) {
    Command c = make(Command::Arrow, {from, to}, stroke, stroke, widthPt);
    c.headPt = headPt;
    commands_.push_back(std::move(c));
}

void Picture::dot(Vec2 zy, double radiusPt, Color fill, Color stroke) {
    commands_.push_back(make(Command::Dot, {zy}, stroke, fill, radiusPt));
}

void Picture::text(double z, double y, const std::string& s, Color c, double sizePt, bool centred) {
    text(z, y, s, c, sizePt, centred ? TextAnchor::Middle : TextAnchor::Start);
}

void Picture::text(double z, double y, const std::string& s, Color c, double sizePt,
                   TextAnchor anchor, bool halo) {
    Command cmd = make(Command::Text, {Vec2(z, y)}, c, {}, sizePt);
    cmd.text = s;
    cmd.anchor = anchor;
    cmd.halo = halo;
    commands_.push_back(std::move(cmd));
}

void Picture::title(const std::string& s) {
    title_ = s;
    overlayText(marginPt, 24.0, s, Color::hex(0x000000), 14.0);
}

void Picture::overlayText(double xPt, double yPt, const std::string& s, Color c, double sizePt,
                          TextAnchor anchor) {
    Command cmd = make(Command::OverlayText, {Vec2(xPt, yPt)}, c, {}, sizePt);
    cmd.text = s;
    cmd.anchor = anchor;
    commands_.push_back(std::move(cmd));
}

void Picture::overlayLine(double x0Pt, double y0Pt, double x1Pt, double y1Pt, Color c,
                          double widthPt) {
    commands_.push_back(
        make(Command::OverlayLine, {Vec2(x0Pt, y0Pt), Vec2(x1Pt, y1Pt)}, c, {}, widthPt));
}

void Picture::overlayRect(double xPt, double yPt, double wPt, double hPt, Color fill) {
    commands_.push_back(
        make(Command::OverlayRect, {Vec2(xPt, yPt), Vec2(wPt, hPt)}, {}, fill, 0.0));
}

void Picture::scaleBar() { scaleBar_ = true; }

void Picture::legend(std::vector<LegendEntry> entries) { legend_ = std::move(entries); }

double Picture::textWidthPt(const std::string& s, double sizePt) {
    cairo_surface_t* surface = cairo_image_surface_create(CAIRO_FORMAT_A8, 1, 1);
    cairo_t* cr = cairo_create(surface);
    cairo_select_font_face(cr, kFontFamily, CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    cairo_set_font_size(cr, sizePt);
    cairo_text_extents_t ext;
    cairo_text_extents(cr, s.c_str(), &ext);
    cairo_destroy(cr);
    cairo_surface_destroy(surface);
    return ext.x_advance;
}

double Picture::modelScale() const { return (kPageWidthPt - 2.0 * marginPt) / (zMax_ - zMin_); }

Vec2 Picture::pagePoint(const Vec2& zy) const {
    const double s = modelScale();
    return Vec2(marginPt + (zy.x - zMin_) * s, titleSpacePt + marginPt + (yMax_ - zy.y) * s);
}

// The scale bar's length and label, and where the legend may start.
namespace {
struct ScaleBarGeometry {
    double lengthMm = 0.0, lengthPt = 0.0;
    std::string label;
    double endPt = 0.0;  // right end of its label
};
ScaleBarGeometry scaleBarGeometry(double zSpanMm, double scale, double marginPt) {
    ScaleBarGeometry g;
    g.lengthMm = niceLength(0.2 * zSpanMm);
    g.lengthPt = g.lengthMm * scale;
    std::ostringstream os;
    os << g.lengthMm << " mm";
    g.label = os.str();
    g.endPt = marginPt + g.lengthPt + 6.0 + Picture::textWidthPt(g.label, kScaleBarTextPt);
    return g;
}
}  // namespace

std::vector<Picture::LegendRow> Picture::legendRows() const {
    std::vector<LegendRow> rows;
    if (legend_.empty()) return rows;
    const double right = kPageWidthPt - marginPt;
    const double firstLeft =
        scaleBar_ ? scaleBarGeometry(zMax_ - zMin_, modelScale(), marginPt).endPt + 24.0 : marginPt;
    LegendRow row;
    double width = 0.0;
    for (size_t i = 0; i < legend_.size(); ++i) {
        const double w = legendEntryWidth(legend_[i]);
        const double left = rows.empty() ? firstLeft : marginPt;
        if (row.count > 0 && right - (width + w) < left) {
            row.xPt = right - width;
            rows.push_back(row);
            row = {i, 0, 0.0};
            width = 0.0;
        }
        ++row.count;
        width += w;
    }
    row.xPt = std::max(marginPt, right - width);
    rows.push_back(row);
    return rows;
}

double Picture::pageHeightPt() const {
    const double model = (yMax_ - yMin_) * modelScale();
    const size_t rows = legendRows().size();
    return model + 2.0 * marginPt + titleSpacePt + kLegendRowPt * (rows > 1 ? rows - 1 : 0);
}

template <class Canvas>
void Picture::draw(Canvas& c) const {
    const double heightPt = pageHeightPt();
    c.title(title_);
    c.polygon({Vec2(0, 0), Vec2(kPageWidthPt, 0), Vec2(kPageWidthPt, heightPt), Vec2(0, heightPt)},
              Color::hex(0xffffff), {}, 0.0);
    auto page = [&](const std::vector<Vec2>& zy) {
        std::vector<Vec2> out;
        out.reserve(zy.size());
        for (const Vec2& p : zy) out.push_back(pagePoint(p));
        return out;
    };
    for (const Command& cmd : commands_) {
        switch (cmd.kind) {
            case Command::Polyline:
                c.line(page(cmd.points), cmd.stroke, cmd.width, cmd.dashed);
                break;
            case Command::Polygon:
                c.polygon(page(cmd.points), cmd.fill, cmd.stroke, cmd.width);
                break;
            case Command::Arrow:
                drawArrow(c, pagePoint(cmd.points[0]), pagePoint(cmd.points[1]), cmd.stroke,
                          cmd.width, cmd.headPt);
                break;
            case Command::Dot:
                c.disk(pagePoint(cmd.points[0]), cmd.width, cmd.fill, cmd.stroke, 0.6);
                break;
            case Command::Text:
                c.text(pagePoint(cmd.points[0]), cmd.text, cmd.stroke, cmd.width, cmd.anchor,
                       cmd.halo);
                break;
            case Command::OverlayText:
                c.text(cmd.points[0], cmd.text, cmd.stroke, cmd.width, cmd.anchor);
                break;
            case Command::OverlayLine:
                c.line(cmd.points, cmd.stroke, cmd.width, false);
                break;
            case Command::OverlayRect: {
                const Vec2 p = cmd.points[0], s = cmd.points[1];
                c.polygon({p, Vec2(p.x + s.x, p.y), p + s, Vec2(p.x, p.y + s.y)}, cmd.fill, {},
                          0.0);
                break;
            }
        }
    }
    // The bottom band: scale bar on the left, legend rows on the right.
    const double baseline = titleSpacePt + 1.5 * marginPt + (yMax_ - yMin_) * modelScale() + 4.0;
    if (scaleBar_) {
        const ScaleBarGeometry g = scaleBarGeometry(zMax_ - zMin_, modelScale(), marginPt);
        const double x0 = marginPt, x1 = x0 + g.lengthPt, y0 = baseline - 4.0;
        const Color black = Color::hex(0x000000);
        c.line({Vec2(x0, y0), Vec2(x1, y0)}, black, 1.5, false);
        c.line({Vec2(x0, y0 - 4), Vec2(x0, y0 + 4)}, black, 1.5, false);
        c.line({Vec2(x1, y0 - 4), Vec2(x1, y0 + 4)}, black, 1.5, false);
        c.text(Vec2(x1 + 6, baseline), g.label, black, kScaleBarTextPt, TextAnchor::Start);
    }
    const std::vector<LegendRow> rows = legendRows();
    for (size_t r = 0; r < rows.size(); ++r) {
        double x = rows[r].xPt;
        const double y = baseline + kLegendRowPt * r;
        for (size_t i = rows[r].first; i < rows[r].first + rows[r].count; ++i) {
            const LegendEntry& e = legend_[i];
            drawSwatch(c, e, x, y);
            c.text(Vec2(x + kSwatchPt + 5.0, y), e.label, Color::hex(0x000000), kLegendTextPt,
                   TextAnchor::Start);
            x += legendEntryWidth(e);
        }
    }
}

std::string Picture::svg(double widthPt) const {
    const double h = pageHeightPt();
    const double zoom = widthPt / kPageWidthPt;
    std::ostringstream os;
    os << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       << "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" << num(widthPt)
       << "pt\" height=\"" << num(h * zoom) << "pt\" viewBox=\"0 0 " << num(kPageWidthPt) << " "
       << num(h) << "\" font-family=\"" << kSvgFontFamily
       << "\" stroke-linejoin=\"round\" stroke-linecap=\"round\">\n";
    {
        SvgCanvas canvas(os);
        draw(canvas);
    }
    os << "</svg>\n";
    return os.str();
}

void Picture::writeSvg(const std::filesystem::path& path, double widthPt) const {
    const std::string text = svg(widthPt);
    const std::filesystem::path tmp = temporaryFor(path);
    {
        errno = 0;
        std::ofstream out(tmp, std::ios::binary);
        out << text;
        out.close();
        if (!out) {
            const std::string reason = systemReason();
            removeQuietly(tmp);
            throw std::runtime_error("cannot write " + path.string() + ": " + reason);
        }
    }
    commitFile(tmp, path);
}

void Picture::writePng(const std::filesystem::path& path, int widthPx) const {
    const double zoom = widthPx / kPageWidthPt;
    const double h = pageHeightPt();
    cairo_surface_t* s = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, widthPx,
                                                    static_cast<int>(std::ceil(h * zoom)));
    cairo_t* cr = cairo_create(s);
    cairo_scale(cr, zoom, zoom);
    {
        CairoCanvas canvas(cr);
        draw(canvas);
    }
    cairo_destroy(cr);
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
