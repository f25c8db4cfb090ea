// Thread choice of the threaded stages (see team.hpp).
#include "exec/team.hpp"

#include <algorithm>

namespace parode {

Team::Team(int threads, long min_parallel, bool adaptive)
    : threads_(std::max(1, threads)), min_parallel_(min_parallel), adaptive_(adaptive) {}

int Team::threads(std::size_t items, std::size_t crossover) const {
    if (shared_) return 1;
    if (static_cast<long>(items) < this->crossover(static_cast<long>(crossover))) return 1;
    return threads_;
}

int Team::sweep_threads(std::size_t items, std::size_t crossover) const {
    if (!try_threads()) return 1;
    if (static_cast<long>(items) < this->crossover(static_cast<long>(crossover))) return 1;
    return threads_;
}

bool barrier_says_shared(double work, double wait, double total_work, double total_wait, int team) {
    if (team <= 1) return false;  // no one to wait for
    const double others = static_cast<double>(team - 1);
    return wait > 1e-3 && wait > others * work && total_wait > others * total_work;
}

void Team::verdict(bool shared) {
    if (!shared || !adaptive_) {
        shared_ = false;
        backoff_ = 1;
        return;
    }
    shared_ = true;
    wait_ = backoff_;
    backoff_ = std::min(2 * backoff_, 16);
}

}  // namespace parode
