// Threaded magnet gather (see magnet_pass.hpp).
#include "omp/forces/magnet_pass.hpp"

namespace parode::omp {

void MagnetPassOmp::gather_all(const MagnetField& field, std::vector<BodyWrench>& out) const {
    const long n = static_cast<long>(field.targets().size());
    const std::uint32_t* target = field.targets().data();
    const int t = exec_.threads_for(static_cast<std::size_t>(n), kMagnetCrossover);
#pragma omp parallel for schedule(dynamic, 128) num_threads(t) if (t > 1)
    for (long j = 0; j < n; ++j) out[static_cast<std::size_t>(j)] = field.gather(target[j]);
}

}  // namespace parode::omp
