// Checkpoints: everything the next step depends on, so that a run restarted
// from step k gives the state of an uninterrupted run bit for bit, on any
// number of processes; written so that a crash at any moment leaves a
// complete one, and read so that a damaged one is refused, never run on.
// Layout of a file:
//   "parode-checkpoint 2 <head bytes> <header XXH3>\n" + JSON metadata,
//     padded with spaces to a multiple of 4 KiB (step, time, the scene's name
//     and digest, ODE's dRand state, run totals, guard and checks state,
//     counts, the checksums of the sections below); the XXH3 (64 bits) of
//     everything after the first line up to the head bytes;
//   one 168-byte record per body, in global-id order: position, the
//     quaternion last handed to ODE and the one ODE holds, linear and angular
//     velocity, initial position, awake (21 doubles);
//   the warm-start impulses of the contact solver, 36 bytes each (lo, hi,
//     index, three impulses), grouped by the process that wrote them; the
//     header's "impulse_index" gives, per group, the smallest and largest
//     lower id of each block of impulses.
// Every process writes its owned bodies' records in place (MPI-IO, by gid)
// and its impulses after them; a restarting process reads the records of the
// ids it builds and the blocks of impulses that may hold those bodies', with
// plain file reads.
// Durability: the file is written as FILE.tmp beside FILE, synced to the
// disk, and renamed over FILE by the root once every process has written;
// the FILE it replaces stays as FILE.prev (a hard link made before the
// rename). A crash at any moment leaves FILE complete (old or new).
// Checksums (XXH3, libxxhash): the header's; each block of 65,536 records,
// the sum modulo 2^64 of every record's XXH3 seeded with its id, so that the
// ranks that write or read a block's records add their parts up in any
// order; each writer's impulses as one piece. A restart checks the header as
// it reads it and, collectively, every block of records (each restarting
// process hashes the records it reads; every id is read once) and every
// piece of impulses (a piece read whole by one process) before anything is
// built from them; a difference throws CheckpointError naming the section
// and both values. Version 1 files (no checksums) still read, unverified.
// Trade-off: fixed-size records by gid make the body part identical for any
// writer and let any reader pick its ids without an index; impulses are
// grouped by writer, not sorted globally (no collective sort when writing),
// so a reader uses the index to skip the blocks it needs none of, and reads
// whole blocks of others' impulses where lower-id ranges overlap.
#pragma once
#include <nlohmann/json.hpp>

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

#include "domain/collectives.hpp"
#include "solve/contact_solver.hpp"
#include "util/byte_source.hpp"
#include "world/world.hpp"

namespace parode {

struct CheckpointRecord {
    BodyState state;     // q: the input last handed to ODE
    double ode_q[4];     // what ODE held: the check that the restore is exact
    Vec3 origin;
    bool enabled = true; // awake (ODE auto-disable)
};
constexpr std::size_t kRecordBytes = 21 * sizeof(double);
constexpr std::size_t kImpulseBytes = 3 * sizeof(std::uint32_t) + 3 * sizeof(double);

struct Checkpoint {
    std::string path;
    nlohmann::json meta;
    std::uint64_t head_bytes = 0;
    std::uint64_t bodies = 0;
    std::uint64_t impulses = 0;
    long step = 0;
    int version = 2;  // 1: no checksums
};

// Records one checksum of the records section covers.
constexpr std::uint64_t kRecordSumBlock = 65536;

// What writing checkpoints cost (seconds: the slowest process's).
struct CheckpointCost {
    long written = 0;
    double seconds = 0;           // packing, checksums, writing, syncing, renaming
    double checksum_seconds = 0;  // the XXH3 of the records and impulses alone
    std::uint64_t bytes = 0;      // of the last one
    CheckpointCost& operator+=(const CheckpointCost& o);
};

// A section written after the impulses (the catom programs' state), made
// piece by piece on the last process (the writer), so that no process holds
// it whole: `piece(k, out)` appends the k-th of `pieces()` to `out` there and
// nothing elsewhere; collective: every process calls it for every k in order.
class SectionSource {
public:
    virtual ~SectionSource() = default;
    virtual std::size_t pieces() const = 0;
    virtual void piece(std::size_t k, std::vector<char>& out) const = 0;
};

// Collective: writes every process's owned bodies and impulses, with `meta`
// (the root's) completed by counts. Throws std::runtime_error naming the file.
// `extra` (every process passes one or none): its pieces are made twice, for
// the section's size and XXH3 in the head, then for the writer to append
// them to the file.
CheckpointCost write_checkpoint(const std::string& path, const Collectives& domain, const World& world,
                      const std::vector<WarmImpulse>* warm, nlohmann::json meta,
                      const SectionSource* extra = nullptr);
// That section, read in windows of a few MB, so that no process of a restart
// holds the scene's catom records at once: its XXH3 is checked first,
// streamed (CheckpointError if it differs), then `refill` hands the bytes
// out in order.
class ExtraReader final : public ByteSource {
public:
    explicit ExtraReader(const Checkpoint& c);
    std::uint64_t size() const { return size_; }  // 0: the checkpoint has none
    // At most a window's worth (64 kB) at a time.
    bool refill(std::vector<char>& window, std::size_t& at) override;

private:
    std::string path_;
    std::ifstream in_;
    std::uint64_t size_ = 0, left_ = 0;
};
// The header of a checkpoint, its checksum checked. Throws CheckpointError
// naming the file and what is wrong with it (std::invalid_argument when it
// cannot be opened).
Checkpoint read_checkpoint(const std::string& path);
// The records of `gids` (ascending), runs of consecutive ids read at once;
// with `sums`, each record's XXH3 added to its block's entry (sized to the
// blocks of the file).
std::vector<CheckpointRecord> read_records(const Checkpoint& c, const std::vector<std::uint32_t>& gids,
                                           std::vector<std::uint64_t>* sums = nullptr);
// Collective: checks the records every process read (their block sums,
// `sums` from read_records over ids that together cover every body once)
// and every piece of impulses (piece p read whole by process p mod ranks)
// against the header. Throws CheckpointError on every process, naming the
// section and both values; returns what was checked, for the run report.
nlohmann::json verify_checkpoint(const Checkpoint& c, std::vector<std::uint64_t> sums, const Collectives& domain);
// The impulses whose lower body is one of `gids` (ascending), sorted: the
// blocks the header's index says may hold them (all impulses if it has none).
std::vector<WarmImpulse> read_impulses(const Checkpoint& c, const std::vector<std::uint32_t>& gids);

// Impulses [first, first + count) of the file.
struct ImpulseRange {
    std::uint64_t first, count;
};
// The blocks of the header's "impulse_index" (per writer's piece: its count,
// then the smallest and largest lower id of each block) whose lower-id range
// holds one of `gids` (ascending), neighbouring blocks joined.
std::vector<ImpulseRange> impulse_ranges(const nlohmann::json& index, const std::vector<std::uint32_t>& gids);

}  // namespace parode
