// Named timers one level below the pipeline's stages (the solver's build,
// warm start, sweeps and integration; the collider's refresh, broadphase,
// narrowphase and merge): seconds accumulated over the run, in the order the
// names first appear, for the run report.
// Trade-off: a steady_clock read on each side of a substage (tens of
// nanoseconds, a few dozen times a step) and a linear search over a handful of
// names, kept out of inner loops.
#pragma once
#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace parode {

class Substages {
public:
    void add(const char* name, double seconds) {
        for (auto& item : items_) {
            if (item.first == name) {
                item.second += seconds;
                return;
            }
        }
        items_.emplace_back(name, seconds);
    }
    const std::vector<std::pair<std::string, double>>& items() const { return items_; }
    // The seconds timed under `name` (0 when none were).
    double seconds(const std::string& name) const {
        for (const auto& item : items_) {
            if (item.first == name) return item.second;
        }
        return 0;
    }

private:
    std::vector<std::pair<std::string, double>> items_;
};

// Seconds on the steady clock: differences of two readings time a phase.
inline double now_seconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// Seconds since an earlier now().
inline double seconds_since(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// Times the rest of a scope into `into` under `name`.
class SubstageTimer {
public:
    SubstageTimer(Substages& into, const char* name) : into_(into), name_(name), t0_(std::chrono::steady_clock::now()) {}
    ~SubstageTimer() { into_.add(name_, seconds_since(t0_)); }
    SubstageTimer(const SubstageTimer&) = delete;
    SubstageTimer& operator=(const SubstageTimer&) = delete;

private:
    Substages& into_;
    const char* name_;
    std::chrono::steady_clock::time_point t0_;
};

}  // namespace parode
