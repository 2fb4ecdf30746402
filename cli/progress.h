#pragma once
// The progress report of long runs on standard error (veil trace, veil ghosts' Monte Carlo).
//
// On a terminal one line is redrawn in place ('\r'), at most 5 times a second:
//
//   trace [###########                   ]  36.2%  48211 rays/s  ETA 1m12s
//
// Anywhere else (a log file, a pipe, CI) '\r' would pile every redraw onto one garbled line,
// so it writes whole lines instead, never '\r': one at the start, one as the run passes
// 25, 50 and 75 %, and one when done, each with the rate and the time elapsed (at most five
// lines a run; a run that jumps past several marks at once reports once):
//
//   trace: 50.3 % (503000 of 1000000 rays), 48211 rays/s, 10.4 s elapsed
//   trace: done, 1000000 rays in 20.7 s, 48309 rays/s
//
// The commands make none with --quiet (veil ghosts none with --json either).

#include <chrono>
#include <cstdint>
#include <ostream>
#include <string>

namespace veil::cli {

// "1h2m3s", "4m5s", "6s": a time left.
std::string duration(double seconds);
// Elapsed time: tenths of a second for short runs ("12.3 s"), h/m/s beyond a minute.
std::string elapsed(double seconds);

class ProgressReporter {
  public:
    // `label` starts every report ("trace", "Monte Carlo"); `totalRays` is the run's size, in
    // `unit` (plural: "rays", "passes"). The mode is chosen once here: a terminal when
    // isatty(fileno(stderr)).
    ProgressReporter(std::string label, uint64_t totalRays, std::string unit = "rays");
    // On a terminal, ends a line left open by a run that did not finish (an exception), so
    // the error message starts on a line of its own.
    ~ProgressReporter();
    ProgressReporter(const ProgressReporter&) = delete;
    ProgressReporter& operator=(const ProgressReporter&) = delete;

    // Rays done so far, from one thread (traceNonsequential's progress callback).
    void update(uint64_t doneRays);
    // The closing report ("done" line, or the full bar and a newline); once.
    void finish();
    // A run that ended early (paths found before the budget): done after `done` rays.
    void finishAt(uint64_t done) {
        totalRays_ = done;
        finish();
    }

    bool terminal() const { return terminal_; }
    friend std::ostream& operator<<(std::ostream& os, const ProgressReporter& p);

  private:
    void drawBar(uint64_t doneRays, double seconds);
    void writeLine(uint64_t doneRays, double seconds);
    double secondsSinceStart() const;

    std::string label_;
    std::string unit_;
    uint64_t totalRays_ = 0;
    bool terminal_ = false;
    std::chrono::steady_clock::time_point start_;
    uint64_t lastDoneRays_ = 0;
    // Terminal: when the bar was last drawn (seconds since start; negative: never) and the
    // rays it showed.
    double lastDrawSeconds_ = -1.0;
    uint64_t drawnRays_ = 0;
    // Log: the next quarter (0..4) that earns a line; 4 is left to finish().
    int nextQuarter_ = 0;
    bool finished_ = false;
};

}  // namespace veil::cli
