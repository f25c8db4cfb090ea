// Diagnostics of a world state: energies, momenta, penetration, NaN count and
// the state hash. Sums over bodies and contacts are exact (ExactSum) and
// reduced over processes through the Collectives, so every diagnostic is the same
// bits for any number of threads and processes.
// The state hash: each body's FNV-1a 64 digest over its global id, position,
// quaternion, linear and angular velocity (bit for bit), the digests summed
// modulo 2^64 and mixed. A sum needs no order, so owned bodies are hashed
// where they live and the per-process sums combine into the hash of the
// whole state; the id in each digest ties every state to its body.
// Trade-off: computed only on observed steps (every `observe_every`), since a
// full pass over the bodies costs about as much as a force pass; exact sums
// cost a few nanoseconds more per value than plain additions.
#pragma once
#include <cstdint>

#include "collide/contacts.hpp"
#include "domain/collectives.hpp"
#include "exec/loops.hpp"
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

// Unit vector against gravity (z when there is no gravity).
Vec3 up_direction(const Scene& scene);
bool finite_state(dBodyID b);
// Digest of one body (its gid and state), the term of the state hash.
std::uint64_t body_digest(const World& world, std::size_t local);
// Collective: diagnostics of the owned bodies and contacts of every process.
// Its loops run on `loops` (the pipeline's execution context).
Diagnostics observe(const World& world, const ContactBuffer& contacts, const Collectives& domain,
                    const LoopRunner& loops);
// Gids of owned bodies whose state is not finite (at most `limit`).
std::vector<std::uint32_t> nan_bodies(const World& world, std::size_t limit);

}  // namespace parode
