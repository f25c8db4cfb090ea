// The solve stage's interface: a SolverBackend advances the world by one step
// given the step's contacts in canonical order. "ode" runs ODE's own stepper
// (dWorldQuickStep or dWorldStep, from the scene) on contact joints made by the
// joints stage; "pgs" (serial, src/) and "parallel" (OpenMP, omp/) run the
// project's contact solver and leave ODE only the integration.
// Trade-off: the project solver handles contact-only scenes (no scene joints,
// no auto-disable); other scenes stay on ODE's stepper and the report says why.
#pragma once
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "contacts.hpp"
#include "registry.hpp"
#include "world.hpp"

namespace parode {

class SolverBackend {
public:
    virtual ~SolverBackend() = default;
    virtual std::string name() const = 0;
    // Why this backend runs (e.g. a fallback to ODE's stepper).
    virtual std::string why() const { return name(); }
    // True if the joints stage must turn contacts into ODE contact joints.
    virtual bool uses_contact_joints() const = 0;
    virtual void step(World& world, const ContactBuffer& contacts) = 0;
};

class SolverRegistry : public Registry<SolverBackend, const Scene&> {
public:
    static SolverRegistry& instance();

private:
    SolverRegistry();
};

// Empty when the project's contact solver can run `scene`, else the reason not.
std::string contact_solver_unsupported(const Scene& scene);
// ODE's stepper, with `why` recorded (used for fallbacks).
std::unique_ptr<SolverBackend> make_ode_solver(const Scene& scene, const std::string& why);

}  // namespace parode
