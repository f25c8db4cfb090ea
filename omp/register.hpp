// Registers the OpenMP stage implementations with the core's registries and
// sets the thread count of every OpenMP stage.
// Trade-off: explicit registration (called from main) instead of static
// initialisers, which a static library's linker would silently drop.
#pragma once

namespace parode::omp {
// Adds the "grid" collide backend and the "parallel" solver, and installs the
// parallel magnet gather.
void register_backends();
// Threads for all OpenMP stages (omp_set_num_threads); <= 0 leaves the default.
void set_threads(int threads);
// Threads the OpenMP stages will use (1 in a build without OpenMP).
int max_threads();
// Smallest loop (bodies, contacts) that runs in parallel; -1 restores the
// defaults. Results never depend on it; tests set 0 to force parallel paths.
void set_min_parallel(long items);
long min_parallel(long default_items);
}  // namespace parode::omp
