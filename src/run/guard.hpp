// The run guard: stops a run at once, with an error naming the step and the
// bodies, when a body's state becomes non-finite (checked every step), a body
// exceeds [guard] max_speed (every step), or the total energy grows past a
// bound (every observed step). When asked, the last observed state that passed
// every check is written out (CSV, full precision) before the run stops.
// The automatic energy bound is what the scene can legitimately add to its
// energy: the initial kinetic energy, the potential energy above the lowest
// body, the energy of lifting every body by 1 m, the binding energy of the
// magnets (their potential is not in the reported energy), and the controller's
// motors at full power for the elapsed time.
// Trade-off: the finite check costs one pass over the bodies per step (small
// next to collision); keeping the last good state costs a copy of every body's
// state per observed step, so it is made only when a dump file is requested.
#pragma once
#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "run/diagnostics.hpp"
#include "world/world.hpp"

namespace parode {

class Guard {
public:
    Guard(const World& world, const Diagnostics& initial, std::string dump_path);
    // Every step: non-finite state and the speed bound. Throws SimulationError.
    void check_step(const World& world, long step) const;
    // Observed steps: the energy bound; a passing state becomes the last good one.
    void check_observed(const World& world, const Diagnostics& d, long step);
    // Allowed growth of the total energy (J) after `time` seconds.
    double energy_bound(double time) const;
    nlohmann::json describe() const;

private:
    struct State {
        long step = 0;
        std::vector<double> data;  // 13 per body: x, q, v, w
    };
    [[noreturn]] void fail(const World& world, long step, const std::string& what) const;
    void remember(const World& world, long step);
    std::string dump() const;

    const Scene& scene_;
    double initial_energy_ = 0;
    double base_bound_ = 0;    // J
    double motor_power_ = 0;   // W
    std::string dump_path_;
    State good_;
};

// Ids of the `limit` bodies with the largest speed, "id (speed m/s)" joined.
std::string fastest_bodies(const World& world, std::size_t limit);

}  // namespace parode
