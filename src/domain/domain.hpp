// Domain: how a run is spread over processes, the seam between the serial
// core and the distributed layer. The pipeline asks it which bodies to build,
// moves bodies and refreshes ghost copies through it (stages "migrate" and
// "exchange"), hands its CorrectionExchange to the contact solver, and
// reduces diagnostics, guard and checks through its collectives.
// This base class is the single-process domain: it owns every body, has no
// ghosts, exchanges nothing, and its collectives return their input. mpi/
// implements the distributed one on the same interface.
// Every collective must be called by every process in the same order; a
// reduction whose result the state depends on is exact (integer sums,
// ExactSum digits, maxima), never a floating-point sum in MPI's order.
// Trade-off: byte-vector gathers to one process are simple and general, and
// fine for what goes through them (trajectory frames, CSV snapshots, failure
// messages); bulk traffic of the step goes through the virtual stages, and
// H5MD snapshots through all_to_all (each process writes a block of ids).
#pragma once
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "scene/scene.hpp"
#include "util/exact_sum.hpp"

namespace parode {

class World;
struct WarmImpulse;
class CorrectionExchange;

// One file written by every process together: the root's head at 0, fixed-
// size records of bodies at records_at + gid * record (gids ascending), then
// every process's tail, in rank order, from tail_at.
struct FilePieces {
    std::vector<char> head;  // root only
    std::uint64_t records_at = 0;
    std::size_t record = 0;
    std::vector<std::uint32_t> gids;
    std::vector<char> records;
    std::uint64_t tail_at = 0;
    std::vector<char> tail;
};

class Domain {
public:
    virtual ~Domain() = default;
    virtual int rank() const { return 0; }
    virtual int ranks() const { return 1; }
    bool root() const { return rank() == 0; }
    bool distributed() const { return ranks() > 1; }

    // Decomposition. Throws SceneError naming the reason when `scene` cannot
    // run on this domain (collide/solver: the chosen backends).
    virtual void check_scene(const Scene& /*scene*/, const std::string& /*collide*/,
                             const std::string& /*solver*/) const {}
    // The global ids this process builds for a fresh run (collective where
    // distributed: the scene's cells are partitioned first, so each process
    // builds the bodies it will own).
    virtual std::vector<std::uint32_t> initial_bodies(const Scene& scene);
    // The global ids this process reads from a checkpoint: the positions are
    // in the file, so the partition comes after (setup).
    virtual std::vector<std::uint32_t> restart_bodies(const Scene& scene) const;
    // Once, after the World is built: assign cells, move bodies to their
    // owners, make ghosts.
    virtual void setup(World& /*world*/, std::vector<WarmImpulse>* /*warm*/) {}
    // Stage "migrate": bodies whose cell has another owner move there with
    // their warm-start impulses; repartition when the load is imbalanced.
    virtual void migrate(World& /*world*/, std::vector<WarmImpulse>* /*warm*/, long /*step*/) {}
    // Stage "exchange": ghosts take their owners' states, then their forces.
    virtual void exchange_states(World& /*world*/) {}
    virtual void exchange_forces(World& /*world*/) {}
    virtual CorrectionExchange* corrections() { return nullptr; }
    // Invariants (one owner per body, constant count, ghosts equal owners);
    // throws SimulationError naming bodies and ranks.
    virtual void check_invariants(const World& /*world*/, long /*step*/) {}
    // The run report's `parallel` block.
    virtual nlohmann::json report() const;
    // Why the stages run or not, for the run report.
    virtual std::string why() const { return "one process: nothing to exchange"; }

    // Collectives (in place; every process gets the result).
    virtual void sum(std::int64_t* v, int n) const;
    virtual void sum_wrapping(std::uint64_t* v, int n) const;  // modulo 2^64
    virtual void max(double* v, int n) const;
    // Collective: writes `pieces` of every process into one file (MPI-IO when
    // distributed). Throws std::runtime_error naming the file on failure.
    virtual void write_file(const std::string& path, const FilePieces& pieces) const;
    // Every process's bytes, in rank order: on every process (all) or on the
    // root only (others get an empty list).
    virtual std::vector<std::vector<char>> all_gather(const std::vector<char>& mine) const;
    virtual std::vector<std::vector<char>> gather(const std::vector<char>& mine) const;
    // out[r] goes to process r; returns what every process sent here, in rank order.
    virtual std::vector<std::vector<char>> all_to_all(const std::vector<std::vector<char>>& out) const;
    // Sets HDF5 property lists (hid_t values) so that every process opens and
    // writes one file together: `file_access` gets the MPI-IO driver and
    // `transfer` MPI-IO transfers when distributed; on one process both stay
    // as they are (HDF5's POSIX driver, which needs no MPI).
    virtual void h5_parallel(std::int64_t /*file_access*/, std::int64_t /*transfer*/) const {}

    // Built on the collectives above.
    void sum(ExactSum* s, int n) const;
    double max(double v) const;
    double min(double v) const;
    std::int64_t sum(std::int64_t v) const;
    // Every process's text joined in rank order (empty parts skipped).
    std::string all_text(const std::string& mine, const std::string& separator) const;
};

}  // namespace parode
