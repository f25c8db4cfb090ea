// The run guard: stops a run at once, with an error naming the step and the
// bodies, when a body's state becomes non-finite (checked every step), a body
// exceeds [guard] max_speed (every step), or the total energy is not finite or
// grows past a bound (every observed step). When asked, the last observed
// state that passed every check is written out (CSV, full precision, bodies in
// global-id order) before the run stops.
// The automatic energy bound is what the scene can legitimately add to its
// energy: the initial kinetic energy, the potential energy above the lowest
// body (along gravity), the energy of lifting every body by 1 m, the binding
// energy of the magnets (their potential is not in the reported energy), and
// the controller's motors at full power for the elapsed time.
// Collective: every check is decided on counts and diagnostics reduced over
// all processes, so every process stops at the same step with the same
// message (the root prints it), and none waits for a process that stopped.
// Trade-off: the per-step checks cost one pass over the owned bodies and,
// with several processes, one small reduction per step; keeping the last good
// state costs a copy of every owned body's state per observed step, so it is
// made only when a dump file is requested.
#pragma once
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "domain/collectives.hpp"
#include "exec/loops.hpp"
#include "observe/diagnostics.hpp"
#include "world/world.hpp"

namespace parode {

class Guard {
public:
    // `loops`: where the step's scan runs (the pipeline's execution context).
    Guard(const World& world, const Diagnostics& initial, const Collectives& domain, const LoopRunner& loops,
          std::string dump_path);
    // Every step: non-finite state and the speed bound. Throws SimulationError.
    // `known_finite`: the solver wrote every owned body's state and checked it
    // finite as it did (the scan is then needed only for the speed bound);
    // known_max_speed >= 0: the largest speed it wrote (no scan when that is
    // within the bound).
    void check_step(const World& world, long step, bool known_finite = false, double known_max_speed = -1.0) const;
    // Observed steps: the energy bound; a passing state becomes the last good one.
    void check_observed(const World& world, const Diagnostics& d, long step);
    // Allowed growth of the total energy (J) after `time` seconds.
    double energy_bound(double time) const;
    nlohmann::json describe() const;
    // What a restarted run must carry on with: the initial energy and bounds.
    nlohmann::json state() const;
    void restore(const nlohmann::json& state);

private:
    struct State {
        long step = 0;
        std::vector<double> rows;  // per owned body: gid, then x, q, v, w
    };
    [[noreturn]] void fail(const World& world, long step, const std::string& what) const;
    void remember(const World& world, long step);
    std::string dump() const;

    const Scene& scene_;
    const Collectives& domain_;
    const LoopRunner& loops_;
    double initial_energy_ = 0;
    double base_bound_ = 0;    // J
    double motor_power_ = 0;   // W
    std::string dump_path_;
    State good_;
};

// Collective: the `limit` fastest bodies of all processes whose speed is
// above `above` (m/s; negative: any), "gid (speed m/s)" joined.
std::string fastest_bodies(const World& world, const Collectives& domain, std::size_t limit, double above = -1.0);

}  // namespace parode
