// Registration of the OpenMP stages (see stages.hpp).
#include "omp/stages.hpp"

#include <memory>

#include "omp/grid/grid_collide.hpp"
#include "omp/runtime/loop_runner.hpp"
#include "omp/forces/magnet_pass.hpp"
#include "omp/solver/parallel_solver.hpp"
#include "solve/solver.hpp"

namespace parode::omp {

void add_stages(Stages& stages) {
    stages.loops.add("loops/omp", [](const Execution& e) { return std::make_unique<OmpLoopRunner>(e); }, {"omp"},
                     "the core's loops on the execution's threads (dynamic schedule)");
    stages.collide.add("grid", [](Execution& e) { return std::make_unique<GridBackend>(e); }, {"grid/omp"},
                       "uniform grid, neighbour list and OpenMP tasks; ODE's contacts bit for bit");
    stages.collide.add("grid-nolist", [](Execution& e) { return std::make_unique<GridBackend>(e, false); },
                       {"grid-nolist/omp"}, "the grid without its neighbour list");
    stages.forces.add("magnets/omp", [](const Scene& s, Execution& e) { return std::make_unique<MagnetPassOmp>(s, e); },
                      {}, "catom magnets, gathered per body on the execution's threads");
    stages.solver.add(
        "parallel",
        [](const Scene& s, Execution& e) -> std::unique_ptr<SolverBackend> {
            const std::string no = contact_solver_unsupported(s);
            if (!no.empty()) return make_ode_solver(s, "parallel solver not used: " + no);
            return std::make_unique<ParallelContactSolver>(s, e);
        },
        {"pgs/omp"}, "pgs with its sweeps on the execution's threads: the same bits");
    stages.solver.add(
        "adaptive/omp",
        [](const Scene& s, Execution& e) -> std::unique_ptr<SolverBackend> {
            const std::string no = contact_solver_unsupported(s);
            if (!no.empty()) return make_ode_solver(s, "adaptive solver not used: " + no);
            return std::make_unique<ParallelContactSolver>(s, e, true);
        },
        {}, "adaptive with its sweeps on the execution's threads: the same bits");
}

}  // namespace parode::omp
