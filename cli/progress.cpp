// Progress bar (see progress.hpp).
#include "progress.hpp"

#include <atomic>
#include <cstdio>

namespace parode::cli {
namespace {

std::atomic<bool> g_line_open{false};

// "2.5 s", "3 min 20 s", "1 h 05 min".
void format_duration(double s, char* out, std::size_t n) {
    if (s < 60) std::snprintf(out, n, "%.1f s", s);
    else if (s < 3600) std::snprintf(out, n, "%d min %02d s", static_cast<int>(s / 60), static_cast<int>(s) % 60);
    else std::snprintf(out, n, "%d h %02d min", static_cast<int>(s / 3600), static_cast<int>(s / 60) % 60);
}

}  // namespace

Progress::Progress(long total, bool on)
    : total_(total), on_(on && total > 0), start_(std::chrono::steady_clock::now()) {}

Progress::~Progress() { end_progress_line(); }

void Progress::update(long done) {
    if (!on_) return;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const int pct = static_cast<int>(100 * done / total_);
    // Redraw on a new percent or every quarter second, and always at the end.
    if (pct == last_pct_ && elapsed - last_draw_ < 0.25 && done != total_) return;
    last_pct_ = pct;
    last_draw_ = elapsed;
    draw(done, elapsed);
    if (done == total_) end_progress_line();
}

void Progress::draw(long done, double elapsed) {
    const int width = 30, fill = static_cast<int>(width * done / total_);
    const double rate = elapsed > 0 ? static_cast<double>(done) / elapsed : 0;
    char spent[32], left[32] = "?";
    format_duration(elapsed, spent, sizeof spent);
    if (rate > 0) format_duration(static_cast<double>(total_ - done) / rate, left, sizeof left);
    // \033[K clears what a longer previous line left behind.
    std::fprintf(stderr, "\r[%.*s%*s] %3d%% step %ld/%ld  %s  %.1f steps/s  %s left\033[K", fill,
                 "##############################", width - fill, "", static_cast<int>(100 * done / total_), done,
                 total_, spent, rate, left);
    std::fflush(stderr);
    g_line_open = true;
}

void end_progress_line() {
    if (!g_line_open.exchange(false)) return;
    std::fputc('\n', stderr);
    std::fflush(stderr);
}

}  // namespace parode::cli
