// Peak memory of a run, estimated from the scene before anything is built, and
// the memory the machine can give; the command line refuses a run whose
// estimate exceeds what is available instead of ending in std::bad_alloc or
// the kernel's out-of-memory killer hours later.
// Trade-off: a linear model with constants measured on the catom prism (peak
// RSS, see memory_estimate.cpp), not an account of every allocation: it errs
// on the high side by about 20 % for piles, and under-counts scenes whose
// bodies touch far more neighbours than a prism's.
#pragma once
#include <cstddef>
#include <stdexcept>
#include <string>

#include "scene/scene.hpp"
#include "scene/scene_file.hpp"
#include "util/errors.hpp"

namespace parode {

// What a run's memory grows with.
struct SceneSize {
    double bodies = 0;    // dynamic bodies, catoms included
    double magnet_catoms = 0;  // catoms whose magnets act (the magnet pass keeps data for them)
    double geoms = 0;     // geoms in the collision space: bodies, statics, planes
    double contacts = 0;  // expected contacts at the peak
    double program_catoms = 0;  // catoms that run a program (its record and the pass's lists)
};

// How the scene is run.
struct RunShape {
    std::string collide = "ode-hash";  // ODE's hash space needs geoms^2 / 8 bytes
    long steps = 0;
    long observe_every = 10;
    bool record_trajectory = false;  // one frame per observed step
    bool dump_on_failure = false;    // the guard keeps a copy of every body's state
    int pipelines = 1;               // bench: one world per variant
};

struct MemoryEstimate {
    double bytes = 0;           // whole run, all ranks
    double bytes_per_rank = 0;
    int ranks = 1;
    std::string detail;         // "1e+08 bodies x 5.4 kB, ..." for messages
};

// Size of a loaded scene, or of one whose [catoms] prism is not generated yet.
SceneSize scene_size(const Scene& scene);
SceneSize scene_size(const Scene& so_far, const CatomPlan& catoms);

// Pure functions of their inputs. `ranks` splits the bodies evenly; each rank
// pays the fixed cost.
MemoryEstimate estimate_memory(const SceneSize& size, const RunShape& run, int ranks = 1);
MemoryEstimate estimate_memory(const Scene& scene, const RunShape& run, int ranks = 1);

struct MemoryAvailable {
    double bytes = 0;
    std::string source;  // "MemAvailable", "cgroup memory.max", "ulimit -v"
};

// The least of /proc/meminfo MemAvailable, the cgroup's limit less its usage,
// and the address-space limit (ulimit -v) less what the process already maps.
MemoryAvailable available_memory();

// Throws MemoryError, with the estimate and what the machine has, when the
// estimate exceeds what is available.
void require_memory(const MemoryEstimate& need, const MemoryAvailable& have);

// "1.06 GB", "48.8 MB" (decimal units).
std::string format_bytes(double bytes);

}  // namespace parode
