#pragma once
// A 2D picture in model units (mm), kept as a display list (lines, polygons, arrows, dots,
// text, a legend) and written as SVG by our own writer and as PNG by Cairo, from the same
// page geometry.
//
// Coordinates: the picture's horizontal axis is the optical axis z (left to right), its
// vertical axis is y (up). The page is always laid out 1000 pt wide (kPageWidthPt): the
// model rectangle fills it between the margins, the height follows the model's aspect
// ratio plus the title band and the margins. Sizes of lines and text are in page points,
// independent of the model scale; overlay items are placed in page points from the top
// left corner. writeSvg() scales the page to the requested width through the viewBox,
// writePng() to the requested number of pixels, so both show the same layout.
//
//      +------------------------------------------------------------+
//      | title (titleSpacePt)                                       |
//      |   margin                                                   |
//      |   +----------------------------------------------------+   |
//      |   | model rectangle [zMin, zMax] x [yMin, yMax]        |   |
//      |   +----------------------------------------------------+   |
//      |   scale bar                       legend row(s), right   |
//      +------------------------------------------------------------+
//
// SVG: text stays text (<text> elements, searchable and selectable), everything is
// escaped for XML (&, <, >, quotes; control characters dropped, bytes that are not UTF-8
// replaced by U+FFFD), and consecutive opaque lines of the same style share one <path>.
// Files are written to a temporary name and renamed, so a failed write never leaves half
// a picture.

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "geometry/frame.h"

namespace veil {

struct Color {
    double r = 0, g = 0, b = 0, a = 1;
    static Color hex(unsigned rgb, double alpha = 1.0) {
        return {((rgb >> 16) & 0xFF) / 255.0, ((rgb >> 8) & 0xFF) / 255.0, (rgb & 0xFF) / 255.0,
                alpha};
    }
};
std::ostream& operator<<(std::ostream& os, const Color& c);  // #rrggbb[/alpha]

// Axis Ticks

// Round tick values for an axis over [lo, hi]: every multiple of `step` inside the range
// (ends included, within 1e-9 of a step), where step is 1, 2 or 5 times a power of ten,
// the smallest such step that gives at most maxCount ticks. `decimals` is the number of
// digits after the point that writes every tick exactly (0 for steps >= 1).
struct Ticks {
    double step = 0.0;
    int decimals = 0;
    std::vector<double> values;  // increasing
    // A tick written with `decimals` digits: "-12.5", "0" (never "-0"), "0.02".
    std::string label(double value) const;
};
std::ostream& operator<<(std::ostream& os, const Ticks& t);

// Throws std::invalid_argument unless lo < hi (both finite) and maxCount >= 2.
Ticks niceTicks(double lo, double hi, int maxCount);
// The largest 1, 2 or 5 times a power of ten that is <= length (> 0): scale bar lengths.
double niceLength(double length);

// Liang-Barsky: clips segment a-b to [zMin, zMax] x [yMin, yMax] (points are (z, y)); false
// when nothing of it is inside, else a and b are moved onto the part inside.
bool clipSegment(Vec2& a, Vec2& b, double zMin, double zMax, double yMin, double yMax);

// Picture

enum class TextAnchor { Start, Middle, End };

// One entry of a picture's legend: a swatch and its label.
struct LegendEntry {
    enum class Swatch { Fill, Line, DashedLine, Arrow, Dot };
    std::string label;
    Swatch swatch = Swatch::Fill;
    Color fill, stroke;  // Fill: both; Line, DashedLine, Arrow: stroke; Dot: fill
    double widthPt = 1.0;
};

// The text of a string escaped for XML character data and attribute values.
std::string xmlEscape(const std::string& s);

class Picture {
  public:
    static constexpr double kPageWidthPt = 1000.0;

    // Model-space rectangle to show: z in [zMin, zMax], y in [yMin, yMax] (mm).
    Picture(double zMin, double zMax, double yMin, double yMax);

    double zMin() const { return zMin_; }
    double zMax() const { return zMax_; }
    double yMin() const { return yMin_; }
    double yMax() const { return yMax_; }

    void polyline(const std::vector<Vec2>& zy, Color stroke, double widthPt, bool dashed = false);
    void polygon(const std::vector<Vec2>& zy, Color fill, Color stroke, double widthPt);
    // A line from `from` to `to` (model) with a filled head of length headPt at `to`.
    void arrow(Vec2 from, Vec2 to, Color stroke, double widthPt, double headPt = 7.0);
    // A filled disk of radiusPt around a model point, with a thin outline.
    void dot(Vec2 zy, double radiusPt, Color fill, Color stroke);
    // Text at a model point; the anchor is where along the text the point lies, the point
    // is on the baseline. `centred` = TextAnchor::Middle.
    void text(double z, double y, const std::string& s, Color c, double sizePt,
              bool centred = true);
    // halo: a white outline under the letters keeps a label readable over a drawing.
    void text(double z, double y, const std::string& s, Color c, double sizePt, TextAnchor anchor,
              bool halo = false);
    // The title at the top left; also the SVG's <title>.
    void title(const std::string& s);
    const std::string& title() const { return title_; }
    // Text placed in page points from the top-left corner (titles, legends).
    void overlayText(double xPt, double yPt, const std::string& s, Color c, double sizePt,
                     TextAnchor anchor = TextAnchor::Start);
    void overlayLine(double x0Pt, double y0Pt, double x1Pt, double y1Pt, Color c, double widthPt);
    void overlayRect(double xPt, double yPt, double wPt, double hPt, Color fill);
    // A scale bar of a round length (niceLength of a fifth of the width) in the lower left.
    void scaleBar();
    // The legend: rows of swatches and labels in the bottom band, right-aligned, right of
    // the scale bar (extra rows below when they do not fit). Replaces an earlier legend.
    void legend(std::vector<LegendEntry> entries);
    const std::vector<LegendEntry>& legendEntries() const { return legend_; }

    // Width in page points of `s` at sizePt in the sans-serif font both writers use (Cairo's
    // metrics; an SVG viewer's font may differ slightly).
    static double textWidthPt(const std::string& s, double sizePt);

    // Page height in points (for kPageWidthPt): model, margins, title band, legend rows.
    double pageHeightPt() const;
    // Page position (points from the top left) of a model point.
    Vec2 pagePoint(const Vec2& zy) const;

    // widthPt / widthPx scale the same 1000 pt page.
    void writeSvg(const std::filesystem::path& path, double widthPt = kPageWidthPt) const;
    void writePng(const std::filesystem::path& path, int widthPx = 2000) const;
    // The SVG document as text (what writeSvg() writes).
    std::string svg(double widthPt = kPageWidthPt) const;

    double marginPt = 40.0;
    double titleSpacePt = 30.0;

  private:
    struct Command {
        enum Kind { Polyline, Polygon, Arrow, Dot, Text, OverlayText, OverlayLine, OverlayRect };
        Kind kind = Polyline;
        std::vector<Vec2> points;  // model for Polyline..Text, page points for overlays
        Color stroke, fill;
        double width = 1.0;  // line width, text size, dot radius (pt)
        bool dashed = false;
        std::string text;
        TextAnchor anchor = TextAnchor::Start;
        bool halo = false;
        double headPt = 0.0;
    };
    static Command make(Command::Kind kind, std::vector<Vec2> points, Color stroke, Color fill,
                        double width);
    template <class Canvas>
    void draw(Canvas& canvas) const;
    // Legend entries per row and the page x where each row starts.
    struct LegendRow {
        size_t first = 0, count = 0;
        double xPt = 0.0;
    };
    std::vector<LegendRow> legendRows() const;
    double modelScale() const;  // page points per mm

    double zMin_, zMax_, yMin_, yMax_;
    std::vector<Command> commands_;
    std::vector<LegendEntry> legend_;
    std::string title_;
    bool scaleBar_ = false;
};

}  // namespace veil
