// The only interface to MPI: every call the distributed layer makes goes
// through Comm (comm.cpp is the only file that includes <mpi.h>), which also
// counts what it costs: seconds inside MPI, bytes and messages sent.
// Patterns: collectives (sums, maxima, gathers, broadcast), a sparse exchange
// with partners that the receiver does not know in advance (the NBX
// algorithm: synchronous sends, then a non-blocking barrier once they are
// all matched), and a neighbour exchange with known partners.
// It also hands MPI_COMM_WORLD to parallel HDF5 (h5_parallel), whose header
// includes <mpi.h> in turn.
// Trade-off: byte vectors everywhere (one copy more than derived datatypes)
// keep the rest of the layer free of MPI types and easy to test.
#pragma once
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "domain/collectives.hpp"

namespace parode::mpi {

using Bytes = std::vector<char>;

// A value's bytes appended to `b`; the value at `at` in `b`, `at` moved past it.
template <class T>
void put(Bytes& b, const T& v) {
    const std::size_t at = b.size();
    b.resize(at + sizeof(T));
    std::memcpy(b.data() + at, &v, sizeof(T));
}
template <class T>
T take(const char* b, std::size_t& at) {
    T v;
    std::memcpy(&v, b + at, sizeof(T));
    at += sizeof(T);
    return v;
}
template <class T>
T take(const Bytes& b, std::size_t& at) {
    return take<T>(b.data(), at);
}

// A message of the span form of Comm::sparse_exchange: `size` bytes at
// `data`, for process `rank` or from it.
struct Message {
    int rank = -1;
    const char* data = nullptr;
    std::size_t size = 0;
};

// Where the span form of Comm::sparse_exchange puts what arrives: `room`
// bytes at `data` (a buffer the caller lends, e.g. a scratch pool's), each
// message after the last; a message that does not fit gets a buffer of its
// own in `spill`.
struct Landing {
    char* data = nullptr;
    std::size_t room = 0, used = 0;
    std::vector<Bytes> spill;
    // Room for `n` bytes: in the lent buffer when they fit, else spilled.
    char* place(std::size_t n);
};

// True when this process was started by an MPI launcher (mpirun, mpiexec,
// srun): then main() initialises MPI, otherwise it never touches it.
bool launched();

// MPI_Init_thread (MPI_THREAD_FUNNELED: only the main thread calls MPI,
// OpenMP threads do not) and MPI_Finalize.
class Session {
public:
    Session(int& argc, char**& argv);
    ~Session();
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;
};

struct CommStats {
    double seconds = 0;         // inside MPI calls, waiting included
    std::uint64_t bytes = 0;    // sent
    std::uint64_t messages = 0; // sent
};

// A message longer than the receive posted for it (post_exchange with
// sizes): the index into `from` and the bytes expected.
class MessageTooLong : public std::runtime_error {
public:
    MessageTooLong(std::size_t from_index, std::size_t expected_bytes)
        : std::runtime_error("a message longer than expected"), index(from_index), expected(expected_bytes) {}
    std::size_t index, expected;
};

// A neighbour exchange under way (Comm::post_exchange), finished by
// Comm::complete_exchange. Owns the requests; one exchange at a time each.
class PendingExchange {
public:
    PendingExchange();
    ~PendingExchange();
    PendingExchange(const PendingExchange&) = delete;
    PendingExchange& operator=(const PendingExchange&) = delete;
    struct Impl;
    std::unique_ptr<Impl> impl;
};

class Comm {
public:
    Comm();  // MPI_COMM_WORLD
    int rank() const { return rank_; }
    int size() const { return size_; }

    void sum(std::int64_t* v, int n) const;
    void sum_wrapping(std::uint64_t* v, int n) const;
    void max(double* v, int n) const;
    void min(std::uint64_t* v, int n) const;
    void max(std::uint64_t* v, int n) const;
    std::vector<Bytes> all_gather(const Bytes& mine) const;
    std::vector<Bytes> gather(const Bytes& mine, int root) const;
    void broadcast(Bytes& bytes, int root) const;
    // out[r] goes to process r; returns what every process sent here, in rank order.
    std::vector<Bytes> all_to_all(const std::vector<Bytes>& out) const;
    // The same from one buffer: counts[r] bytes of `flat` (in rank order)
    // to process r; returns what arrived, concatenated in rank order, `flat`
    // freed first.
    Bytes all_to_all(Bytes flat, const std::vector<std::size_t>& counts) const;

    // Sends out[dest] to each dest; returns what every other process sent
    // here, sorted by source rank. Partners need not be known in advance.
    // Every process makes the calls with one `tag` in the same order.
    std::vector<std::pair<int, Bytes>> sparse_exchange(const std::map<int, Bytes>& out, int tag) const;
    // The same from messages in the caller's memory (one per destination,
    // ascending), received into `in`: no copy of a message on either side.
    std::vector<Message> sparse_exchange(const std::vector<Message>& out, Landing& in, int tag) const;
    // Sends out[i] to partners[i] and receives one message (any size) from
    // each of `from`; in[j] is what from[j] sent (its buffer reused).
    void exchange(const std::vector<int>& to, const std::vector<Bytes>& out, const std::vector<int>& from,
                  std::vector<Bytes>& in, int tag) const;
    // exchange() in two halves, so that work can run while the messages
    // travel: post_exchange sends (out must stay untouched until complete)
    // and, when `sizes` gives the bytes expected from each of `from`, posts
    // the receives into `in`; complete_exchange receives what was not posted
    // (probed, any size) and waits for everything.
    void post_exchange(const std::vector<int>& to, const std::vector<Bytes>& out, const std::vector<int>& from,
                       std::vector<Bytes>& in, const std::vector<std::size_t>* sizes, int tag, PendingExchange& p) const;
    void complete_exchange(PendingExchange& p) const;
    // PARODE_INJECT_LATENCY_US (a testing aid): every point-to-point exchange
    // completes no sooner than this many seconds after it began, as on a
    // network of that latency; 0 when unset.
    double injected_latency() const { return latency_; }

    // Collective MPI-IO of `f` (domain/collectives.hpp): the root's head at
    // 0; the records (one of f.record bytes per entry of f.gids, ascending)
    // at f.records_at + gid * f.record, f.piece a round (as many rounds
    // on every process as the fullest needs), each through an indexed file
    // view and a collective write (aggregated by the MPI library); each
    // process's tail after the previous ranks' tails, from f.tail_at. Throws
    // std::runtime_error (on every process) when the file cannot be opened
    // or written.
    void write_file(const std::string& path, const FilePieces& f) const;

    // HDF5 property lists (hid_t values) for one file of every process: the
    // MPI-IO driver on MPI_COMM_WORLD, independent transfers of each
    // process's contiguous block. Throws std::logic_error in a build without HDF5.
    void h5_parallel(std::int64_t file_access, std::int64_t transfer) const;

    [[noreturn]] void abort(int code) const;
    // Point-to-point time between ranks 0 and 1, measured by a ping-pong of
    // `rounds` messages of `bytes` bytes (collective; seconds one way).
    double ping_pong_latency(int rounds, std::size_t bytes) const;
    // Seconds of one round of exchange() in which every process swaps a
    // message of `bytes` with every other (collective; the mean of `rounds`).
    double exchange_round(int rounds, std::size_t bytes) const;

    const CommStats& stats() const { return stats_; }

private:
    // sparse_exchange's rounds: sends `out`, calls receive(msg, status) for
    // each message matched here.
    template <class Receive>
    void nbx(const std::vector<Message>& out, int call_tag, Receive receive) const;
    Bytes exchange_all(Bytes flat, const std::vector<std::size_t>& counts, std::vector<int>& recv) const;
    // Waits until `since` + the injected latency (now_seconds' clock).
    void hold_until(double since) const;
    int rank_ = 0, size_ = 1;
    double latency_ = 0;  // seconds, from PARODE_INJECT_LATENCY_US
    mutable CommStats stats_;
    mutable std::map<int, unsigned> sparse_calls_;  // sparse_exchange calls by tag: their MPI tag's parity
};

}  // namespace parode::mpi
