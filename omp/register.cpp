// Registration of the OpenMP backends (see register.hpp): "grid", the uniform
// grid broadphase with a task-parallel narrowphase (grid_collide.hpp), and the
// parallel magnet gather (magnet_pass.hpp).
#include "register.hpp"

#include <memory>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "collide.hpp"
#include "grid_collide.hpp"
#include "magnet_pass.hpp"

namespace parode::omp {

void register_backends() {
    BackendRegistry::instance().add("grid", [] { return std::make_unique<GridBackend>(); });
    set_magnet_gather(&gather_magnets_parallel);
}

void set_threads(int threads) {
#ifdef _OPENMP
    if (threads > 0) omp_set_num_threads(threads);
#else
    (void)threads;
#endif
}

int max_threads() {
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

}  // namespace parode::omp
