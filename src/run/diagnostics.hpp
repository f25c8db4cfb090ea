// Diagnostics of a world state: energies, momenta, penetration, NaN count and
// the state hash (FNV-1a over position, quaternion, linear and angular velocity
// of every body, in global-id order, bit for bit).
// Trade-off: computed only on observed steps (every `observe_every`), since a
// full pass over the bodies costs about as much as a force pass.
#pragma once
#include <cstdint>

#include "collide/contacts.hpp"
#include "world/world.hpp"

namespace parode {

struct Diagnostics {
    double kinetic = 0;
    double potential = 0;  // gravity only
    Vec3 momentum{0, 0, 0};
    Vec3 angular_momentum{0, 0, 0};  // about the origin
    double com_height = 0;           // along -gravity
    double max_penetration = 0;      // over the contacts of the observed step
    double mean_penetration = 0;
    std::size_t contacts = 0;
    std::size_t nan_count = 0;       // bodies with a non-finite state
    std::size_t disabled = 0;        // sleeping bodies
    std::uint64_t state_hash = 0;
    double energy() const { return kinetic + potential; }
};

std::uint64_t state_hash(const World& world);
Diagnostics observe(const World& world, const ContactBuffer& contacts);
// Ids of bodies whose state is not finite (at most `limit`).
std::vector<std::size_t> nan_bodies(const World& world, std::size_t limit);

}  // namespace parode
