#include "analysis/pictures/chart.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>

namespace veil {

namespace {

// The page, in model units of one point each: a 920 x 560 model rectangle fills the 1000 pt
// page between its 40 pt margins. The plot area sits inside it with room for tick labels.
constexpr double kWidth = 920.0, kHeight = 560.0;
constexpr double kLeft = 110.0, kRight = kWidth - 20.0, kBottom = 70.0, kTop = kHeight - 30.0;

// Colour-blind-safe qualitative palette (Okabe and Ito), black last.
const Color kPalette[] = {Color::hex(0x0072B2), Color::hex(0xD55E00), Color::hex(0x009E73),
                          Color::hex(0xCC79A7), Color::hex(0xE69F00), Color::hex(0x56B4E9),
                          Color::hex(0xF0E442), Color::hex(0x000000)};
const Color kGrid = Color::hex(0xDDDDDD), kInk = Color::hex(0x222222);
constexpr size_t kMaxLabel = 90;

struct Axis {
    bool log = false;
    double lo = 0.0, hi = 1.0;  // in axis units (log10 of the value on a log axis)
    std::vector<double> ticks;  // in axis units
    std::vector<std::string> labels;

    double unit(double v) const { return log ? std::log10(v) : v; }
    bool drawable(double v) const { return std::isfinite(v) && (!log || v > 0.0); }
    // Page position along [from, to] of a value.
    double at(double v, double from, double to) const {
        return from + (unit(v) - lo) / (hi - lo) * (to - from);
    }
};

std::string shortNumber(double v) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.3g", v);
    return buf;
}

// Range and ticks over the drawable values in [lo, hi] (values, not axis units).
Axis makeAxis(bool log, double lo, double hi) {
    Axis a;
    a.log = log;
    if (log) {
        a.lo = std::log10(lo);
        a.hi = std::log10(hi);
        if (a.hi - a.lo < 1e-9) {
            a.lo -= 0.5;
            a.hi += 0.5;
        }
        const double pad = 0.05 * (a.hi - a.lo);
        a.lo -= pad;
        a.hi += pad;
        const bool fine = a.hi - a.lo <= 2.5;
        for (int k = static_cast<int>(std::floor(a.lo)); k <= static_cast<int>(std::ceil(a.hi));
             ++k) {
            for (int m : {1, 2, 5}) {
                if (m != 1 && !fine) continue;
                const double u = k + std::log10(static_cast<double>(m));
                if (u < a.lo || u > a.hi) continue;
                a.ticks.push_back(u);
                char buf[32];
                std::snprintf(buf, sizeof(buf), "%de%d", m, k);
                a.labels.push_back(k == 0 ? std::to_string(m) : std::string(buf));
            }
        }
        return a;
    }
    a.lo = lo;
    a.hi = hi;
    if (!(a.hi > a.lo)) {
        const double d = a.lo != 0.0 ? 0.1 * std::abs(a.lo) : 1.0;
        a.lo -= d;
        a.hi += d;
    }
    const double pad = 0.05 * (a.hi - a.lo);
    a.lo -= pad;
    a.hi += pad;
    const Ticks t = niceTicks(a.lo, a.hi, 7);
    const double big = std::max(std::abs(a.lo), std::abs(a.hi));
    const bool scientific = big >= 1e5 || t.step < 1e-3;
    for (double v : t.values) {
        a.ticks.push_back(v);
        a.labels.push_back(scientific ? (std::abs(v) < 1e-12 * big ? "0" : shortNumber(v))
                                      : t.label(v));
    }
    return a;
}

}  // namespace

bool chooseLogAxis(const std::vector<double>& values) {
    double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
    for (double v : values) {
        if (!std::isfinite(v)) continue;
        if (v <= 0.0) return false;
        lo = std::min(lo, v);
        hi = std::max(hi, v);
    }
    return hi > 0.0 && hi >= 10.0 * lo;
}

Picture drawChart(const ChartSpec& spec) {
    const bool categories = !spec.xCategories.empty();
    const bool logX = spec.logX && !categories;
    // The ranges over what can be drawn.
    double xLo = std::numeric_limits<double>::infinity(), xHi = -xLo, yLo = xLo, yHi = -xLo;
    int points = 0, hidden = 0;
    for (const ChartSeries& s : spec.series) {
        for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
            const double x = s.x[i], y = s.y[i];
            const bool ok = std::isfinite(x) && std::isfinite(y) && (!logX || x > 0.0) &&
                            (!spec.logY || y > 0.0);
            if (!ok) {
                ++hidden;
                continue;
            }
            ++points;
            xLo = std::min(xLo, x);
            xHi = std::max(xHi, x);
            const double e = i < s.yError.size() && std::isfinite(s.yError[i]) ? s.yError[i] : 0.0;
            yLo = std::min(yLo, spec.logY && y - e <= 0.0 ? y : y - e);
            yHi = std::max(yHi, y + e);
        }
    }
    if (points == 0) throw std::invalid_argument("drawChart: no point to draw");
    Axis ax;
    if (categories) {
        ax.lo = -0.5;
        ax.hi = static_cast<double>(spec.xCategories.size()) - 0.5;
        for (size_t i = 0; i < spec.xCategories.size(); ++i) {
            ax.ticks.push_back(static_cast<double>(i));
            ax.labels.push_back(spec.xCategories[i]);
        }
    } else {
        ax = makeAxis(logX, xLo, xHi);
    }
    const Axis ay = makeAxis(spec.logY, yLo, yHi);

    Picture pic(0.0, kWidth, 0.0, kHeight);
    pic.title(spec.title);
    auto px = [&](double x) { return ax.at(x, kLeft, kRight); };
    auto py = [&](double y) { return ay.at(y, kBottom, kTop); };
    // Grid and tick labels.
    for (size_t i = 0; i < ax.ticks.size(); ++i) {
        const double x = kLeft + (ax.ticks[i] - ax.lo) / (ax.hi - ax.lo) * (kRight - kLeft);
        pic.polyline({{x, kBottom}, {x, kTop}}, kGrid, 0.6);
        pic.text(x, kBottom - 18.0, ax.labels[i], kInk, 11.0, TextAnchor::Middle);
    }
    for (size_t i = 0; i < ay.ticks.size(); ++i) {
        const double y = kBottom + (ay.ticks[i] - ay.lo) / (ay.hi - ay.lo) * (kTop - kBottom);
        pic.polyline({{kLeft, y}, {kRight, y}}, kGrid, 0.6);
        pic.text(kLeft - 8.0, y - 4.0, ay.labels[i], kInk, 11.0, TextAnchor::End);
    }
    pic.polyline(
        {{kLeft, kBottom}, {kRight, kBottom}, {kRight, kTop}, {kLeft, kTop}, {kLeft, kBottom}},
        kInk, 1.0);
    pic.text(0.5 * (kLeft + kRight), kBottom - 45.0, spec.xLabel + (logX ? " (log scale)" : ""),
             kInk, 13.0, TextAnchor::Middle);
    pic.text(kLeft, kTop + 10.0, spec.yLabel + (spec.logY ? " (log scale)" : ""), kInk, 13.0,
             TextAnchor::Start);

    for (const auto& [x, label] : spec.xMarkers) {
        if (!ax.drawable(x) && !categories) continue;
        const double px0 = px(x);
        if (px0 < kLeft || px0 > kRight) continue;
        pic.polyline({{px0, kBottom}, {px0, kTop}}, Color::hex(0x888888), 1.0, true);
        pic.text(px0 + 4.0, kTop - 14.0, label, Color::hex(0x555555), 10.0, TextAnchor::Start);
    }

    // Series: error bars, lines, markers.
    std::vector<LegendEntry> legend;
    for (size_t k = 0; k < spec.series.size(); ++k) {
        const ChartSeries& s = spec.series[k];
        const Color c = kPalette[k % (sizeof(kPalette) / sizeof(kPalette[0]))];
        std::vector<Vec2> line;
        auto flush = [&] {
            if (line.size() > 1) pic.polyline(line, c, 1.8, s.dashed);
            line.clear();
        };
        for (size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
            const double x = s.x[i], y = s.y[i];
            if (!(ax.drawable(x) || categories) || !ay.drawable(y)) {
                flush();  // a gap where a variant has no value
                continue;
            }
            const Vec2 p{px(x), py(y)};
            const double e = i < s.yError.size() && std::isfinite(s.yError[i]) ? s.yError[i] : 0.0;
            if (e > 0.0) {
                const double top = py(y + e);
                const double bottom = ay.drawable(y - e) ? py(y - e) : kBottom;
                pic.polyline({{p.x, std::max(bottom, kBottom)}, {p.x, std::min(top, kTop)}}, c,
                             1.0);
                for (double yy : {std::max(bottom, kBottom), std::min(top, kTop)})
                    pic.polyline({{p.x - 4.0, yy}, {p.x + 4.0, yy}}, c, 1.0);
            }
            line.push_back(p);
        }
        flush();
        for (size_t i = 0; s.markers && i < s.x.size() && i < s.y.size(); ++i)
            if ((ax.drawable(s.x[i]) || categories) && ay.drawable(s.y[i]))
                pic.dot({px(s.x[i]), py(s.y[i])}, 3.0, c, c);
        // Long labels (a criterion written out) are cut: the tables hold them whole.
        std::string label = s.label;
        if (label.size() > kMaxLabel) label = label.substr(0, kMaxLabel - 3) + "...";
        legend.push_back({label,
                          s.dashed ? LegendEntry::Swatch::DashedLine : LegendEntry::Swatch::Line, c,
                          c, 1.8});
    }
    if (hidden > 0)
        pic.text(kRight, kTop + 10.0,
                 std::to_string(hidden) + (hidden == 1 ? " value" : " values") +
                     " not drawn (zero or none on a log axis)",
                 kInk, 10.0, TextAnchor::End);
    pic.legend(std::move(legend));
    return pic;
}

}  // namespace veil
