// The forces stage's interface: a ForcePass adds forces and torques to the
// owned bodies of a World before each step, in an order that fixes every sum
// (results never depend on threads or processes). The pipeline runs the
// passes the scene needs, in the order it lists them, each made from the stage
// registry (run/stages.hpp) with the pipeline's execution context:
// "magnets" (catom magnets, magnets.hpp; "magnets/omp" gathers on threads)
// and "controller" (the buggy's driver, controller.hpp). Catom programs
// will be passes too.
// Trade-off: one virtual call per pass per step; a pass keeps what it needs
// between steps (the magnets' cell list) instead of the pipeline holding it.
#pragma once
#include <string>

#include "world/world.hpp"

namespace parode {

class ForcePass {
public:
    virtual ~ForcePass() = default;
    virtual std::string name() const = 0;
    // Adds this pass's forces to the owned bodies of `world` at simulated
    // time `time` (seconds since the run's start).
    virtual void apply(World& world, double time) = 0;
};

}  // namespace parode
