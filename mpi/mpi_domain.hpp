// The distributed domain: every process owns the bodies whose centres lie in
// its cells of the global cell grid (domain/cells.hpp) and holds ghost
// copies of the bodies around its own cells that its bodies can reach (a
// contact, a magnet or a program's message away: the halo). Cells, not bodies, are
// partitioned (METIS, partition.hpp), and the contact solver's per-colour
// exchange (CorrectionExchange) keeps every copy of a body in step, so a run
// on any number of processes gives the state of a one-process run, bit for
// bit.
// Per step: migrate (bodies whose cell has another owner move there with
// their warm-start impulses; repartition first when the load is imbalanced)
// -> exchange ghost states (owners send each body to the other holders of
// its cell, receivers add, update and drop ghosts) -> forces on owned
// bodies, then ghosts take their owners' forces -> contacts whose lower-id
// body is owned -> solve, with the corrections of shared bodies sent after
// every colour of every sweep to the processes holding copies.
// Trade-off: one message per neighbour per colour per sweep (about 170 a
// step at 20 iterations) is latency-bound; the partition decides how many
// neighbours there are, never the result.
#pragma once
#include <array>
#include <map>
#include <vector>

#include "cell_map.hpp"
#include "comm.hpp"
#include "partition.hpp"
#include "domain/cells.hpp"
#include "domain/decomposition.hpp"
#include "exec/execution.hpp"
#include "solve/contact_solver.hpp"
#include "world/world.hpp"

namespace parode::mpi {

// The collectives of a run on MPI_COMM_WORLD, through Comm.
class MpiCollectives final : public Collectives {
public:
    explicit MpiCollectives(const Comm& comm) : comm_(comm) {}
    int rank() const override { return comm_.rank(); }
    int ranks() const override { return comm_.size(); }
    void sum(std::int64_t* v, int n) const override { comm_.sum(v, n); }
    void sum_wrapping(std::uint64_t* v, int n) const override { comm_.sum_wrapping(v, n); }
    void max(double* v, int n) const override { comm_.max(v, n); }
    std::vector<std::vector<char>> all_gather(const std::vector<char>& mine) const override { return comm_.all_gather(mine); }
    std::vector<std::vector<char>> gather(const std::vector<char>& mine) const override { return comm_.gather(mine, 0); }
    std::vector<std::vector<char>> all_to_all(const std::vector<std::vector<char>>& out) const override {
        return comm_.all_to_all(out);
    }
    std::vector<char> all_to_all(std::vector<char> flat, const std::vector<std::size_t>& counts) const override {
        return comm_.all_to_all(std::move(flat), counts);
    }
    std::vector<std::vector<char>> sparse_to(const std::vector<std::vector<char>>& out, int channel) const override;
    void h5_parallel(std::int64_t file_access, std::int64_t transfer) const override {
        comm_.h5_parallel(file_access, transfer);
    }
    void write_file(const std::string& path, const FilePieces& f) const override {
        comm_.write_file(path, f);
    }
    using Collectives::max;
    using Collectives::sum;

private:
    const Comm& comm_;
};

// The "mpi" decomposition of the stage registry (mpi/stages.hpp).
class MpiDomain final : public Decomposition, public CorrectionExchange {
public:
    // On MPI_COMM_WORLD; its loops on `exec`'s runner, the ghost exchange's
    // messages in `exec`'s scratch pool (both must outlive it).
    MpiDomain(const Scene& scene, Execution& exec);
    MpiDomain(Scene&&, Execution&) = delete;  // keeps a reference to the scene

    const Collectives& collectives() const override { return collectives_; }
    void check_scene(const Scene& scene, const std::string& collide, const std::string& solver) const override;
    std::vector<std::uint32_t> block(const Scene& scene) const override;
    std::vector<std::uint32_t> initial_bodies(const Scene& scene, const std::vector<std::uint32_t>& block,
                                              const std::vector<Vec3>& positions) override;
    using Decomposition::initial_bodies;
    void setup(World& world, std::vector<WarmImpulse>* warm) override;
    void migrate(World& world, std::vector<WarmImpulse>* warm, long step) override;
    void exchange_states(World& world) override;
    void exchange_forces(World& world) override;
    CorrectionExchange* corrections() override { return this; }
    void check_invariants(const World& world, long step) override;
    nlohmann::json report() const override;
    std::string why() const override;

    bool shared(std::uint32_t local) const override;
    void plan(const std::vector<std::vector<std::uint32_t>>& touched) override;
    void post(int colour, const CorrectionView& fc) override;
    void complete(int colour, const CorrectionView& fc) override;
    bool any(bool mine) override;
    // The next message of every colour names its bodies again, as after
    // plan() (for tests: a process that disagrees with its neighbours).
    void restart_names() { corr_named_.assign(corr_named_.size(), 0); }
    // Bytes this process sent in the solver's exchange after each colour.
    const std::array<std::uint64_t, 8>& colour_bytes() const { return colour_bytes_; }

    // For tests: the cell map of the last partition and what moved.
    const CellMap& cell_map() const { return map_; }
    const std::vector<int>& partners() const { return nbrs_; }  // of the solver's exchange, ascending
    long migrations() const { return migrations_; }
    long repartitions() const { return repartitions_; }

private:
    // Message tags, one per kind of exchange.
    enum Tag { kTagMigrate = 11, kTagGhost = 12, kTagForce = 13, kTagCorrection = 14, kTagCheck = 15, kTagInterest = 16 };
    void exchange_interest(const std::vector<std::vector<std::uint32_t>>& touched);
    std::uint8_t next_mark();
    void repartition(const World& world, const std::vector<WarmImpulse>* warm);
    void partition(std::vector<CellLoad> mine);
    void cut_together(const std::vector<CellLoad>& cells);
    void gather_and_cut(const std::vector<CellLoad>& cells, std::int64_t occupied);
    void move_bodies(World& world, std::vector<WarmImpulse>* warm);
    void receive_bodies(World& world, std::vector<WarmImpulse>* warm, const std::vector<std::pair<int, Bytes>>& in);
    void index_bodies(World& world);
    const DomainSlot& place(World& world, std::size_t i) const;
    void locate_all(World& world);
    // Whether this step's locate_all found the entry current.
    bool located(const DomainSlot& s) const { return s.stamp == stamp_ && s.stamp != 0 && s.epoch == epoch_; }
    // Per chunk of bodies, their locals in body order (chunk by chunk).
    std::vector<std::vector<std::uint32_t>> outgoing(const World& world) const;
    // A new stamp (never 0): the entries of the last pass stop being located.
    void next_stamp() {
        if (++stamp_ == 0) stamp_ = 1;
    }
    // Stops the run: neighbour j's correction message is not the size expected.
    [[noreturn]] void bad_message(std::size_t j, std::size_t got, std::size_t expected, bool more = false) const;
    static const std::vector<int>& holders(const DomainSlot& s) { return *s.holders; }
    double load_imbalance(const World& world, const std::vector<WarmImpulse>* warm) const;
    std::int64_t ghost_mismatches(const World& world, std::string& detail) const;

    const Scene& scene_;
    const LoopRunner& loops_;
    ScratchPool* scratch_;
    Comm comm_;
    MpiCollectives collectives_{comm_};
    CellSpace cells_;
    double reach_;  // how far a body's partners lie from its centre (halo_reach)
    CellMap map_;
    World* world_ = nullptr;
    std::uint32_t epoch_ = 0;                      // partitions made so far
    std::uint32_t stamp_ = 0;                      // locate_all passes made so far
    std::vector<std::uint8_t> moved_;              // locate_all: bodies that changed cell or leave
    std::vector<int> send_to_, recv_from_;         // ghost partners of this step
    std::vector<std::vector<std::uint32_t>> send_locals_, recv_locals_;
    std::size_t in_bytes_ = 0;                     // what the last ghost exchange received
    std::vector<int> nbrs_;                        // partners of the solver's exchange
    std::vector<int> nbr_index_;                   // rank -> index into nbrs_, or -1
    std::vector<std::vector<std::vector<std::uint32_t>>> corr_;  // colour -> neighbour -> locals
    // The solve's exchange: per colour, whether this step's lists were sent
    // (the first message of a colour carries the ids, the rest only the
    // corrections), and what each neighbour sends, as locals here.
    std::vector<std::uint8_t> corr_named_;
    std::vector<std::vector<std::vector<std::uint32_t>>> corr_in_;  // colour -> neighbour -> locals
    std::vector<Bytes> corr_out_, corr_recv_;  // message buffers, kept for their capacity
    std::vector<std::size_t> expect_;           // the posted receives' sizes
    std::vector<Bytes> interest_in_;            // per neighbour: the gids it touches this step
    std::vector<std::uint8_t> mark_;            // per local body: the token of the pass that marked it
    std::uint8_t mark_token_ = 0;               // a byte: cleared every 255 passes, 1 byte a body
    PendingExchange pending_;                   // the colour posted and not yet completed
    bool posted_named_ = false;                 // its messages carry the ids
    std::array<std::uint64_t, 8> colour_bytes_{};
    std::uint64_t id_hash_ = 0;                    // sum of mixed gids of every body
    bool partitioned_ = false;                     // initial_bodies partitioned the scene's cells
    long conflicts_ = 0;                           // ghosts received for bodies owned here
    long migrations_ = 0, repartitions_ = 0, steps_ = 0;
    CommStats setup_stats_;                        // what setup cost: the stats when the first step began
    std::int64_t edge_cut_ = 0;
    double partition_imbalance_ = 1.0, partition_colour_imbalance_ = 1.0, imbalance_ = 1.0;
    bool bisection_ = false;  // the last partition was the bisection's
    bool together_ = false;   // ... made by every process together (its tree)
    std::int64_t tree_nodes_ = 0;
    double partition_seconds_ = 0;  // in partition(), setup and repartitions
};

}  // namespace parode::mpi
