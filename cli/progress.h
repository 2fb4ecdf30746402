#pragma once
// The one progress reporter of the veil command line: every run's ProgressEvents
// (analysis/reports/progress.h) on standard error.
//
// On a terminal one line is redrawn in place ('\r'), at most 5 times a second:
//
//   trace [###########                   ]  36.2%  48211 rays/s  ETA 1m12s
//   render: 3 passes, error 12.3 %, radius 1.21 mm, 81234 photons/s, ETA 1m12s
//
// Anywhere else (a log file, a pipe, CI) '\r' would pile every redraw onto one garbled line,
// so it writes whole lines instead, never '\r'. A task of known size gets one line at the
// start, one as it passes 25, 50 and 75 %, and one when done, each with the rate and the time
// elapsed (at most five lines a task; a run that jumps past several marks at once reports
// once); a task of unknown size (a render, which its stop rules end) one line every 10 s and
// one when done:
//
//   trace: 50.3 % (503000 of 1000000 rays), 48211 rays/s, 10.4 s elapsed
//   trace: done, 1000000 rays in 20.7 s, 48309 rays/s
//
// A new task text ends the task before it (its "done" line), so a study's steps (a sweep's
// variants, a PST's angles) each get their lines. The commands make none with --quiet (veil
// ghosts none with --json either).

#include <chrono>
#include <cstdint>
#include <ostream>
#include <string>

#include "analysis/reports/progress.h"

namespace veil::cli {

class ProgressReporter {
  public:
    // The mode is chosen once here: a terminal when isatty(fileno(stderr)).
    ProgressReporter();
    // On a terminal, ends a line left open by a run that did not finish (an exception), so
    // the error message starts on a line of its own.
    ~ProgressReporter();
    ProgressReporter(const ProgressReporter&) = delete;
    ProgressReporter& operator=(const ProgressReporter&) = delete;

    // An event from the run (one thread at a time).
    void report(const ProgressEvent& event);
    // The sink to hand a run's spec: report() on this reporter.
    ProgressSink sink() {
        return [this](const ProgressEvent& e) { report(e); };
    }
    // The closing report of the current task ("done" line, or the full bar and a newline);
    // nothing when there is none or it is closed.
    void finish();
    // A task that ended early (paths found before the budget): done after `done` units.
    void finishAt(uint64_t done);

    bool terminal() const { return terminal_; }
    friend std::ostream& operator<<(std::ostream& os, const ProgressReporter& p);

  private:
    void start(const ProgressEvent& e);
    void drawBar(double seconds);
    void drawOpen(double seconds);
    void writeLine(double seconds);
    double secondsSinceStart() const;

    bool terminal_ = false;
    bool open_ = false;  // a task is running
    ProgressEvent last_;
    std::chrono::steady_clock::time_point start_;
    // Terminal: when the line was last drawn (seconds since start; negative: never) and the
    // units it showed.
    double lastDrawSeconds_ = -1.0;
    uint64_t drawnUnits_ = 0;
    // Log: the next quarter (0..4) that earns a line (4 is left to finish()); for a task of
    // unknown size, when the last line was written.
    int nextQuarter_ = 0;
    double lastLineSeconds_ = -1e9;
};

}  // namespace veil::cli
