// Pass criteria of a run, from the scene's [checks] table: penetration and
// energy growth over the observed steps; displacement, final speed, sleeping
// bodies, escaped catoms at the end; body positions at the end or always. The
// result goes into the run report under `checks`; `parode run` exits 5 when
// one fails.
// Collective: the states the criteria need are gathered on the root in
// global-id order (the checked bodies on observed steps, every body's position
// once at the end), the root decides, and every process gets its verdict, so
// the verdict does not depend on the number of processes.
// Trade-off: criteria are evaluated on observed steps only (every
// observe_every), so a transient between two observations is not seen; the
// guard's per-step finite check still catches any NaN. The end-of-run gather
// holds every position on the root once (24 bytes a body).
#pragma once
#include <nlohmann/json.hpp>

#include "domain/collectives.hpp"
#include "io/trajectory.hpp"

namespace parode {

class Checker {
public:
    Checker(const World& world, const Diagnostics& initial, const Collectives& domain);
    void observe(const World& world, const Diagnostics& d);
    // {passed, items: [{name, value, bound, passed}]} for the state of `world` now.
    nlohmann::json result(const World& world, const Diagnostics& last) const;
    // What a restarted run must carry on with (the root's; collective restore).
    nlohmann::json state() const;
    void restore(const nlohmann::json& state);

private:
    const Scene& scene_;
    const Collectives& domain_;
    Trajectory start_;  // root: the initial frame, for displacement and footprint
    std::vector<std::uint32_t> checked_;  // gids of the position checks, sorted
    double initial_energy_ = 0;
    double max_penetration_ = 0;
    double max_energy_gain_ = 0;
    std::vector<Vec3> extremes_;  // per position check: {lowest, highest} seen when `always`
};

}  // namespace parode
