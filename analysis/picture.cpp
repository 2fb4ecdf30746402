#include "analysis/picture.h"

#include <cairo-svg.h>
#include <cairo.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "lensdata/output_file.h"

namespace veil {

namespace {

void setColor(cairo_t* cr, const Color& c) { cairo_set_source_rgba(cr, c.r, c.g, c.b, c.a); }

}  // namespace

Picture::Picture(double zMin, double zMax, double yMin, double yMax)
    : zMin_(zMin), zMax_(zMax), yMin_(yMin), yMax_(yMax) {
    if (!(zMax > zMin) || !(yMax > yMin)) throw std::invalid_argument("Picture: empty extent");
}

void Picture::polyline(const std::vector<Vec2>& zy, Color stroke, double widthPt, bool dashed) {
    commands_.push_back({Command::Polyline, zy, stroke, {}, widthPt, dashed, {}, true});
}

void Picture::polygon(const std::vector<Vec2>& zy, Color fill, Color stroke, double widthPt) {
    commands_.push_back({Command::Polygon, zy, stroke, fill, widthPt, false, {}, true});
}

void Picture::text(double z, double y, const std::string& s, Color c, double sizePt, bool centred) {
    commands_.push_back({Command::Text, {Vec2(z, y)}, c, {}, sizePt, false, s, centred});
}

void Picture::overlayText(double xPt, double yPt, const std::string& s, Color c, double sizePt) {
    commands_.push_back({Command::OverlayText, {Vec2(xPt, yPt)}, c, {}, sizePt, false, s, false});
}

void Picture::overlayLine(double x0Pt, double y0Pt, double x1Pt, double y1Pt, Color c,
                          double widthPt) {
    commands_.push_back({Command::OverlayLine,
                         {Vec2(x0Pt, y0Pt), Vec2(x1Pt, y1Pt)},
                         c,
                         {},
                         widthPt,
                         false,
                         {},
                         false});
}

void Picture::overlayRect(double xPt, double yPt, double wPt, double hPt, Color fill) {
    commands_.push_back(
        {Command::OverlayRect, {Vec2(xPt, yPt), Vec2(wPt, hPt)}, {}, fill, 0.0, false, {}, false});
}

void Picture::scaleBar() {
    commands_.push_back({Command::ScaleBar, {}, {}, {}, 1.0, false, {}, true});
}

double Picture::heightFor(double widthPt) const {
    const double scale = (widthPt - 2.0 * marginPt) / (zMax_ - zMin_);
    return (yMax_ - yMin_) * scale + 2.0 * marginPt + titleSpacePt;
}

void Picture::render(void* context, double widthPt, double heightPt) const {
    cairo_t* cr = static_cast<cairo_t*>(context);
    const double scale = (widthPt - 2.0 * marginPt) / (zMax_ - zMin_);
    auto px = [&](const Vec2& zy) {
        return Vec2(marginPt + (zy.x - zMin_) * scale,
                    titleSpacePt + marginPt + (yMax_ - zy.y) * scale);
    };
    cairo_set_source_rgb(cr, 1.0, 1.0, 1.0);
    cairo_paint(cr);
    cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
    cairo_select_font_face(cr, "sans-serif", CAIRO_FONT_SLANT_NORMAL, CAIRO_FONT_WEIGHT_NORMAL);
    auto path = [&](const std::vector<Vec2>& pts) {
        cairo_new_path(cr);
        for (size_t i = 0; i < pts.size(); ++i) {
            const Vec2 p = px(pts[i]);
            if (i == 0)
                cairo_move_to(cr, p.x, p.y);
            else
                cairo_line_to(cr, p.x, p.y);
        }
    };
    for (const Command& c : commands_) {
        switch (c.kind) {
            case Command::Polyline: {
                if (c.points.size() < 2) break;
                path(c.points);
                setColor(cr, c.stroke);
                cairo_set_line_width(cr, c.width);
                if (c.dashed) {
                    const double dash[] = {6.0, 3.0};
                    cairo_set_dash(cr, dash, 2, 0.0);
                }
                cairo_stroke(cr);
                cairo_set_dash(cr, nullptr, 0, 0.0);
                break;
            }
            case Command::Polygon: {
                if (c.points.size() < 3) break;
                path(c.points);
                cairo_close_path(cr);
                setColor(cr, c.fill);
                cairo_fill_preserve(cr);
                setColor(cr, c.stroke);
                cairo_set_line_width(cr, c.width);
                cairo_stroke(cr);
                break;
            }
            case Command::Text:
            case Command::OverlayText: {
                cairo_set_font_size(cr, c.width);
                cairo_text_extents_t ext;
                cairo_text_extents(cr, c.text.c_str(), &ext);
                Vec2 p = c.kind == Command::Text ? px(c.points[0]) : c.points[0];
                if (c.centred) p.x -= ext.width / 2.0 + ext.x_bearing;
                setColor(cr, c.stroke);
                cairo_move_to(cr, p.x, p.y);
                cairo_show_text(cr, c.text.c_str());
                break;
            }
            case Command::OverlayLine:
                setColor(cr, c.stroke);
                cairo_set_line_width(cr, c.width);
                cairo_move_to(cr, c.points[0].x, c.points[0].y);
                cairo_line_to(cr, c.points[1].x, c.points[1].y);
                cairo_stroke(cr);
                break;
            case Command::OverlayRect:
                setColor(cr, c.fill);
                cairo_rectangle(cr, c.points[0].x, c.points[0].y, c.points[1].x, c.points[1].y);
                cairo_fill(cr);
                break;
            case Command::ScaleBar: {
                // The largest 1-2-5 length that fits in a fifth of the width.
                const double target = 0.2 * (zMax_ - zMin_);
                const double decade = std::pow(10.0, std::floor(std::log10(target)));
                double len = decade;
                for (double m : {2.0, 5.0})
                    if (m * decade <= target) len = m * decade;
                const double x0 = marginPt, y0 = heightPt - 0.5 * marginPt;
                const double x1 = x0 + len * scale;
                cairo_set_source_rgb(cr, 0.0, 0.0, 0.0);
                cairo_set_line_width(cr, 1.5);
                cairo_move_to(cr, x0, y0);
                cairo_line_to(cr, x1, y0);
                cairo_move_to(cr, x0, y0 - 4);
                cairo_line_to(cr, x0, y0 + 4);
                cairo_move_to(cr, x1, y0 - 4);
                cairo_line_to(cr, x1, y0 + 4);
                cairo_stroke(cr);
                std::ostringstream os;
                os << len << " mm";
                cairo_set_font_size(cr, 11.0);
                cairo_move_to(cr, x1 + 6, y0 + 4);
                cairo_show_text(cr, os.str().c_str());
                break;
            }
        }
    }
}

void Picture::writeSvg(const std::filesystem::path& path, double widthPt) const {
    const double h = heightFor(widthPt);
    const std::filesystem::path tmp = temporaryFor(path);
    cairo_surface_t* s = cairo_svg_surface_create(tmp.c_str(), widthPt, h);
    cairo_t* cr = cairo_create(s);
    render(cr, widthPt, h);
    cairo_destroy(cr);
    cairo_surface_finish(s);
    const cairo_status_t status = cairo_surface_status(s);
    cairo_surface_destroy(s);
    if (status != CAIRO_STATUS_SUCCESS) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        throw std::runtime_error("cannot write " + path.string() + ": " +
                                 cairo_status_to_string(status));
    }
    commitFile(tmp, path);
}

void Picture::writePng(const std::filesystem::path& path, int widthPx) const {
    const double widthPt = 1000.0;
    const double zoom = widthPx / widthPt;
    const double h = heightFor(widthPt);
    cairo_surface_t* s = cairo_image_surface_create(CAIRO_FORMAT_ARGB32, widthPx,
                                                    static_cast<int>(std::ceil(h * zoom)));
    cairo_t* cr = cairo_create(s);
    cairo_scale(cr, zoom, zoom);
    render(cr, widthPt, h);
    cairo_destroy(cr);
    const std::filesystem::path tmp = temporaryFor(path);
    const cairo_status_t status = cairo_surface_write_to_png(s, tmp.c_str());
    cairo_surface_destroy(s);
    if (status != CAIRO_STATUS_SUCCESS) {
        std::error_code ec;
        std::filesystem::remove(tmp, ec);
        throw std::runtime_error("cannot write " + path.string() + ": " +
                                 cairo_status_to_string(status));
    }
    commitFile(tmp, path);
}

}  // namespace veil
