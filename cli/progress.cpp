#include "cli/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <utility>

namespace veil::cli {

namespace {

// Terminal redraws at most ~5 per second: the tracer calls every 200 ms, and a little slack
// keeps a call that comes a hair early from skipping a whole frame.
constexpr double kRedrawSeconds = 0.18;
constexpr int kBarWidth = 30;

double rate(uint64_t rays, double seconds) { return seconds > 0.0 ? rays / seconds : 0.0; }

// A rate as text: whole numbers from 100 up, three significant digits below (passes/s).
std::string rateText(double r) {
    std::ostringstream os;
    if (r >= 100.0)
        os << std::fixed << std::setprecision(0) << r;
    else
        os << std::setprecision(3) << r;
    return os.str();
}

}  // namespace

std::string duration(double s) {
    std::ostringstream os;
    if (s >= 3600) os << static_cast<int>(s / 3600) << "h";
    if (s >= 60) os << static_cast<int>(std::fmod(s, 3600) / 60) << "m";
    os << static_cast<int>(std::fmod(s, 60)) << "s";
    return os.str();
}

std::string elapsed(double s) {
    if (s >= 60.0) return duration(s);
    std::ostringstream os;
    os << std::fixed << std::setprecision(1) << s << " s";
    return os.str();
}

ProgressReporter::ProgressReporter(std::string label, uint64_t totalRays, std::string unit)
    : label_(std::move(label)),
      unit_(std::move(unit)),
      totalRays_(totalRays),
      terminal_(isatty(fileno(stderr)) != 0),
      start_(std::chrono::steady_clock::now()) {}

ProgressReporter::~ProgressReporter() {
    if (terminal_ && !finished_ && lastDrawSeconds_ >= 0.0) std::cerr << "\n" << std::flush;
}

double ProgressReporter::secondsSinceStart() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void ProgressReporter::update(uint64_t doneRays) {
    if (finished_) return;
    doneRays = std::min(doneRays, totalRays_);
    lastDoneRays_ = doneRays;
    const double seconds = secondsSinceStart();
    if (terminal_) {
        if (lastDrawSeconds_ < 0.0 || seconds - lastDrawSeconds_ >= kRedrawSeconds)
            drawBar(doneRays, seconds);
        return;
    }
    // The end of the run is finish()'s "done" line, not a quarter.
    if (doneRays >= totalRays_) return;
    const double fraction = static_cast<double>(doneRays) / totalRays_;
    if (fraction * 4.0 < nextQuarter_) return;
    writeLine(doneRays, seconds);
    nextQuarter_ = static_cast<int>(std::floor(fraction * 4.0)) + 1;
}

void ProgressReporter::finish() {
    if (finished_) return;
    const double seconds = secondsSinceStart();
    lastDoneRays_ = totalRays_;
    if (terminal_) {
        // The tracer's last update is usually the full bar already.
        if (lastDrawSeconds_ < 0.0 || drawnRays_ != totalRays_) drawBar(totalRays_, seconds);
        std::cerr << "\n" << std::flush;
    } else {
        std::ostringstream os;
        os << label_ << ": done, " << totalRays_ << " " << unit_ << " in " << elapsed(seconds)
           << ", " << rateText(rate(totalRays_, seconds)) << " " << unit_ << "/s\n";
        std::cerr << os.str() << std::flush;
    }
    finished_ = true;
}

void ProgressReporter::drawBar(uint64_t doneRays, double seconds) {
    const double fraction = totalRays_ ? static_cast<double>(doneRays) / totalRays_ : 1.0;
    const int filled = static_cast<int>(kBarWidth * fraction);
    const double raysPerSecond = rate(doneRays, seconds);
    const std::string left =
        raysPerSecond > 0.0 ? duration((totalRays_ - doneRays) / raysPerSecond) : "-";
    // Formatted aside so std::cerr keeps its own format flags; trailing blanks wipe what a
    // longer previous line left behind.
    std::ostringstream os;
    os << "\r" << label_ << " [" << std::string(filled, '#') << std::string(kBarWidth - filled, ' ')
       << "] " << std::setw(5) << std::fixed << std::setprecision(1) << 100.0 * fraction << "%  "
       << rateText(raysPerSecond) << " " << unit_ << "/s  ETA " << left << "   ";
    std::cerr << os.str() << std::flush;
    lastDrawSeconds_ = seconds;
    drawnRays_ = doneRays;
}

void ProgressReporter::writeLine(uint64_t doneRays, double seconds) {
    std::ostringstream os;
    os << label_ << ": " << std::fixed << std::setprecision(1) << 100.0 * doneRays / totalRays_
       << " % (" << doneRays << " of " << totalRays_ << " " << unit_ << "), "
       << rateText(rate(doneRays, seconds)) << " " << unit_ << "/s, " << elapsed(seconds)
       << " elapsed\n";
    std::cerr << os.str() << std::flush;
}

std::ostream& operator<<(std::ostream& os, const ProgressReporter& p) {
    return os << "ProgressReporter{'" << p.label_ << "', " << p.lastDoneRays_ << " of "
              << p.totalRays_ << " " << p.unit_ << ", " << (p.terminal_ ? "terminal" : "log lines")
              << (p.finished_ ? ", finished" : "") << "}";
}

}  // namespace veil::cli
