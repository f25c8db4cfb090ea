// Scene queries (see scene.hpp).
#include "scene/scene.hpp"

namespace parode {

std::size_t Scene::catom_count() const {
    std::size_t n = 0;
    for (const auto& b : bodies) n += b.catom ? 1 : 0;
    return n;
}

bool Scene::any_magnets() const {
    if (!magnets.enabled || magnets.strength == 0) return false;
    for (const auto& b : bodies) if (b.magnets) return true;
    return false;
}

int Scene::find_body(const std::string& n) const {
    for (std::size_t i = 0; i < bodies.size(); ++i) if (!n.empty() && bodies[i].name == n) return static_cast<int>(i);
    return -1;
}

bool CheckSpec::any() const {
    return max_penetration || max_final_penetration || max_energy_gain || max_displacement || max_final_speed || min_disabled ||
           max_escaped || !positions.empty();
}

int Scene::find_joint(const std::string& n) const {
    for (std::size_t i = 0; i < joints.size(); ++i) if (joints[i].name == n) return static_cast<int>(i);
    return -1;
}

}  // namespace parode
