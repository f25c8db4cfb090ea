// Solver backends and their registry (see solver.hpp).
#include "solve/solver.hpp"

#include <algorithm>
#include <string>

#include "solve/contact_solver.hpp"

namespace parode {
namespace {

// What a run on ODE's stepper leaves out of the scene's settings: substeps
// are the project's contact solver's; ODE takes whole steps.
std::string ode_ignores(const Scene& scene) {
    if (scene.solver.substeps <= 1) return "";
    return "solver.substeps = " + std::to_string(scene.solver.substeps) + " not used (ODE's stepper takes whole steps)";
}

std::string joined(std::string a, const std::string& b) {
    if (a.empty() || b.empty()) return a + b;
    return a + "; " + b;
}

// One step of ODE's stepper with this world's dRand sequence (world.hpp).
void ode_step(World& world, const Scene& scene) {
    dRandSetSeed(world.drand_seed());
    if (scene.solver.stepper == Stepper::Quick) dWorldQuickStep(world.id(), scene.dt);
    else dWorldStep(world.id(), scene.dt);
    world.set_drand_seed(dRandGetSeed());
    world.settle_quaternions();
}

class OdeSolver final : public SolverBackend {
public:
    OdeSolver(const Scene& scene, std::string why) : scene_(scene), why_(std::move(why)) {}
    std::string name() const override {
        return scene_.solver.stepper == Stepper::Quick ? "ode-quickstep" : "ode-worldstep";
    }
    std::string why() const override {
        const std::string more = joined(why_, ode_ignores(scene_));
        return more.empty() ? name() : name() + ": " + more;
    }
    bool uses_contact_joints() const override { return true; }
    void step(World& world, const ContactBuffer& /*contacts*/) override { ode_step(world, scene_); }

private:
    const Scene& scene_;
    std::string why_;
};

// ODE's stepper on ODE's built-in thread pool (dThreadingAllocateMultiThreaded-
// Implementation), attached to the world at the first step, detached at the end.
class OdeThreadedSolver final : public SolverBackend {
public:
    OdeThreadedSolver(const Scene& scene, int threads) : scene_(scene), threads_(std::max(1, threads)) {}
    ~OdeThreadedSolver() override {
        if (!impl_) return;
        dThreadingImplementationShutdownProcessing(impl_);
        dThreadingFreeThreadPool(pool_);
        dWorldSetStepThreadingImplementation(world_, nullptr, nullptr);
        dThreadingFreeImplementation(impl_);
    }
    std::string name() const override { return "ode-threaded"; }
    std::string why() const override {
        return joined("ODE's staged QuickStep on its own pool of " + std::to_string(threads_) +
                          " threads (not reproducible run to run with 2+ threads)",
                      ode_ignores(scene_));
    }
    bool uses_contact_joints() const override { return true; }
    void step(World& world, const ContactBuffer& /*contacts*/) override {
        if (!impl_) attach(world.id());
        ode_step(world, scene_);
    }

private:
    void attach(dWorldID w) {
        world_ = w;
        impl_ = dThreadingAllocateMultiThreadedImplementation();
        pool_ = dThreadingAllocateThreadPool(static_cast<unsigned>(threads_), 0, dAllocateFlagBasicData, nullptr);
        dThreadingThreadPoolServeMultiThreadedImplementation(pool_, impl_);
        dWorldSetStepIslandsProcessingMaxThreadCount(w, static_cast<unsigned>(threads_));
        dWorldSetStepThreadingImplementation(w, dThreadingImplementationGetFunctions(impl_), impl_);
    }

    const Scene& scene_;
    int threads_;
    dWorldID world_ = nullptr;
    dThreadingImplementationID impl_ = nullptr;
    dThreadingThreadPoolID pool_ = nullptr;
};

}  // namespace

std::unique_ptr<SolverBackend> make_ode_solver(const Scene& scene, const std::string& why) {
    return std::make_unique<OdeSolver>(scene, why);
}

std::string contact_solver_unsupported(const Scene& scene) {
    if (!scene.joints.empty()) return "the scene has joints; the contact solver handles contact-only scenes";
    if (scene.solver.auto_disable) return "auto-disable needs ODE's islands";
    return "";
}

void add_reference_solvers(SolverRegistry& r) {
    r.add("ode", [](const Scene& s, Execution&) { return make_ode_solver(s, ""); }, {},
          "ODE's own stepper (dWorldQuickStep, or dWorldStep with solver.stepper = \"world\"): the reference");
    r.add("ode-threaded",
          [](const Scene& s, Execution& e) { return std::make_unique<OdeThreadedSolver>(s, e.threads()); }, {},
          "ODE's staged QuickStep on ODE's own thread pool (not reproducible with 2+ threads)");
    r.add("pgs",
          [](const Scene& s, Execution& e) -> std::unique_ptr<SolverBackend> {
              const std::string no = contact_solver_unsupported(s);
              if (!no.empty()) return make_ode_solver(s, "pgs not used: " + no);
              return std::make_unique<ContactSolver>(s, e);
          },
          {}, "parode's contact solver (cells, colours, warm start), serial");
    r.add("adaptive",
          [](const Scene& s, Execution& e) -> std::unique_ptr<SolverBackend> {
              const std::string no = contact_solver_unsupported(s);
              if (!no.empty()) return make_ode_solver(s, "adaptive not used: " + no);
              return std::make_unique<ContactSolver>(s, e, true);
          },
          {}, "pgs whose last sweeps take only the cells still changing by more than solver.tolerance, serial");
}

}  // namespace parode
