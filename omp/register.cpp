// Registration of the OpenMP backends (see register.hpp): "grid", the uniform
// grid broadphase with a task-parallel narrowphase (grid_collide.hpp), and the
// parallel magnet gather (magnet_pass.hpp).
#include "register.hpp"

#include <cstdlib>
#include <memory>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "collide/collide.hpp"
#include "grid_collide.hpp"
#include "loop_runner.hpp"
#include "magnet_pass.hpp"
#include "parallel_solver.hpp"
#include "team.hpp"
#include "solve/solver.hpp"

namespace parode::omp {

void register_backends() {
    // PARODE_MIN_PARALLEL=N: stages run threaded from N items on, whatever
    // their crossover and however long threads wait (jobs/crossover.py
    // measures the crossovers with it).
    if (const char* env = std::getenv("PARODE_MIN_PARALLEL")) {
        set_min_parallel(std::atol(env));
        Team::instance().set_adaptive(false);
    }
    static const OmpLoopRunner runner;
    set_loop_runner(&runner);
    BackendRegistry::instance().add("grid", [] { return std::make_unique<GridBackend>(); });
    BackendRegistry::instance().add("grid-nolist", [] { return std::make_unique<GridBackend>(false); });
    set_magnet_gather(&gather_magnets_parallel);
    SolverRegistry::instance().add("parallel", [](const Scene& s, int) -> std::unique_ptr<SolverBackend> {
        const std::string no = contact_solver_unsupported(s);
        if (!no.empty()) return make_ode_solver(s, "parallel solver not used: " + no);
        return std::make_unique<ParallelContactSolver>(s);
    });
}

void set_threads(int threads) {
#ifdef _OPENMP
    if (threads > 0) omp_set_num_threads(threads);
#else
    (void)threads;
#endif
}

namespace {
long g_min_parallel = -1;
}

void set_min_parallel(long items) { g_min_parallel = items; }
long min_parallel(long default_items) { return g_min_parallel >= 0 ? g_min_parallel : default_items; }

int max_threads() {
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

}  // namespace parode::omp
