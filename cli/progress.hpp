// The progress bar of `parode run` on stderr: bar, percentage, step, elapsed
// time, rate (steps/s) and estimated time left, redrawn in place with '\r'.
// Drawn only when stderr is a terminal. Any message printed while a bar line is
// open first ends that line (end_progress_line()), so an error never shares
// the bar's line; the destructor ends it too, when an exception unwinds a run.
// Trade-off: one global "line open" flag instead of routing every message
// through the bar: messages come from many places (the error guard, ODE's
// handlers), and a flag is all they need to check.
#pragma once
#include <chrono>

namespace parode::cli {

class Progress {
public:
    Progress(long total, bool on);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;
    void update(long done);

private:
    void draw(long done, double elapsed);
    long total_;
    bool on_;
    int last_pct_ = -1;
    double last_draw_ = -1;
    std::chrono::steady_clock::time_point start_;
};

// Ends the bar's line on stderr if one is open; safe to call at any time.
void end_progress_line();

}  // namespace parode::cli
