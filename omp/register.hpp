// Registers the OpenMP stage implementations with the core's registries.
// Trade-off: explicit registration (called from main) instead of static
// initialisers, which a static library's linker would silently drop.
#pragma once

namespace parode::omp {
void register_backends();
}
