// The single-process decomposition (see decomposition.hpp).
#include "domain/decomposition.hpp"

#include <numeric>

namespace parode {

std::vector<std::uint32_t> Decomposition::block(const Scene& scene) const {
    std::vector<std::uint32_t> ids(scene.body_count());
    std::iota(ids.begin(), ids.end(), 0u);
    return ids;
}

std::vector<std::uint32_t> Decomposition::initial_bodies(const Scene& /*scene*/, const std::vector<std::uint32_t>& block,
                                                         const std::vector<Vec3>& /*positions*/) {
    return block;
}

std::vector<std::uint32_t> Decomposition::initial_bodies(const Scene& scene) {
    const std::vector<std::uint32_t> ids = block(scene);
    std::vector<Vec3> at(ids.size());
    for (std::size_t k = 0; k < ids.size(); ++k) at[k] = scene.body(ids[k]).position;
    return initial_bodies(scene, ids, at);
}

nlohmann::json Decomposition::report() const {
    return {{"ranks", 1}, {"imbalance", 1.0}, {"edge_cut", 0}, {"ghost_fraction", 0.0}, {"migrations", 0},
            {"repartitions", 0}, {"comm_seconds", 0.0}, {"comm_bytes", 0}, {"messages_per_step", 0.0},
            {"setup_comm_seconds", 0.0}, {"setup_comm_bytes", 0}};
}

}  // namespace parode
