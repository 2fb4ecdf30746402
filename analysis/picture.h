#pragma once
// A 2D picture in model units (mm) written as SVG and PNG from the same drawing commands
// (Cairo renders both), for layouts and ray path pictures.
//
// Coordinates: the picture's horizontal axis is the optical axis z (left to right), its
// vertical axis is y (up). Sizes of lines and text are in output points, independent of
// the model scale. Files are written to a temporary name and renamed, so a failed write
// never leaves half a picture.

#include <filesystem>
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

class Picture {
  public:
    // Model-space rectangle to show: z in [zMin, zMax], y in [yMin, yMax] (mm).
    Picture(double zMin, double zMax, double yMin, double yMax);

    void polyline(const std::vector<Vec2>& zy, Color stroke, double widthPt, bool dashed = false);
    void polygon(const std::vector<Vec2>& zy, Color fill, Color stroke, double widthPt);
    void text(double z, double y, const std::string& s, Color c, double sizePt,
              bool centred = true);
    // Text placed in output points from the top-left corner (titles, legends).
    void overlayText(double xPt, double yPt, const std::string& s, Color c, double sizePt);
    void overlayLine(double x0Pt, double y0Pt, double x1Pt, double y1Pt, Color c, double widthPt);
    void overlayRect(double xPt, double yPt, double wPt, double hPt, Color fill);
    // A scale bar of a round length in the lower left corner.
    void scaleBar();

    // Page width in points; the height follows the model aspect ratio (plus margins).
    void writeSvg(const std::filesystem::path& path, double widthPt = 1000.0) const;
    void writePng(const std::filesystem::path& path, int widthPx = 2000) const;

    double marginPt = 40.0;
    double titleSpacePt = 30.0;

  private:
    struct Command {
        enum Kind { Polyline, Polygon, Text, OverlayText, OverlayLine, OverlayRect, ScaleBar } kind;
        std::vector<Vec2> points;
        Color stroke, fill;
        double width = 1.0;
        bool dashed = false;
        std::string text;
        bool centred = true;
    };
    void render(void* cairoContext, double widthPt, double heightPt) const;
    double heightFor(double widthPt) const;

    double zMin_, zMax_, yMin_, yMax_;
    std::vector<Command> commands_;
};

}  // namespace veil
