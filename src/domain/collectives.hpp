// Collectives: what the processes of a run do together, for the stages that
// reduce, gather or write (diagnostics, guard, checks, trajectories,
// snapshots, checkpoints, the run report). This base class is one process:
// its collectives return their input and it writes files with plain POSIX
// I/O; mpi/ implements the same interface over MPI.
// Every collective must be called by every process in the same order; a
// reduction whose result the state depends on is exact (integer sums,
// ExactSum digits, maxima), never a floating-point sum in MPI's order.
// Trade-off: byte-vector gathers to one process are simple and general, and
// fine for what goes through them (trajectory frames, CSV snapshots, failure
// messages); H5MD snapshots go through all_to_all (each process writes a
// block of ids), and the step's bulk traffic through the Decomposition.
#pragma once
#include <algorithm>
#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "util/exact_sum.hpp"

namespace parode {

// Records a piece of FilePieces holds at most: 5.5 MB of checkpoint records,
// about the collective write's own buffers.
inline constexpr std::size_t kPieceRecords = 32768;

// One file written by every process together: the root's head at 0, fixed-
// size records of bodies at records_at + gid * record (gids ascending), then
// every process's tail (tail_count records of tail_record bytes), in rank
// order, from tail_at. Records and tails are made as they are written,
// `piece` at a time (pack(first, n, out) writes records first .. first +
// n - 1, in gids' order, at out; pack_tail the same of the tail): a process
// never holds all of them at once (a checkpoint's: 168 bytes a body, 36 an
// impulse).
struct FilePieces {
    using Pack = std::function<void(std::size_t first, std::size_t n, char* out)>;
    std::vector<char> head;  // root only
    std::uint64_t records_at = 0;
    std::size_t record = 0;
    std::vector<std::uint32_t> gids;
    Pack pack;
    std::uint64_t tail_at = 0;
    std::size_t tail_record = 1, tail_count = 0;
    Pack pack_tail;
    std::size_t piece = kPieceRecords;  // records (or tail records) a piece
};

// use(first, n) for each piece of `count` records, `piece` at a time.
template <class Use>
void each_piece(std::size_t count, std::size_t piece, Use use) {
    for (std::size_t first = 0; first < count; first += piece) use(first, std::min(count - first, piece));
}

// The first record and the records of round `r` of `count` records, `piece` a
// round (none in a round past the last: a process taking part with nothing).
inline std::pair<std::size_t, std::size_t> piece_of_round(std::uint64_t r, std::size_t count, std::size_t piece) {
    const std::size_t first = std::min<std::uint64_t>(count, r * piece);
    return {first, std::min(count - first, piece)};
}

// `n` bytes at `at` of file `fd`, whole (pwrite may write less); false on an error.
bool write_at(int fd, const char* data, std::size_t n, std::uint64_t at);

class Collectives {
public:
    virtual ~Collectives() = default;
    virtual int rank() const { return 0; }
    virtual int ranks() const { return 1; }
    bool root() const { return rank() == 0; }
    bool last() const { return rank() == ranks() - 1; }  // a checkpoint's programs' section is made there
    bool distributed() const { return ranks() > 1; }

    // In place; every process gets the result.
    virtual void sum(std::int64_t* v, int n) const;
    virtual void sum_wrapping(std::uint64_t* v, int n) const;  // modulo 2^64
    virtual void max(double* v, int n) const;
    // Writes `pieces` of every process into one file (MPI-IO when
    // distributed). Throws OutputError naming the file on failure.
    virtual void write_file(const std::string& path, const FilePieces& pieces) const;
    // Every process's bytes, in rank order: on every process (all) or on the
    // root only (others get an empty list).
    virtual std::vector<std::vector<char>> all_gather(const std::vector<char>& mine) const;
    virtual std::vector<std::vector<char>> gather(const std::vector<char>& mine) const;
    // out[r] goes to process r; returns what every process sent here, in rank order.
    virtual std::vector<std::vector<char>> all_to_all(const std::vector<std::vector<char>>& out) const;
    // The same from one buffer: the first counts[0] bytes of `flat` go to
    // process 0, the next counts[1] to process 1, ...; returns what every
    // process sent here, concatenated in rank order. `flat` is freed before
    // it returns, so that a large exchange holds at most its two buffers.
    virtual std::vector<char> all_to_all(std::vector<char> flat, const std::vector<std::size_t>& counts) const;
    // The same for traffic between few processes: only the non-empty out[r]
    // travel, and no process learns the others' counts first (a sparse,
    // non-blocking-barrier exchange: the messages sent plus a barrier's
    // rounds, against all_to_all's count from every process). `channel`
    // (0-3) keeps apart exchanges that follow each other with no other
    // collective between them.
    virtual std::vector<std::vector<char>> sparse_to(const std::vector<std::vector<char>>& out, int channel) const;
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
