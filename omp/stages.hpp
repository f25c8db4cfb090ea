// Adds the OpenMP stage implementations to the stage registry
// (run/stages.hpp): the "grid" and "grid-nolist" collide backends, the
// threaded contact solver "parallel" (also "pgs/omp"), the threaded magnet
// gather "magnets/omp" and the core's loop runner "loops/omp".
// Trade-off: explicit registration (called from main, or by a program
// linking parode) instead of static initialisers, which a static library's
// linker would silently drop.
#pragma once
#include "omp/runtime/loop_runner.hpp"  // default_threads
#include "run/stages.hpp"

namespace parode::omp {
// Adds the OpenMP implementations to `stages` (idempotent).
void add_stages(Stages& stages = Stages::instance());
}  // namespace parode::omp
