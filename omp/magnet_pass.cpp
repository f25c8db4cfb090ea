// Parallel magnet force pass: the per-body gather of MagnetField (src/magnets)
// over OpenMP threads with dynamic scheduling. Each body's wrench is computed by
// one thread in the serial order of its neighbours, so the result is bit for bit
// the serial one for any thread count; applying the wrenches stays serial, in id
// order (dBodyAddForce is safe only on distinct bodies, and order fixes the sums).
// Trade-off: pole positions and the cell sort are still prepared serially.
#include "magnet_pass.hpp"

#include "forces/magnets.hpp"
#include "register.hpp"

namespace parode::omp {

void gather_magnets_parallel(const MagnetField& field, std::vector<BodyWrench>& out) {
    const long n = static_cast<long>(field.targets().size());
    const std::uint32_t* target = field.targets().data();
#pragma omp parallel for schedule(dynamic, 128) if (n >= min_parallel(1024))
    for (long j = 0; j < n; ++j) out[static_cast<std::size_t>(j)] = field.gather(target[j]);
}

}  // namespace parode::omp
