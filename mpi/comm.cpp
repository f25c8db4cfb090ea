// MPI calls of the distributed layer (see comm.hpp).
#include "comm.hpp"

#include <mpi.h>
#ifdef PARODE_HAVE_HDF5
#include <hdf5.h>
#endif

#include "util/errors.hpp"
#include "util/launcher.hpp"
#include "util/substages.hpp"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cstdlib>
#include <stdexcept>
#include <type_traits>

namespace parode::mpi {
namespace {

// Adds the wall time of its scope to a counter.
class Clock {
public:
    explicit Clock(CommStats& s) : s_(s), t0_(std::chrono::steady_clock::now()) {}
    ~Clock() { s_.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count(); }
    Clock(const Clock&) = delete;
    Clock& operator=(const Clock&) = delete;

private:
    CommStats& s_;
    std::chrono::steady_clock::time_point t0_;
};

void check(int rc, const char* what) {
    if (rc != MPI_SUCCESS) throw std::runtime_error(std::string("MPI error in ") + what);
}

std::vector<int> displacements(const std::vector<int>& counts) {
    std::vector<int> d(counts.size(), 0);
    for (std::size_t i = 1; i < counts.size(); ++i) d[i] = d[i - 1] + counts[i - 1];
    return d;
}

std::vector<Bytes> split(const Bytes& all, const std::vector<int>& counts) {
    std::vector<Bytes> out(counts.size());
    std::size_t at = 0;
    for (std::size_t i = 0; i < counts.size(); ++i) {
        out[i].assign(all.begin() + static_cast<long>(at), all.begin() + static_cast<long>(at + static_cast<std::size_t>(counts[i])));
        at += static_cast<std::size_t>(counts[i]);
    }
    return out;
}

// Into `b` (resized; its capacity is reused from call to call).
void receive_probed_into(MPI_Message& msg, MPI_Status& st, Bytes& b) {
    int n = 0;
    MPI_Get_count(&st, MPI_BYTE, &n);
    b.resize(static_cast<std::size_t>(n));
    check(MPI_Mrecv(b.data(), n, MPI_BYTE, &msg, MPI_STATUS_IGNORE), "MPI_Mrecv");
}

Bytes receive_probed(MPI_Message& msg, MPI_Status& st) {
    Bytes b;
    receive_probed_into(msg, st, b);
    return b;
}

}  // namespace

bool launched() { return launcher::launched(); }

Session::Session(int& argc, char**& argv) {
    int provided = 0;
    check(MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided), "MPI_Init_thread");
    if (provided < MPI_THREAD_FUNNELED) throw std::runtime_error("the MPI library does not support MPI_THREAD_FUNNELED");
    // Errors come back as codes (check() turns them into exceptions), so
    // that a message longer than a posted receive is reported, not fatal.
    MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
}

Session::~Session() { MPI_Finalize(); }

Comm::Comm() {
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
    if (const char* env = std::getenv("PARODE_INJECT_LATENCY_US"); env && *env) {
        char* end = nullptr;
        const double us = std::strtod(env, &end);
        if (end == env || *end != '\0' || !(us >= 0 && us <= 1e6)) {
            throw std::invalid_argument(std::string("PARODE_INJECT_LATENCY_US=") + env +
                                        ": expected microseconds, a number in [0, 1000000]");
        }
        latency_ = us * 1e-6;
    }
}

namespace {

// Element-wise `op` of every process's v, in place, timed into `stats`.
void allreduce(CommStats& stats, void* v, int n, MPI_Datatype type, MPI_Op op) {
    Clock c(stats);
    check(MPI_Allreduce(MPI_IN_PLACE, v, n, type, op, MPI_COMM_WORLD), "MPI_Allreduce");
}

}  // namespace

void Comm::sum(std::int64_t* v, int n) const { allreduce(stats_, v, n, MPI_INT64_T, MPI_SUM); }
void Comm::sum_wrapping(std::uint64_t* v, int n) const { allreduce(stats_, v, n, MPI_UINT64_T, MPI_SUM); }
void Comm::max(double* v, int n) const { allreduce(stats_, v, n, MPI_DOUBLE, MPI_MAX); }
void Comm::min(std::uint64_t* v, int n) const { allreduce(stats_, v, n, MPI_UINT64_T, MPI_MIN); }
void Comm::max(std::uint64_t* v, int n) const { allreduce(stats_, v, n, MPI_UINT64_T, MPI_MAX); }

std::vector<Bytes> Comm::all_gather(const Bytes& mine) const {
    Clock c(stats_);
    int n = static_cast<int>(mine.size());
    std::vector<int> counts(static_cast<std::size_t>(size_));
    check(MPI_Allgather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, MPI_COMM_WORLD), "MPI_Allgather");
    const std::vector<int> disp = displacements(counts);
    Bytes all(static_cast<std::size_t>(disp.back() + counts.back()));
    check(MPI_Allgatherv(mine.data(), n, MPI_BYTE, all.data(), counts.data(), disp.data(), MPI_BYTE, MPI_COMM_WORLD),
          "MPI_Allgatherv");
    return split(all, counts);
}

std::vector<Bytes> Comm::gather(const Bytes& mine, int root) const {
    Clock c(stats_);
    int n = static_cast<int>(mine.size());
    std::vector<int> counts(static_cast<std::size_t>(size_));
    check(MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, root, MPI_COMM_WORLD), "MPI_Gather");
    const std::vector<int> disp = displacements(counts);
    Bytes all(rank_ == root ? static_cast<std::size_t>(disp.back() + counts.back()) : 0);
    check(MPI_Gatherv(mine.data(), n, MPI_BYTE, all.data(), counts.data(), disp.data(), MPI_BYTE, root, MPI_COMM_WORLD),
          "MPI_Gatherv");
    if (rank_ != root) return {};
    return split(all, counts);
}

void Comm::broadcast(Bytes& bytes, int root) const {
    Clock c(stats_);
    long n = static_cast<long>(bytes.size());
    check(MPI_Bcast(&n, 1, MPI_LONG, root, MPI_COMM_WORLD), "MPI_Bcast");
    bytes.resize(static_cast<std::size_t>(n));
    check(MPI_Bcast(bytes.data(), static_cast<int>(n), MPI_BYTE, root, MPI_COMM_WORLD), "MPI_Bcast");
}

std::vector<Bytes> Comm::all_to_all(const std::vector<Bytes>& out) const {
    std::vector<std::size_t> counts(static_cast<std::size_t>(size_));
    Bytes flat;
    for (std::size_t r = 0; r < counts.size(); ++r) {
        if (out[r].size() > static_cast<std::size_t>(INT_MAX) - flat.size()) {
            throw std::runtime_error("all_to_all: more than 2 GiB from one process");
        }
        counts[r] = out[r].size();
        flat.insert(flat.end(), out[r].begin(), out[r].end());
    }
    std::vector<int> recv;
    const Bytes all = exchange_all(flat, counts, recv);
    return split(all, recv);
}

Bytes Comm::all_to_all(Bytes flat, const std::vector<std::size_t>& counts) const {
    std::vector<int> recv;
    return exchange_all(std::move(flat), counts, recv);
}

// MPI_Alltoallv of `flat` (counts[r] bytes to process r); `recv` the bytes
// from each process. `flat` is freed before the result is handed back.
Bytes Comm::exchange_all(Bytes flat, const std::vector<std::size_t>& counts, std::vector<int>& recv) const {
    Clock c(stats_);
    std::vector<int> send(static_cast<std::size_t>(size_));
    long long out = 0;
    for (std::size_t r = 0; r < send.size(); ++r) {
        out += static_cast<long long>(counts[r]);
        send[r] = static_cast<int>(counts[r]);
    }
    if (out > INT_MAX) throw std::runtime_error("all_to_all: more than 2 GiB from one process");
    recv.assign(send.size(), 0);
    check(MPI_Alltoall(send.data(), 1, MPI_INT, recv.data(), 1, MPI_INT, MPI_COMM_WORLD), "MPI_Alltoall");
    long long in = 0;
    for (int n : recv) in += n;
    if (in > INT_MAX) throw std::runtime_error("all_to_all: more than 2 GiB to one process");
    const std::vector<int> sdisp = displacements(send), rdisp = displacements(recv);
    Bytes all(static_cast<std::size_t>(rdisp.back()) + static_cast<std::size_t>(recv.back()));
    check(MPI_Alltoallv(flat.data(), send.data(), sdisp.data(), MPI_BYTE, all.data(), recv.data(), rdisp.data(), MPI_BYTE,
                        MPI_COMM_WORLD),
          "MPI_Alltoallv");
    stats_.bytes += static_cast<std::uint64_t>(out) - counts[static_cast<std::size_t>(rank_)];
    Bytes().swap(flat);
    return all;
}

// NBX (Hoefler, Siebert, Lumsdaine 2010): synchronous sends complete only
// when matched, so once all of this process's sends are done it enters a
// non-blocking barrier; when the barrier completes, every message of the
// round has been received somewhere. The barrier completes at processes one
// by one, so a process may send the next call's messages while another still
// probes for this call's; calls with one tag alternate between two MPI tags
// (1000 + 2 tag and the next; never two calls ahead: ending the next call
// needs that process in its barrier), so no call takes the next one's.
template <class Receive>
void Comm::nbx(const std::vector<Message>& out, int call_tag, Receive receive) const {
    Clock c(stats_);
    const int tag = 1000 + 2 * call_tag + static_cast<int>(sparse_calls_[call_tag]++ & 1u);
    const double began = now_seconds();
    std::vector<MPI_Request> sends;
    for (const Message& m : out) {
        sends.emplace_back();
        check(MPI_Issend(m.data, static_cast<int>(m.size), MPI_BYTE, m.rank, tag, MPI_COMM_WORLD, &sends.back()),
              "MPI_Issend");
        stats_.bytes += m.size;
        ++stats_.messages;
    }
    MPI_Request barrier = MPI_REQUEST_NULL;
    for (bool done = false; !done;) {
        int flag = 0;
        MPI_Message msg;
        MPI_Status st;
        check(MPI_Improbe(MPI_ANY_SOURCE, tag, MPI_COMM_WORLD, &flag, &msg, &st), "MPI_Improbe");
        if (flag) receive(msg, st);
        if (barrier == MPI_REQUEST_NULL) {
            int sent = 0;
            check(MPI_Testall(static_cast<int>(sends.size()), sends.data(), &sent, MPI_STATUSES_IGNORE), "MPI_Testall");
            if (sent) check(MPI_Ibarrier(MPI_COMM_WORLD, &barrier), "MPI_Ibarrier");
        } else {
            int fin = 0;
            check(MPI_Test(&barrier, &fin, MPI_STATUS_IGNORE), "MPI_Test");
            done = fin != 0;
        }
    }
    hold_until(began);
}

std::vector<std::pair<int, Bytes>> Comm::sparse_exchange(const std::map<int, Bytes>& out, int call_tag) const {
    std::vector<Message> msgs;
    for (const auto& [dest, bytes] : out) msgs.push_back({dest, bytes.data(), bytes.size()});
    std::vector<std::pair<int, Bytes>> in;
    nbx(msgs, call_tag, [&in](MPI_Message& msg, MPI_Status& st) { in.emplace_back(st.MPI_SOURCE, receive_probed(msg, st)); });
    std::sort(in.begin(), in.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    return in;
}

char* Landing::place(std::size_t n) {
    if (used + n <= room) {
        char* at = data + used;
        used += n;
        return at;
    }
    spill.emplace_back(n);
    return spill.back().data();
}

std::vector<Message> Comm::sparse_exchange(const std::vector<Message>& out, Landing& landing, int call_tag) const {
    std::vector<Message> in;
    nbx(out, call_tag, [&in, &landing](MPI_Message& msg, MPI_Status& st) {
        int n = 0;
        MPI_Get_count(&st, MPI_BYTE, &n);
        char* at = landing.place(static_cast<std::size_t>(n));
        check(MPI_Mrecv(at, n, MPI_BYTE, &msg, MPI_STATUS_IGNORE), "MPI_Mrecv");
        in.push_back({st.MPI_SOURCE, at, static_cast<std::size_t>(n)});
    });
    std::sort(in.begin(), in.end(), [](const Message& a, const Message& b) { return a.rank < b.rank; });
    return in;
}

struct PendingExchange::Impl {
    std::vector<MPI_Request> sends, recvs;  // recvs: MPI_REQUEST_NULL where the size was not known
    const std::vector<int>* from = nullptr;
    std::vector<Bytes>* in = nullptr;
    int tag = 0;
    double began = 0;
};

PendingExchange::PendingExchange() : impl(std::make_unique<Impl>()) {}
PendingExchange::~PendingExchange() = default;

void Comm::exchange(const std::vector<int>& to, const std::vector<Bytes>& out, const std::vector<int>& from,
                    std::vector<Bytes>& in, int tag) const {
    PendingExchange p;
    post_exchange(to, out, from, in, nullptr, tag, p);
    complete_exchange(p);
}

void Comm::post_exchange(const std::vector<int>& to, const std::vector<Bytes>& out, const std::vector<int>& from,
                         std::vector<Bytes>& in, const std::vector<std::size_t>* sizes, int tag,
                         PendingExchange& p) const {
    Clock c(stats_);
    PendingExchange::Impl& x = *p.impl;
    x.began = now_seconds();
    x.from = &from;
    x.in = &in;
    x.tag = tag;
    in.resize(from.size());
    x.recvs.assign(from.size(), MPI_REQUEST_NULL);
    for (std::size_t j = 0; sizes && j < from.size(); ++j) {
        in[j].resize((*sizes)[j]);
        check(MPI_Irecv(in[j].data(), static_cast<int>(in[j].size()), MPI_BYTE, from[j], tag, MPI_COMM_WORLD, &x.recvs[j]),
              "MPI_Irecv");
    }
    x.sends.assign(to.size(), MPI_REQUEST_NULL);
    for (std::size_t i = 0; i < to.size(); ++i) {
        check(MPI_Isend(out[i].data(), static_cast<int>(out[i].size()), MPI_BYTE, to[i], tag, MPI_COMM_WORLD, &x.sends[i]),
              "MPI_Isend");
        stats_.bytes += out[i].size();
        ++stats_.messages;
    }
}

void Comm::complete_exchange(PendingExchange& p) const {
    Clock c(stats_);
    PendingExchange::Impl& x = *p.impl;
    for (std::size_t j = 0; j < x.from->size(); ++j) {
        if (x.recvs[j] != MPI_REQUEST_NULL) continue;
        MPI_Message msg;
        MPI_Status st;
        check(MPI_Mprobe((*x.from)[j], x.tag, MPI_COMM_WORLD, &msg, &st), "MPI_Mprobe");
        receive_probed_into(msg, st, (*x.in)[j]);
    }
    std::vector<MPI_Status> got(x.recvs.size());
    const int rc = MPI_Waitall(static_cast<int>(x.recvs.size()), x.recvs.data(), got.data());
    check(MPI_Waitall(static_cast<int>(x.sends.size()), x.sends.data(), MPI_STATUSES_IGNORE), "MPI_Waitall");
    if (rc == MPI_ERR_IN_STATUS) {
        for (std::size_t j = 0; j < got.size(); ++j) {
            if (got[j].MPI_ERROR == MPI_ERR_TRUNCATE) throw MessageTooLong(j, (*x.in)[j].size());
        }
    }
    check(rc, "MPI_Waitall");
    for (std::size_t j = 0; j < got.size(); ++j) {  // a posted receive got a shorter message: its size
        if ((*x.from)[j] < 0 || (*x.in)[j].empty()) continue;
        int n = 0;
        if (got[j].MPI_SOURCE == (*x.from)[j] && MPI_Get_count(&got[j], MPI_BYTE, &n) == MPI_SUCCESS &&
            static_cast<std::size_t>(n) < (*x.in)[j].size()) {
            (*x.in)[j].resize(static_cast<std::size_t>(n));
        }
    }
    hold_until(x.began);
}

void Comm::hold_until(double since) const {
    if (latency_ <= 0) return;
    while (now_seconds() < since + latency_) {
    }
}

namespace {

// Every process agrees whether an MPI-IO call failed anywhere.
void io_check(int rc, const std::string& path, const char* what) {
    int bad = rc != MPI_SUCCESS ? 1 : 0;
    MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (bad) throw OutputError(path + ": " + what + " failed on at least one process");
}

// Records [first, first + n) of `f` through a view of their places and one
// collective write (n may be 0: this process then takes part with nothing).
int write_records(MPI_File fh, MPI_Datatype rec, const FilePieces& f, std::size_t first, std::size_t n, char* piece) {
    if (n > 0) f.pack(first, n, piece);
    std::vector<int> at(f.gids.begin() + static_cast<std::ptrdiff_t>(first),
                        f.gids.begin() + static_cast<std::ptrdiff_t>(first + n));
    MPI_Datatype view = rec;
    if (n > 0) {
        MPI_Type_create_indexed_block(static_cast<int>(n), 1, at.data(), rec, &view);
        MPI_Type_commit(&view);
    }
    int rc = MPI_File_set_view(fh, static_cast<MPI_Offset>(f.records_at), rec, view, "native", MPI_INFO_NULL);
    if (rc == MPI_SUCCESS) rc = MPI_File_write_all(fh, piece, static_cast<int>(n), rec, MPI_STATUS_IGNORE);
    if (n > 0) MPI_Type_free(&view);
    return rc;
}

// This process's tail from `at` (after the previous ranks' tails), a piece
// a round for `rounds` rounds (every process's count: the longest tail's).
int write_tails(MPI_File fh, const FilePieces& f, MPI_Offset at, std::uint64_t rounds, std::vector<char>& piece) {
    piece.resize(std::max(piece.size(), std::min(f.tail_count, f.piece) * f.tail_record));
    int rc = MPI_File_set_view(fh, 0, MPI_BYTE, MPI_BYTE, "native", MPI_INFO_NULL);
    for (std::uint64_t r = 0; r < rounds; ++r) {
        const auto [first, n] = piece_of_round(r, f.tail_count, f.piece);
        if (n > 0) f.pack_tail(first, n, piece.data());
        const int rr = MPI_File_write_at_all(fh, at + static_cast<MPI_Offset>(first * f.tail_record), piece.data(),
                                             static_cast<int>(n * f.tail_record), MPI_BYTE, MPI_STATUS_IGNORE);
        if (rc == MPI_SUCCESS) rc = rr;
    }
    return rc;
}

}  // namespace

void Comm::write_file(const std::string& path, const FilePieces& f) const {
    Clock c(stats_);
    MPI_File fh;
    MPI_File_set_errhandler(MPI_FILE_NULL, MPI_ERRORS_RETURN);
    io_check(MPI_File_open(MPI_COMM_WORLD, path.c_str(), MPI_MODE_CREATE | MPI_MODE_WRONLY, MPI_INFO_NULL, &fh), path,
             "opening for writing");
    int rc = MPI_File_set_size(fh, 0);
    if (rank_ == 0 && rc == MPI_SUCCESS && !f.head.empty()) {
        rc = MPI_File_write_at(fh, 0, f.head.data(), static_cast<int>(f.head.size()), MPI_BYTE, MPI_STATUS_IGNORE);
    }
    MPI_Datatype rec;
    MPI_Type_contiguous(static_cast<int>(f.record), MPI_BYTE, &rec);
    MPI_Type_commit(&rec);
    std::uint64_t rounds[2] = {(f.gids.size() + f.piece - 1) / f.piece, (f.tail_count + f.piece - 1) / f.piece};
    max(rounds, 2);  // every process in every round's collective write
    std::vector<char> piece(std::max<std::size_t>(1, std::min(f.gids.size(), f.piece) * f.record));  // reused by the tails
    int rc2 = MPI_SUCCESS;
    for (std::uint64_t r = 0; r < rounds[0]; ++r) {
        const auto [first, n] = piece_of_round(r, f.gids.size(), f.piece);
        const int rr = write_records(fh, rec, f, first, n, piece.data());
        if (rc2 == MPI_SUCCESS) rc2 = rr;
    }
    long long mine = static_cast<long long>(f.tail_count * f.tail_record), before = 0;
    MPI_Exscan(&mine, &before, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    if (rank_ == 0) before = 0;
    const int rc3 = write_tails(fh, f, static_cast<MPI_Offset>(f.tail_at) + before, rounds[1], piece);
    MPI_Type_free(&rec);
    const int rc5 = MPI_File_sync(fh);  // on the disk before the caller renames the file into place
    const int rc4 = MPI_File_close(&fh);
    stats_.bytes += f.head.size() + f.gids.size() * f.record + f.tail_count * f.tail_record;
    io_check(rc != MPI_SUCCESS    ? rc
             : rc2 != MPI_SUCCESS ? rc2
             : rc3 != MPI_SUCCESS ? rc3
             : rc5 != MPI_SUCCESS ? rc5
                                  : rc4,
             path, "writing");
}

#ifdef PARODE_HAVE_HDF5
static_assert(std::is_same_v<hid_t, std::int64_t>, "Domain::h5_parallel passes hid_t as int64_t (HDF5 1.10+)");

// Independent transfers: each process's selection is already one contiguous
// run of ids per dataset (block_rows did the aggregation), so collective
// buffering would only shuffle the data a second time and make every write
// wait for every process (measured at 10^6 bodies on 2 ranks: 0.6 to 1.3 s
// a frame collective, 0.1 s independent). Creating and growing datasets
// stays collective, as parallel HDF5 requires.
void Comm::h5_parallel(std::int64_t file_access, std::int64_t transfer) const {
    if (H5Pset_fapl_mpio(file_access, MPI_COMM_WORLD, MPI_INFO_NULL) < 0 ||
        H5Pset_dxpl_mpio(transfer, H5FD_MPIO_INDEPENDENT) < 0) {
        throw std::runtime_error("HDF5 cannot use MPI-IO (H5Pset_fapl_mpio)");
    }
}
#else
void Comm::h5_parallel(std::int64_t, std::int64_t) const { throw std::logic_error("parode was built without HDF5"); }
#endif

void Comm::abort(int code) const { MPI_Abort(MPI_COMM_WORLD, code); std::abort(); }

double Comm::ping_pong_latency(int rounds, std::size_t bytes) const {
    Bytes msg(std::max<std::size_t>(bytes, 1), 0);
    const int n = static_cast<int>(msg.size());
    MPI_Barrier(MPI_COMM_WORLD);
    const double t0 = MPI_Wtime();
    for (int r = 0; r < rounds && size_ > 1; ++r) {
        if (rank_ == 0) {
            MPI_Send(msg.data(), n, MPI_BYTE, 1, 99, MPI_COMM_WORLD);
            MPI_Recv(msg.data(), n, MPI_BYTE, 1, 99, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
        } else if (rank_ == 1) {
            MPI_Recv(msg.data(), n, MPI_BYTE, 0, 99, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
            MPI_Send(msg.data(), n, MPI_BYTE, 0, 99, MPI_COMM_WORLD);
        }
    }
    double t = (MPI_Wtime() - t0) / (2.0 * rounds);
    MPI_Bcast(&t, 1, MPI_DOUBLE, 0, MPI_COMM_WORLD);
    return t;
}

double Comm::exchange_round(int rounds, std::size_t bytes) const {
    std::vector<int> others;
    for (int r = 0; r < size_; ++r) {
        if (r != rank_) others.push_back(r);
    }
    const std::vector<Bytes> out(others.size(), Bytes(bytes, 0));
    std::vector<Bytes> in;
    MPI_Barrier(MPI_COMM_WORLD);
    const double t0 = MPI_Wtime();
    for (int r = 0; r < rounds; ++r) exchange(others, out, others, in, 98);
    double t = (MPI_Wtime() - t0) / rounds;
    MPI_Allreduce(MPI_IN_PLACE, &t, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    return t;
}

}  // namespace parode::mpi
