// Registration of the OpenMP backends (see register.hpp).
#include "register.hpp"

#include "collide.hpp"

namespace parode::omp {
void register_backends() {}
}  // namespace parode::omp
