// The distributed domain on two processes, unit by unit (run under mpiexec
// -n 2; the back-to-back sparse exchanges also on 4): after setup every body
// has exactly one owner and sits in one of its owner's cells; a body moved
// into the other process's cells migrates there with its state bit for bit
// and its warm-start impulses, and the old owner keeps neither; the
// invariant check passes, and fails on every process when one process
// claims a body it does not own; the solver's exchange partners are every
// holder of a body held here, also one way; the solve's correction exchange delivers
// the other's corrections and stops both processes on a message of the
// wrong size; the collectives' sparse exchange delivers only what was sent,
// to the call that sent it.
// Trade-off: a custom main brings MPI up around GoogleTest; every process
// runs every test, and a failure on either fails the run.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>

#include "comm.hpp"
#include "domain/cells.hpp"
#include "mpi_domain.hpp"
#include "run/pipeline.hpp"
#include "scene/scene_file.hpp"

using namespace parode;

namespace {

const mpi::Comm* g_comm = nullptr;
Execution* g_exec = nullptr;  // one thread, the serial loops

Scene slab() {
    return load_scene_text("[scene]\nname = \"slab\"\n[catoms]\ncount = 512\n[[planes]]\nnormal = [0.0, 0.0, 1.0]\n", "slab");
}

// The slab distributed over the processes: a domain, this process's world
// (owned bodies and ghosts) and its warm impulses, set up; without them
// (`with_warm` false) as for a solver that keeps none.
struct SlabDomain {
    Scene sc = slab();
    mpi::MpiDomain d{sc, *g_exec};
    std::vector<std::uint32_t> ids = d.initial_bodies(sc);
    World w{sc, SpaceKind::Simple, &ids};
    std::vector<WarmImpulse> warm;
    explicit SlabDomain(bool with_warm = true) { d.setup(w, with_warm ? &warm : nullptr); }
};

std::int64_t owned_everywhere(const World& w) {
    std::int64_t n = static_cast<std::int64_t>(w.owned_count());
    g_comm->sum(&n, 1);
    return n;
}

// Every body this process owns lies in one of its cells.
void expect_owned_in_own_cells(const Scene& sc, const mpi::MpiDomain& d, const World& w) {
    const CellSpace cells(sc);
    for (std::size_t i = 0; i < w.body_count(); ++i) {
        if (w.ghost(i)) continue;
        EXPECT_EQ(d.cell_map().owner(cells.key(dBodyGetPosition(w.body(i)))), d.rank()) << "body " << w.gid(i);
    }
}

TEST(MpiDomain, SetupGivesEveryBodyOneOwnerInItsCells) {
    SlabDomain slab_run;
    const Scene& sc = slab_run.sc;
    mpi::MpiDomain& d = slab_run.d;
    World& w = slab_run.w;
    EXPECT_EQ(owned_everywhere(w), 512);
    expect_owned_in_own_cells(sc, d, w);
    EXPECT_GT(w.body_count(), w.owned_count()) << "each process holds ghosts of the other's boundary";
    EXPECT_NO_THROW(d.check_invariants(w, 0));
    EXPECT_EQ(d.migrations(), 0) << "a fresh scene's bodies are built by their owners, none moves at setup";
}

// A world built from blocks of ids, not from initial_bodies (no partition
// yet): setup partitions and moves the bodies to the owners of their cells.
TEST(MpiDomain, BlocksOfIdsMoveToTheirOwnersAtSetup) {
    const Scene sc = slab();
    mpi::MpiDomain d{sc, *g_exec};
    const std::vector<std::uint32_t> ids = d.block(sc);
    World w{sc, SpaceKind::Simple, &ids};
    d.setup(w, nullptr);
    EXPECT_EQ(owned_everywhere(w), 512);
    expect_owned_in_own_cells(sc, d, w);
    std::int64_t moved = d.migrations();
    g_comm->sum(&moved, 1);
    EXPECT_GT(moved, 0) << "the slab's halves by id are not its METIS parts";
    EXPECT_NO_THROW(d.check_invariants(w, 0));
}

// A cell of the other process, and a point inside it.
std::array<double, 3> point_of_other(const mpi::MpiDomain& d, const CellSpace& cells) {
    const auto& keys = d.cell_map().keys();
    const auto& owners = d.cell_map().owners();
    for (std::size_t i = 0; i < keys.size(); ++i) {
        if (owners[i] == d.rank()) continue;
        std::array<double, 3> x{};
        for (int a = 0; a < 3; ++a) {
            const double q = static_cast<double>(CellSpace::coord(keys[i], a)) - static_cast<double>(CellSpace::kBias);
            x[static_cast<std::size_t>(a)] = (q + 0.5) * cells.edge();
        }
        return x;
    }
    return {0, 0, 0};
}

TEST(MpiDomain, MovedBodyMigratesWithStateAndImpulses) {
    SlabDomain slab_run;
    const Scene& sc = slab_run.sc;
    mpi::MpiDomain& d = slab_run.d;
    World& w = slab_run.w;
    std::vector<WarmImpulse>& warm = slab_run.warm;
    const CellSpace cells(sc);
    // The owner of body 100 moves it into a cell of the other process.
    const std::uint32_t gid = 100;
    std::uint32_t local = w.local_of(gid);
    const bool mine = local != IdMap::kNone && !w.ghost(local);
    BodyState moved{};
    if (mine) {
        moved = w.state(local);
        const auto x = point_of_other(d, cells);
        std::copy(x.begin(), x.end(), moved.x);
        moved.v[0] = 0.125;
        w.set_state(local, moved);
        warm = {WarmImpulse{gid, 200, 0, {1.5, 0.25, -0.25}}, WarmImpulse{gid, 300, 1, {2.5, 0, 0}}};
    }
    std::int64_t owners = mine ? 1 : 0;
    g_comm->sum(&owners, 1);
    ASSERT_EQ(owners, 1);
    d.migrate(w, &warm, 1);
    d.exchange_states(w);
    local = w.local_of(gid);
    const bool now_mine = local != IdMap::kNone && !w.ghost(local);
    EXPECT_NE(mine, now_mine) << "the body changed owner";
    if (now_mine) {
        const BodyState s = w.state(local);
        EXPECT_EQ(s.x[0], dBodyGetPosition(w.body(local))[0]);
        EXPECT_EQ(s.v[0], 0.125);
        ASSERT_EQ(warm.size(), 2u);
        EXPECT_EQ(warm[0].hi, 200u);
        EXPECT_EQ(warm[1].lambda[0], 2.5);
    } else {
        EXPECT_TRUE(warm.empty()) << "the impulses left with the body";
    }
    EXPECT_EQ(owned_everywhere(w), 512);
    EXPECT_NO_THROW(d.check_invariants(w, 1));
}

// The solver's exchange partners: every process that holds a copy of a body
// held here, also when the copies go one way only. Here process 1 gives up
// its bodies, so process 0 holds no ghost but still sends its boundary's
// bodies to 1, and must hear 1's corrections of them.
TEST(MpiDomain, PartnersAreEveryHolderOfABodyHeldHereAlsoOneWay) {
    SlabDomain slab_run(false);
    mpi::MpiDomain& d = slab_run.d;
    World& w = slab_run.w;
    ASSERT_EQ(d.ranks(), 2) << "run on two processes";
    std::array<std::int64_t, 2> ghosts{};  // held on each process: copies of the other's bodies
    auto count_ghosts = [&] {
        ghosts = {0, 0};
        for (std::size_t i = 0; i < w.body_count(); ++i) ghosts[static_cast<std::size_t>(d.rank())] += w.ghost(i) ? 1 : 0;
        g_comm->sum(ghosts.data(), 2);
    };
    const std::vector<int> other{1 - d.rank()};
    count_ghosts();
    ASSERT_GT(ghosts[0] * ghosts[1], 0) << "both processes hold copies of the other's boundary";
    EXPECT_EQ(d.partners(), other) << "after setup";
    if (d.rank() == 1) {
        for (std::size_t i = w.body_count(); i-- > 0;) w.remove_body(i);
    }
    d.exchange_states(w);
    count_ghosts();
    ASSERT_EQ(ghosts[0], 0) << "process 1 owns nothing to copy";
    ASSERT_GT(ghosts[1], 0) << "process 0 still sends its boundary";
    EXPECT_EQ(d.partners(), other) << "after process 1 gave up its bodies";
}

TEST(MpiDomain, InvariantCheckFailsOnEveryProcess) {
    SlabDomain slab_run(false);
    mpi::MpiDomain& d = slab_run.d;
    World& w = slab_run.w;
    if (d.rank() == 1) {  // claim a ghost: that body now has two owners
        for (std::size_t i = 0; i < w.body_count(); ++i) {
            if (!w.ghost(i)) continue;
            w.set_ghost(i, false);
            break;
        }
    }
    EXPECT_THROW(d.check_invariants(w, 7), SimulationError);
}

// The solve's correction exchange between the two processes: each receives
// the other's corrections of the bodies both hold; and when the two disagree
// about which message of a colour carries the ids (here one process forgets
// it named them, so it names its bodies a second time), each stops with an
// error that names both ranks and the sizes, instead of reading past a
// message or applying the wrong bytes.
TEST(MpiDomain, CorrectionMessagesOfTheWrongSizeStopBothProcesses) {
    SlabDomain slab_run(false);
    mpi::MpiDomain& d = slab_run.d;
    World& w = slab_run.w;
    const int other = 1 - d.rank();
    std::vector<BodyRow> rows(w.body_count());
    std::vector<std::uint32_t> slot(w.body_count());
    std::vector<std::vector<std::uint32_t>> touched(1);
    for (std::uint32_t i = 0; i < w.body_count(); ++i) {
        slot[i] = i;
        touched[0].push_back(i);
        for (int k = 0; k < 6; ++k) rows[i].fc[k] = w.gid(i) + 0.1 * (d.rank() + 1) + k;
    }
    const CorrectionView fc(rows.data(), slot.data());
    d.plan(touched);
    d.exchange(0, fc);
    std::int64_t shared = 0;
    for (std::uint32_t i = 0; i < w.body_count(); ++i) {
        if (rows[i].fc[0] == w.gid(i) + 0.1 * (other + 1)) ++shared;
    }
    g_comm->sum(&shared, 1);
    ASSERT_GT(shared, 0) << "the processes share bodies and exchanged their corrections";
    if (d.rank() == 1) d.restart_names();  // rank 1 names its bodies again; rank 0 does not expect it
    try {
        d.exchange(0, fc);
        FAIL() << "rank " << d.rank() << ": a message of the wrong size was read";
    } catch (const std::runtime_error& e) {
        const std::string m = e.what();
        EXPECT_NE(m.find("rank " + std::to_string(d.rank()) + ": a correction message from rank " + std::to_string(other)),
                  std::string::npos) << m;
        EXPECT_NE(m.find(" expected"), std::string::npos) << m;
    }
}

// The sparse exchange of the collectives: only the non-empty buffers travel;
// each process gets them at their sender's rank, its own buffer at its own,
// and nothing from a process that sent it nothing; two exchanges on different
// channels back to back keep their messages apart.
TEST(MpiCollectives, SparseExchangeDeliversOnlyWhatWasSent) {
    const mpi::MpiCollectives c(*g_comm);
    const int me = c.rank(), other = 1 - me;
    for (int round = 0; round < 3; ++round) {
        std::vector<std::vector<char>> a(2), b(2);
        a[static_cast<std::size_t>(me)] = {'s', static_cast<char>('0' + me)};
        if (me == 0 || round == 1) a[static_cast<std::size_t>(other)] = {'a', static_cast<char>('0' + me), static_cast<char>(round)};
        b[static_cast<std::size_t>(other)] = {'b', static_cast<char>('0' + me)};
        const auto ina = c.sparse_to(a, 0);
        const auto inb = c.sparse_to(b, 1);
        ASSERT_EQ(ina.size(), 2u);
        EXPECT_EQ(ina[static_cast<std::size_t>(me)], a[static_cast<std::size_t>(me)]);
        const std::vector<char> want_a = (other == 0 || round == 1)
                                              ? std::vector<char>{'a', static_cast<char>('0' + other), static_cast<char>(round)}
                                              : std::vector<char>{};
        EXPECT_EQ(ina[static_cast<std::size_t>(other)], want_a) << "round " << round;
        EXPECT_EQ(inb[static_cast<std::size_t>(other)], (std::vector<char>{'b', static_cast<char>('0' + other)}));
    }
    EXPECT_THROW(c.sparse_to(std::vector<std::vector<char>>(2), 4), std::logic_error);
}

// The span form: messages read in place from the sender's buffer and landed
// in the receiver's lent buffer while they fit, each later one in a buffer
// of its own; sorted by source either way, every byte as sent.
TEST(MpiComm, SparseExchangeLandsInTheLentBufferThenSpills) {
    const mpi::Comm& comm = *g_comm;
    const int me = comm.rank(), other = 1 - me;
    const auto bytes = [](int from, std::size_t n) {
        std::vector<char> b(n);
        for (std::size_t k = 0; k < n; ++k) b[k] = static_cast<char>((from * 131 + static_cast<int>(k) * 7) % 251);
        return b;
    };
    for (const std::size_t room : {std::size_t{0}, std::size_t{99}, std::size_t{100}, std::size_t{4096}}) {
        const std::vector<char> mine = bytes(me, 100);
        std::vector<char> lent(4096, 0);
        mpi::Landing landing{lent.data(), room, 0, {}};
        const auto in = comm.sparse_exchange({{other, mine.data(), mine.size()}}, landing, 3);
        ASSERT_EQ(in.size(), 1u) << "room " << room;
        EXPECT_EQ(in[0].rank, other);
        EXPECT_EQ(std::vector<char>(in[0].data, in[0].data + in[0].size), bytes(other, 100)) << "room " << room;
        const bool fits = room >= 100;
        EXPECT_EQ(in[0].data == lent.data(), fits) << "room " << room;
        EXPECT_EQ(landing.spill.size(), fits ? 0u : 1u) << "room " << room;
        EXPECT_EQ(landing.used, fits ? 100u : 0u) << "room " << room;
    }
}

// A file of every process: records and tails made piece by piece, two a
// round, by processes that need 2 and 4 rounds of records and 1 and 3 of
// tails (the one with fewer takes part in the other's rounds with nothing);
// the file is head, records by gid, tails in rank order, byte for byte.
TEST(MpiCollectives, FileRecordsGoPieceByPieceInEveryRound) {
    const mpi::MpiCollectives c(*g_comm);
    const int me = c.rank();
    const std::vector<std::uint32_t> gids = me == 0 ? std::vector<std::uint32_t>{0, 2, 3, 9}
                                                    : std::vector<std::uint32_t>{1, 4, 5, 6, 7, 8, 10};
    const auto record = [](std::uint32_t g) { return std::string("rec") + static_cast<char>('A' + g) + "0123"; };
    FilePieces f;
    f.head = me == 0 ? std::vector<char>{'H', 'E', 'A', 'D'} : std::vector<char>{};
    f.records_at = 4;
    f.record = 8;
    f.gids = gids;
    f.piece = 2;
    int packed = 0;
    f.pack = [&](std::size_t first, std::size_t n, char* out) {
        ASSERT_LE(n, 2u);
        packed += static_cast<int>(n);
        for (std::size_t k = 0; k < n; ++k) std::memcpy(out + 8 * k, record(gids[first + k]).data(), 8);
    };
    f.tail_at = 4 + 11 * 8;
    const std::string tail = me == 0 ? "t0" : "t1!xy";  // tails of 1 and 3 rounds
    f.tail_count = tail.size();
    f.pack_tail = [&](std::size_t first, std::size_t n, char* out) {
        ASSERT_LE(n, 2u);
        std::memcpy(out, tail.data() + first, n);
    };
    const std::string path = "mpi_file_pieces.bin";
    c.write_file(path, f);
    EXPECT_EQ(packed, static_cast<int>(gids.size()));
    if (me != 0) return;
    std::string want = "HEAD";
    for (std::uint32_t g = 0; g < 11; ++g) want += record(g);
    want += "t0t1!xy";
    std::ifstream in(path, std::ios::binary);
    const std::string got((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(got, want);
    std::remove(path.c_str());
}

// Calls on one channel back to back, every process sending to the last (as a
// checkpoint's pieces of catom records): each call gets its own round's
// messages only, although a process that saw a call end may send the next
// call's while the last one still probes for this one's.
TEST(MpiCollectives, BackToBackCallsOnOneChannelKeepTheirRounds) {
    const mpi::MpiCollectives c(*g_comm);
    const int last = c.ranks() - 1;
    int wrong = 0;
    const auto piece = [](int round, int from) {  // large: received while the sender may be done
        std::vector<char> p(std::size_t{1} << 16, static_cast<char>(from));
        p[0] = static_cast<char>(round % 100);
        return p;
    };
    for (int round = 0; round < 4000; ++round) {
        std::vector<std::vector<char>> out(static_cast<std::size_t>(c.ranks()));
        if (c.rank() != last) out[static_cast<std::size_t>(last)] = piece(round, c.rank());
        const auto in = c.sparse_to(out, 2);
        if (c.rank() != last) continue;
        for (int r = 0; r < last; ++r) wrong += in[static_cast<std::size_t>(r)] != piece(round, r);
    }
    EXPECT_EQ(wrong, 0) << "messages taken for another call's";
}

}  // namespace

int main(int argc, char** argv) {
    mpi::Session session(argc, argv);
    mpi::Comm comm;
    g_comm = &comm;
    Execution exec;
    g_exec = &exec;
    ::testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}
