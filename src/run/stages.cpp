// The stage registry with the core's implementations (see stages.hpp).
#include "run/stages.hpp"

#include "forces/controller.hpp"
#include "forces/magnets.hpp"
#include "programs/program_pass.hpp"

namespace parode {

Stages::Stages() {
    add_reference_backends(collide);
    add_reference_solvers(solver);
    forces.add("magnets", [](const Scene& s, Execution&) { return std::make_unique<MagnetPass>(s); }, {},
               "catom magnets, gathered per body on one thread");
    forces.add("program", [](const Scene& s, Execution& e) { return std::make_unique<ProgramPass>(s, e); }, {},
               "the catom program of the scene's [program], its handlers on the execution's loops");
    forces.add("controller", [](const Scene& s, Execution&) { return std::make_unique<ControllerPass>(s); }, {},
               "the scene's [controller] (the buggy's driver)");
    loops.add("loops", [](const Execution&) { return std::make_unique<LoopRunner>(); }, {"serial"},
              "the core's loops on one thread");
    domain.add("single", [](const Scene&, Execution&) { return std::make_unique<Decomposition>(); }, {},
               "one process owns every body");
}

Stages& Stages::instance() {
    static Stages stages;
    return stages;
}

std::unique_ptr<Execution> Stages::execution(ExecutionConfig config) const {
    config.loops = config.loops.empty() ? threaded(loops, "loops") : loops.canonical(config.loops);
    const LoopRegistry& r = loops;
    const std::string name = config.loops;
    return std::make_unique<Execution>(std::move(config), [&r, name](const Execution& e) { return r.make(name, e); });
}

}  // namespace parode
