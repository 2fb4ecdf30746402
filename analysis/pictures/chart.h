#pragma once
// Line charts with error bars, drawn as a Picture (SVG and PNG from the same page): what
// studies plot (a sweep's stray light against the varied value, point source transmittance
// against the angle).
//
// Axes are linear or logarithmic. chooseLogAxis() takes log when every value is positive and
// they span at least a decade; on a log axis points at or below zero are left out (and
// counted in the chart's note), error bars are clipped at the bottom of the axis. Ticks are
// round numbers (niceTicks) on a linear axis and powers of ten on a log one (with 2 and 5
// between them when the axis spans few decades).

#include <string>
#include <utility>
#include <vector>

#include "analysis/pictures/picture.h"

namespace veil {

struct ChartSeries {
    std::string label;
    std::vector<double> x, y, yError;  // yError: 1 sigma, empty or one per point
    bool dashed = false;
    bool markers = true;  // a dot at every point (off for densely sampled curves)
};

struct ChartSpec {
    std::string title;
    std::string xLabel, yLabel;
    bool logX = false, logY = false;
    std::vector<ChartSeries> series;
    // Category labels for the x axis instead of numbers (x = 0, 1, ...); empty: numbers.
    std::vector<std::string> xCategories;
    // Vertical dashed lines at these x values with their labels (the edge of a field).
    std::vector<std::pair<double, std::string>> xMarkers;
};

// Whether these values ask for a log axis: all positive and max / min >= 10.
bool chooseLogAxis(const std::vector<double>& values);

// The chart as a picture (1000 pt wide page). Throws std::invalid_argument when no series
// has a point that can be drawn.
Picture drawChart(const ChartSpec& spec);

}  // namespace veil
