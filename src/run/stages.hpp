// The one registry of every replaceable stage: collide backends, solvers,
// force passes, the core's loop runner and the decomposition over processes.
// The core's implementations are in it from the start; omp::add_stages
// (omp/stages.hpp) and mpi::add_stages (mpi/stages.hpp) add the threaded and
// distributed ones, once, at start-up (the command line does; a program
// linking parode calls them itself). After that it is only read: a pipeline
// makes its stages from it with its own execution context.
// Names: a threaded variant of a serial implementation X is X/omp ("pgs/omp"
// for the threaded "pgs", also known by its older name "parallel";
// "magnets/omp"; "loops/omp"); a pipeline takes X/omp for a force pass or the
// loop runner whenever it is built in.
// Trade-off: a process-wide table filled by explicit calls, not static
// initialisers, which a static library's linker would silently drop.
#pragma once
#include <memory>
#include <string>

#include "collide/collide.hpp"
#include "domain/decomposition.hpp"
#include "exec/execution.hpp"
#include "forces/force_pass.hpp"
#include "solve/solver.hpp"
#include "util/registry.hpp"

namespace parode {

using ForceRegistry = Registry<ForcePass, const Scene&, Execution&>;
using LoopRegistry = Registry<LoopRunner, const Execution&>;
using DomainRegistry = Registry<Decomposition, const Scene&, Execution&>;

class Stages {
public:
    static Stages& instance();

    CollideRegistry collide{"collide backend"};
    SolverRegistry solver{"solver"};
    ForceRegistry forces{"force pass"};
    LoopRegistry loops{"loop runner"};
    DomainRegistry domain{"domain"};

    // An execution context for `config`, its loop runner the one it names,
    // else the best built ("loops/omp" when OpenMP is in, else "loops").
    std::unique_ptr<Execution> execution(ExecutionConfig config) const;
    // "name/omp" when `registry` has it, else `name`.
    template <class R>
    static std::string threaded(const R& registry, const std::string& name) {
        return registry.has(name + "/omp") ? name + "/omp" : name;
    }

private:
    Stages();
};

}  // namespace parode
