// The catom programs' pass, the first of the forces stage: each step it finds
// every owned catom's neighbours (centres within the two radii plus the
// reach, among the catoms this process holds, ghosts included), runs each
// owned catom's handlers — start (first step), neighbours lost, then gained
// (by id), the messages sent to it the step before (by sender id, then
// sending order), its timer — on the run's threads, one catom per call, and
// then switches the magnets the programs asked for (the magnets pass that
// follows sees them) and files the messages sent for delivery next step.
// Every owned catom's values, magnets, timer, pending messages and program
// bytes go into the state hash (a sum modulo 2^64 over the processes).
// On several processes (program_state.cpp): a catom's program state lives
// with the process that owns the catom and travels with it when it migrates
// (to the new owner, or to every process when this one no longer holds a
// copy); messages go to the receiver's owner, magnet switches to every
// process (each keeps the switches of all catoms, so a ghost that arrives
// anywhere carries the right magnets), errors to every process; each of the
// two exchanges of a step is a sparse exchange (only to the processes that get
// something). The order of everything a catom
// sees is by global id, so every thread and process count gives the same bits.
// Errors (a handler's exception, a message to a non-neighbour, a sender past
// its budget) end the run with a ProgramError naming the lowest such catom,
// its event and the message, on every process.
// Its whole state goes into checkpoints (state_piece / load_state), in one
// format for any number of processes.
// Trade-off: a catom's record (its program object, mail, values, digest)
// lives only on the process that owns it, made when it first owns it and
// dropped when it sends it on, found by gid (util/gid_table.hpp); everything else
// the pass keeps is per catom held here (owned or ghost), never per catom of
// the scene, so a rank's memory follows what it holds (gid lookups go
// through the world's id map, and lists of the owned catoms are matched by
// merging sorted gids, against the dense tables over every catom this once
// kept); neighbours tested each step among candidates listed with a skin
// (listed again from a cell list, O(N), when a catom moved half the skin),
// kept as gids, and handed to a handler with their directions only when it
// asks; only catoms with an event run. Checkpoints hold every catom's record
// (the whole scene's state, gathered only when written or read).
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "domain/collectives.hpp"
#include "exec/execution.hpp"
#include "forces/force_pass.hpp"
#include "programs/program.hpp"
#include "util/byte_source.hpp"
#include "util/gid_table.hpp"
#include "util/id_map.hpp"
#include "util/substages.hpp"

namespace parode {

struct ProgramCounts {
    std::uint64_t steps = 0, messages = 0, events = 0;  // messages and events: this process's (totals(): all)
    double seconds = 0;                                  // this process's
    std::uint64_t lists = 0;                             // this process's listings of candidate neighbours
    // This process's seconds in each part of the pass: locate, transfer (the
    // migrants' records, a collective), neighbours, handlers, mail (a
    // collective: it also waits for the slowest process), digest.
    Substages parts;
};

class ProgramPass final : public ForcePass {
public:
    ProgramPass(const Scene& scene, Execution& exec);
    ~ProgramPass() override;
    ProgramPass(Scene&&, Execution&) = delete;  // keeps a reference to the scene
    std::string name() const override { return "program:" + spec_->name; }
    // The run's processes (default: this one alone); kept by reference.
    void set_collectives(const Collectives& c) { coll_ = &c; }
    void apply(World& world, double time) override;
    // Before the first step, once the world holds its bodies: the records
    // of the catoms owned here (else the first step makes them).
    void prepare(const World& world);
    // The counts with every process's messages and events (collective when
    // distributed: summed only when asked, not every step).
    ProgramCounts totals() const;
    // Everything the next step depends on (each catom's values, magnets,
    // timer, pending messages, program bytes and last neighbours; the step
    // and counts), for checkpoints, in one format for any number of
    // processes, in pieces of kStatePiece catoms (io/checkpoint.hpp
    // SectionSource): made on the last process (the checkpoint's writer) and
    // on one; the other processes get nothing, and send it only their own
    // catoms' records (collective when distributed). load_state takes it
    // back, read window by window from the checkpoint (and sets the world's
    // magnet switches and values). Throws CheckpointError if it does not fit
    // this scene. Called once the world holds what this process owns (after
    // the domain's set-up): it keeps only their records.
    static constexpr std::size_t kStatePiece = 8192;
    std::size_t state_pieces() const;
    void state_piece(std::size_t k, std::vector<char>& out) const;
    void load_state(World& world, ByteSource& state);
    const ProgramSpec& spec() const { return *spec_; }
    // The scene's catoms: their number, their gids in order, and value k of
    // every catom (after the last step; collective when distributed).
    std::size_t catom_count() const { return numbering_.count(); }
    std::vector<std::uint32_t> catom_ids() const;
    std::vector<double> values_of(int k) const;

    struct Catom;  // per catom: program, mail, values (catom_state.hpp)

private:
    // The scene's catoms numbered in gid order (the checkpoint's order):
    // [[bodies]] catoms first, then the generated ones (all catoms).
    class Numbering {
    public:
        explicit Numbering(const Scene& scene);
        std::size_t count() const { return listed_.size() + generated_; }
        std::uint32_t gid(std::size_t k) const;
        std::size_t index(std::uint32_t gid) const;

    private:
        std::vector<std::uint32_t> listed_;  // the [[bodies]] catoms' gids
        std::size_t first_generated_ = 0, generated_ = 0;
    };
    // Neighbour lists of some catoms (keys: gids, ascending): key j's are
    // ids[at[j] .. at[j + 1]) (gids, ascending).
    struct Csr {
        std::vector<std::uint32_t> keys, at, ids;
        // Key g's place, or IdMap::kNone.
        std::uint32_t place(std::uint32_t g) const;
    };

    static std::vector<std::uint32_t> sorted_places(const std::vector<std::uint32_t>& keys,
                                                    const std::vector<std::uint32_t>& in);
    void locate(const World& world);
    bool owned_here(const World& world, std::uint32_t g) const;
    Catom* record(std::uint32_t g) const;
    void ensure_records(std::size_t expected);
    void mark_dirty(std::uint32_t g);
    void bind_owned();
    void transfer(World& world);
    void update_candidates(const World& world);
    void find_neighbours(const World& world);
    void neighbours_of(const World& world, std::uint32_t g, std::uint32_t local, std::vector<std::uint32_t>& out) const;
    const Vec3& reference(std::uint32_t g) const;
    bool stale() const;
    void add_arrivals();
    void listed_near(const Vec3& x, double ra, std::vector<std::uint32_t>& out) const;
    void list_candidates();
    void grid_listed();
    void join(const std::vector<std::vector<std::uint32_t>>& part, std::vector<std::uint32_t>& out) const;
    std::vector<std::uint32_t> due(double time) const;
    void neighbour_changes(std::size_t o, std::vector<std::uint32_t>& lost, std::vector<std::uint32_t>& gained) const;
    void run_handlers(const World& world, const std::vector<std::uint32_t>& which, double time);
    void finish_step(World& world);
    void exchange_mail(World& world, std::vector<std::pair<std::uint32_t, std::string>>& failed);
    std::unique_ptr<Catom> fresh_record(std::uint32_t g) const;
    void hold_records();
    void refresh_world(World& world, bool all);
    // One catom's record (values, flags, timer, inbox, program bytes, last
    // neighbours as catom indices): appended to `out`, or read from `in` at
    // `at` (returns the offset after it; `nbrs` gets the neighbours' gids).
    void put_catom(std::uint32_t g, std::vector<char>& out) const;
    std::size_t get_catom(Catom& c, std::uint32_t g, const std::vector<char>& in, std::size_t at,
                          std::vector<std::uint32_t>& nbrs) const;
    void assemble_piece(const std::vector<std::vector<char>>& all, std::size_t lo, std::size_t hi,
                        std::vector<char>& out) const;
    std::size_t next_catom(Catom& c, std::uint32_t g, ByteSource& state, std::vector<char>& window, std::size_t at,
                           std::vector<std::uint32_t>& nbrs) const;
    bool distributed() const { return coll_->distributed(); }

    const Scene& scene_;
    Execution& exec_;
    const ProgramSpec* spec_;
    Numbering numbering_;
    Collectives single_;
    const Collectives* coll_ = &single_;
    double reach_, edge_ = 0, skin_ = 0;
    // Each owned catom's record by gid, held only while this process owns the
    // catom (and, from the set-up, until the first step has moved what moves);
    // sized at its first use (ensure_records) for the catoms owned then.
    GidTable<Catom> records_;
    // No catom has run anywhere since the start: an owned catom without a
    // record here may start afresh; later (and after a restart) it must arrive.
    bool unstarted_ = true;
    bool relocated_ = false;  // locate() found the world changed: owned catoms may lack records
    bool sweep_ = false;      // records of catoms not owned here to drop (made at the set-up, before the first step)
    // This step: the catoms held here (gids, ascending) and their local
    // indices; the owned ones (gids, ascending), their local indices and
    // records, and whether each record changed since its digest and the
    // digest (bind_owned; the digests were worked out for digest_of_).
    std::vector<std::uint32_t> present_, plocal_, owned_, owned_local_;
    std::vector<Catom*> owned_rec_;
    std::vector<std::uint8_t> dirty_;
    std::vector<std::uint64_t> digest_;
    std::vector<std::uint32_t> digest_of_;
    std::vector<std::uint32_t> ran_;  // places in owned_ of the catoms whose handlers ran this step (ascending)
    std::vector<std::uint32_t> last_owned_;  // the catoms this process ran last step (gids)
    std::uint64_t generation_ = ~0ULL;       // the world's, when the values were last written
    // Last step's neighbours of catoms that arrived from another process.
    std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> arrived_;
    // This step's neighbours of the owned catoms (keys: owned_) and last
    // step's (keys: last step's owned catoms); each owned catom's place in
    // before_ (kNone: none).
    Csr now_, before_;
    std::vector<std::uint32_t> before_at_;
    // The candidate neighbours: the catoms listed (listed_k_, gids
    // ascending), their centres then (listed_x_) and candidates (cand_: gids,
    // ascending), by their place in listed_k_; the same catoms sorted by cell
    // with their centres and radii (listed_, for the lookups; a radius kept
    // in a float rounded up, so the bound can only widen); each held catom's
    // place in listed_k_ (lidx_ by gid: kArrived for one that arrived since,
    // with its reference position in extra_; absent: no reference); arrivals'
    // candidates and the others' added to them (extra_), the arrivals in a
    // hash grid, and how many arrived since the listing.
    struct Listed {
        Vec3 x;
        float r;
        std::uint32_t k;
    };
    Csr cand_;
    std::vector<Listed> listed_;
    std::vector<std::uint32_t> listed_k_;
    IdMap lidx_;
    std::vector<Vec3> listed_x_;
    struct Extra {
        Vec3 x{0, 0, 0};
        std::vector<std::uint32_t> cand;
    };
    std::unordered_map<std::uint32_t, Extra> extra_;
    std::unordered_map<std::int64_t, std::vector<std::uint32_t>> arrived_cells_;
    std::size_t arrivals_ = 0;
    std::vector<Vec3> xl_;  // the held catoms' centres this step, by local index
    // The listing's cells: a dense grid over the listed catoms' bounding box
    // (start_: where each cell's catoms begin in listed_), or, when that
    // would hold more than 8 cells a catom, each listed catom's cell key.
    std::vector<std::uint32_t> start_;
    std::vector<std::int64_t> keys_;
    Vec3 low_{0, 0, 0};
    std::int64_t dims_[3] = {0, 0, 0};
    std::uint64_t located_ = ~0ULL;  // the world's generation when the catoms were located
    long step_ = 0;
    ProgramCounts counts_;
};

}  // namespace parode
