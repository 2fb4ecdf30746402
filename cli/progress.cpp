#include "cli/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <iostream>
#include <sstream>
#include <utility>

#include "analysis/reports/format.h"

namespace veil::cli {

namespace {

// Terminal redraws at most ~5 per second: the tracer calls every 200 ms, and a little slack
// keeps a call that comes a hair early from skipping a whole frame.
constexpr double kRedrawSeconds = 0.18;
constexpr int kBarWidth = 30;
// A task of unknown size in a log: a line at most this often.
constexpr double kOpenLineSeconds = 10.0;

// Before kRateSeconds a rate is not known yet (a task's first event can carry a whole batch
// done in no measurable time: billions of rays/s), and shows as 0.
constexpr double kRateSeconds = 0.05;
double rate(uint64_t units, double seconds) {
    return seconds >= kRateSeconds ? units / seconds : 0.0;
}

// A rate as text: whole numbers from 100 up, three significant digits below (passes/s).
std::string rateText(double r) {
    std::ostringstream os;
    if (r >= 100.0)
        os << std::fixed << std::setprecision(0) << r;
    else
        os << std::setprecision(3) << r;
    return os.str();
}

std::string etaText(const ProgressEvent& e, double seconds) {
    if (std::isfinite(e.etaSeconds)) return duration(std::max(e.etaSeconds, 0.0));
    const double r = rate(e.done, seconds);
    if (e.total == 0 || !(r > 0.0)) return "-";
    return duration(static_cast<double>(e.total - std::min(e.done, e.total)) / r);
}

}  // namespace

ProgressReporter::ProgressReporter() : terminal_(isatty(fileno(stderr)) != 0) {}

ProgressReporter::~ProgressReporter() {
    if (terminal_ && open_ && lastDrawSeconds_ >= 0.0) std::cerr << "\n" << std::flush;
}

double ProgressReporter::secondsSinceStart() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

void ProgressReporter::start(const ProgressEvent& e) {
    finish();
    open_ = true;
    last_ = e;
    last_.done = 0;
    start_ = std::chrono::steady_clock::now();
    lastDrawSeconds_ = -1.0;
    drawnUnits_ = 0;
    nextQuarter_ = 0;
    lastLineSeconds_ = -1e9;
}

void ProgressReporter::report(const ProgressEvent& e) {
    if (!open_ || e.task != last_.task) start(e);
    last_ = e;
    if (last_.total > 0) last_.done = std::min(last_.done, last_.total);
    const double seconds = secondsSinceStart();
    if (terminal_) {
        if (lastDrawSeconds_ < 0.0 || seconds - lastDrawSeconds_ >= kRedrawSeconds) {
            if (last_.total > 0)
                drawBar(seconds);
            else
                drawOpen(seconds);
        }
        return;
    }
    if (last_.total == 0) {
        if (seconds - lastLineSeconds_ < kOpenLineSeconds) return;
        writeLine(seconds);
        lastLineSeconds_ = seconds;
        return;
    }
    // The end of the task is finish()'s "done" line, not a quarter.
    if (last_.done >= last_.total) return;
    const double fraction = static_cast<double>(last_.done) / last_.total;
    if (fraction * 4.0 < nextQuarter_) return;
    writeLine(seconds);
    nextQuarter_ = static_cast<int>(std::floor(fraction * 4.0)) + 1;
}

void ProgressReporter::finishAt(uint64_t done) {
    if (!open_) return;
    last_.total = done;
    last_.done = done;
    finish();
}

void ProgressReporter::finish() {
    if (!open_) return;
    const double seconds = secondsSinceStart();
    if (last_.total > 0) last_.done = last_.total;
    if (terminal_) {
        // The run's last event is usually the full bar already.
        if (lastDrawSeconds_ < 0.0 || drawnUnits_ != last_.done) {
            if (last_.total > 0)
                drawBar(seconds);
            else
                drawOpen(seconds);
        }
        std::cerr << "\n" << std::flush;
    } else if (last_.unit.empty()) {
        std::cerr << last_.task << ": done in " << elapsed(seconds) << "\n" << std::flush;
    } else {
        std::ostringstream os;
        os << last_.task << ": done, " << last_.done << " " << last_.unit << " in "
           << elapsed(seconds) << ", " << rateText(rate(last_.done, seconds)) << " "
           << last_.unit << "/s";
        if (last_.total == 0 && !last_.state.empty()) os << ", " << last_.state;
        std::cerr << os.str() << "\n" << std::flush;
    }
    open_ = false;
}

void ProgressReporter::drawBar(double seconds) {
    const double fraction =
        last_.total ? static_cast<double>(last_.done) / last_.total : 1.0;
    const int filled = static_cast<int>(kBarWidth * fraction);
    // Formatted aside so std::cerr keeps its own format flags; trailing blanks wipe what a
    // longer previous line left behind.
    std::ostringstream os;
    os << "\r" << last_.task << " [" << std::string(filled, '#')
       << std::string(kBarWidth - filled, ' ') << "] " << std::setw(5) << std::fixed
       << std::setprecision(1) << 100.0 * fraction << "%  "
       << rateText(rate(last_.done, seconds)) << " " << last_.unit << "/s  ETA "
       << etaText(last_, seconds);
    if (!last_.state.empty()) os << "  " << last_.state;
    os << "   ";
    std::cerr << os.str() << std::flush;
    lastDrawSeconds_ = seconds;
    drawnUnits_ = last_.done;
}

void ProgressReporter::drawOpen(double seconds) {
    std::ostringstream os;
    if (last_.unit.empty()) {
        // A phase without units: its name and how long it has run.
        os << "\r" << last_.task << ", " << elapsed(seconds) << "\033[K";
        std::cerr << os.str() << std::flush;
        lastDrawSeconds_ = seconds;
        return;
    }
    os << "\r" << last_.task << ": " << last_.done << " " << last_.unit;
    if (!last_.state.empty()) os << ", " << last_.state;
    os << ", ETA " << etaText(last_, seconds) << "\033[K";
    std::cerr << os.str() << std::flush;
    lastDrawSeconds_ = seconds;
    drawnUnits_ = last_.done;
}

void ProgressReporter::writeLine(double seconds) {
    std::ostringstream os;
    os << last_.task << ": ";
    if (last_.unit.empty())
        ;  // a phase: how long it has run
    else if (last_.total > 0)
        os << std::fixed << std::setprecision(1) << 100.0 * last_.done / last_.total << " % ("
           << last_.done << " of " << last_.total << " " << last_.unit << "), "
           << rateText(rate(last_.done, seconds)) << " " << last_.unit << "/s, "
           << (last_.state.empty() ? "" : last_.state + ", ");
    else
        os << last_.done << " " << last_.unit << ", "
           << (last_.state.empty() ? "" : last_.state + ", ") << "ETA "
           << etaText(last_, seconds) << ", ";
    os << elapsed(seconds) << " elapsed\n";
    std::cerr << os.str() << std::flush;
}

std::ostream& operator<<(std::ostream& os, const ProgressReporter& p) {
    return os << "ProgressReporter{'" << p.last_.task << "', " << p.last_.done << " of "
              << p.last_.total << " " << p.last_.unit << ", "
              << (p.terminal_ ? "terminal" : "log lines") << (p.open_ ? "" : ", finished") << "}";
}

}  // namespace veil::cli
