// Thread choice of the OpenMP stages (see team.hpp).
#include "team.hpp"

#include <algorithm>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "register.hpp"

namespace parode::omp {

Team& Team::instance() {
    static Team team;
    return team;
}

int Team::max_threads() const {
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

int Team::threads(std::size_t items, std::size_t crossover) const {
    if (shared_) return 1;
    if (static_cast<long>(items) < min_parallel(static_cast<long>(crossover))) return 1;
    return max_threads();
}

int Team::sweep_threads(std::size_t items, std::size_t crossover) const {
    if (!try_threads()) return 1;
    if (static_cast<long>(items) < min_parallel(static_cast<long>(crossover))) return 1;
    return max_threads();
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

}  // namespace parode::omp
