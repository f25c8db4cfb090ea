// The solve stage's interface: a SolverBackend advances the world by one step
// given the step's contacts in canonical order. "ode" runs ODE's own stepper
// (dWorldQuickStep or dWorldStep, from the scene) on contact joints made by the
// joints stage; "ode-threaded" is the same on ODE's built-in thread pool
// (islands and QuickStep stages in parallel; not reproducible run to run with
// 2+ threads, which the report states); "pgs" (serial, src/) and its threaded
// variant "pgs/omp" (omp/; also named "parallel") run the project's contact
// solver.
// Trade-off: the project solver handles contact-only scenes (no scene joints,
// no auto-disable); other scenes stay on ODE's stepper and the report says why.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "collide/contacts.hpp"
#include "util/registry.hpp"
#include "exec/execution.hpp"
#include "util/substages.hpp"
#include "world/world.hpp"

namespace parode {

struct WarmImpulse;
class CorrectionExchange;

// Per colour of parode's contact solver, summed over a run's steps: the
// seconds its cells took to relax (the boundary cells, the post, the
// interior cells: the colour's own work on this process) and the seconds
// spent completing its exchange (waiting for the other processes).
struct ColourTimes {
    std::array<double, 8> compute{}, wait{};
};

// The adaptive contact solver's active sweeps so far (solve/active_sweeps.cpp):
// the steps (substeps) that ran them, the sweeps over listed cells (the last
// sweep of every cell included), the contacts those relaxed, and every
// contact of those steps.
struct ActiveWork {
    std::int64_t steps = 0, sweeps = 0, relaxed = 0, contacts = 0;
};

class SolverBackend {
public:
    virtual ~SolverBackend() = default;
    virtual std::string name() const = 0;
    // Why this backend runs (e.g. a fallback to ODE's stepper).
    virtual std::string why() const { return name(); }
    // True if the joints stage must turn contacts into ODE contact joints.
    virtual bool uses_contact_joints() const = 0;
    virtual void step(World& world, const ContactBuffer& contacts) = 0;
    // The impulses kept for the next step's warm start (moved with their
    // bodies between processes), or null.
    virtual std::vector<WarmImpulse>* warm_impulses() { return nullptr; }
    // Where a distributed run exchanges corrections during the solve.
    virtual void set_exchange(CorrectionExchange* /*exchange*/) {}
    // Seconds spent in the backend's substages so far, or null.
    virtual const Substages* substages() const { return nullptr; }
    // Per colour of parode's contact solver, its compute and wait seconds so
    // far (contact_solver.hpp), or null.
    virtual const ColourTimes* colour_times() const { return nullptr; }
    // The adaptive solver's active sweeps so far, or null.
    virtual const ActiveWork* active_work() const { return nullptr; }
    // True when the last step wrote every owned body's state and found it
    // finite as it did (the guard then skips its own scan).
    virtual bool wrote_finite_state() const { return false; }
    // With wrote_finite_state: the largest linear speed it wrote, computed as
    // the guard computes it (negative: not known; the guard then scans).
    virtual double max_speed_written() const { return -1.0; }
};

// Name -> factory, in the stage registry (run/stages.hpp). Factories take
// the scene and the pipeline's execution (threads, loops, scratch pool).
using SolverRegistry = Registry<SolverBackend, const Scene&, Execution&>;
// Adds ode, ode-threaded and pgs.
void add_reference_solvers(SolverRegistry& registry);

// Empty when the project's contact solver can run `scene`, else the reason not.
std::string contact_solver_unsupported(const Scene& scene);
// ODE's stepper, with `why` recorded (used for fallbacks).
std::unique_ptr<SolverBackend> make_ode_solver(const Scene& scene, const std::string& why);

}  // namespace parode
