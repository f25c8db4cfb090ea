// Pass criteria of a run, from the scene's [checks] table: penetration and
// energy growth over the observed steps; displacement, final speed, sleeping
// bodies, escaped catoms at the end; body positions at the end or always. The result goes into
// the run report under `checks`; `parode run` exits 5 when one fails.
// Trade-off: criteria are evaluated on observed steps only (every
// observe_every), so a transient between two observations is not seen; the
// guard's per-step finite check still catches any NaN.
#pragma once
#include <nlohmann/json.hpp>

#include "io/trajectory.hpp"

namespace parode {

class Checker {
public:
    Checker(const World& world, const Diagnostics& initial);
    void observe(const World& world, const Diagnostics& d);
    // {passed, items: [{name, value, bound, passed}]} for the state of `world` now.
    nlohmann::json result(const World& world, const Diagnostics& last) const;

private:
    const Scene& scene_;
    Trajectory start_;  // the initial frame, for displacement and footprint
    double initial_energy_ = 0;
    double max_penetration_ = 0;
    double max_energy_gain_ = 0;
    std::vector<Vec3> extremes_;  // per position check: {lowest, highest} seen when `always`
};

}  // namespace parode
