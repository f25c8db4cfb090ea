// Solver backends and their registry (see solver.hpp).
#include "solver.hpp"

#include "contact_solver.hpp"

namespace parode {
namespace {

class OdeSolver final : public SolverBackend {
public:
    OdeSolver(const Scene& scene, std::string why) : scene_(scene), why_(std::move(why)) {}
    std::string name() const override {
        return scene_.solver.stepper == Stepper::Quick ? "ode-quickstep" : "ode-worldstep";
    }
    std::string why() const override { return why_.empty() ? name() : name() + ": " + why_; }
    bool uses_contact_joints() const override { return true; }
    void step(World& world, const ContactBuffer& /*contacts*/) override {
        if (scene_.solver.stepper == Stepper::Quick) dWorldQuickStep(world.id(), scene_.dt);
        else dWorldStep(world.id(), scene_.dt);
    }

private:
    const Scene& scene_;
    std::string why_;
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

SolverRegistry::SolverRegistry() : Registry("solver") {
    add("ode", [](const Scene& s) { return make_ode_solver(s, ""); });
    add("pgs", [](const Scene& s) -> std::unique_ptr<SolverBackend> {
        const std::string no = contact_solver_unsupported(s);
        if (!no.empty()) return make_ode_solver(s, "pgs not used: " + no);
        return std::make_unique<ContactSolver>(s);
    });
}

SolverRegistry& SolverRegistry::instance() {
    static SolverRegistry registry;
    return registry;
}

}  // namespace parode
