// The distributed domain (see mpi_domain.hpp).
#include "mpi_domain.hpp"

#include <algorithm>
#include <cstring>
#include <map>
#include <sstream>
#include <stdexcept>

#include "domain/distribution.hpp"
#include "cut_tree.hpp"
#include "partition.hpp"
#include "observe/diagnostics.hpp"
#include "util/errors.hpp"
#include "scene/toml_reader.hpp"
#include "exec/execution.hpp"
#include "util/split_mix.hpp"
#include "util/substages.hpp"

namespace parode::mpi {
namespace {

Vec3 position(const World& w, std::size_t i) {
    const dReal* x = dBodyGetPosition(w.body(i));
    return {x[0], x[1], x[2]};
}

// Orders impulses and lower ids (equal_range over a vector sorted by lo).
struct ByLo {
    bool operator()(const WarmImpulse& m, std::uint32_t g) const { return m.lo < g; }
    bool operator()(std::uint32_t g, const WarmImpulse& m) const { return g < m.lo; }
};

// The run of `warm` (sorted by lower id) whose lower body is `gid`; empty
// without impulses.
std::pair<std::size_t, std::size_t> impulses_of(const std::vector<WarmImpulse>* warm, std::uint32_t gid) {
    if (!warm) return {0, 0};
    const auto range = std::equal_range(warm->begin(), warm->end(), gid, ByLo{});
    return {static_cast<std::size_t>(range.first - warm->begin()), static_cast<std::size_t>(range.second - warm->begin())};
}

// Drops the impulses flagged in `gone`, keeping the order of the rest: one
// pass, however many bodies left (erasing each body's run as it left moved
// the whole tail each time: minutes when a restart or a repartition moves
// half a million bodies).
void drop_impulses(std::vector<WarmImpulse>& warm, const std::vector<unsigned char>& gone) {
    std::size_t keep = 0;
    for (std::size_t k = 0; k < warm.size(); ++k) {
        if (!gone[k]) warm[keep++] = warm[k];
    }
    warm.resize(keep);
}

// `warm` sorted again after impulses were appended from `first` on: the
// arrivals sorted alone and merged in (std::inplace_merge, whose buffer is
// the smaller part's), not the whole vector sorted again: a full sort of a
// rank's 1.7 million impulses was 3 % of a step on 4 ranks of 10^6 catoms,
// every step a body crossed a cut; a full sort if what was there was not
// sorted.
void sort_impulses(std::vector<WarmImpulse>& warm, std::size_t first) {
    const auto mid = warm.begin() + static_cast<std::ptrdiff_t>(first);
    if (mid == warm.end()) return;
    if (!std::is_sorted(warm.begin(), mid, warm_less)) {
        std::sort(warm.begin(), warm.end(), warm_less);
        return;
    }
    std::sort(mid, warm.end(), warm_less);
    std::inplace_merge(warm.begin(), mid, warm.end(), warm_less);
}

}  // namespace

MpiDomain::MpiDomain(const Scene& scene, Execution& exec)
    : scene_(scene), loops_(exec.loops()), scratch_(&exec.scratch()), cells_(scene), reach_(halo_reach(scene)) {
    nbr_index_.assign(static_cast<std::size_t>(comm_.size()), -1);
}

void MpiDomain::check_scene(const Scene& sc, const std::string& /*collide*/, const std::string& solver) const {
    const DistributionVerdict v = distribution_verdict(sc, solver, ranks(), cells_.edge());
    if (v.ok) return;
    if (v.option_error) throw std::invalid_argument(v.reason);
    throw SceneError(v.reason);
}

std::vector<std::uint32_t> MpiDomain::block(const Scene& scene) const {
    const std::uint64_t n = scene.body_count(), r = static_cast<std::uint64_t>(rank()), p = static_cast<std::uint64_t>(ranks());
    std::vector<std::uint32_t> ids;
    for (std::uint64_t id = n * r / p; id < n * (r + 1) / p; ++id) ids.push_back(static_cast<std::uint32_t>(id));
    return ids;
}

// Collective: each process weighs the cells of a block of ids at their scene
// positions, the cells are partitioned as in a repartition, and each id goes
// to the owner of its cell (4 bytes an id, instead of a body's state and
// impulses after it was built: at 10^6 catoms on 2 processes, setup moved
// 496,568 bodies so).
std::vector<std::uint32_t> MpiDomain::initial_bodies(const Scene& /*scene*/, const std::vector<std::uint32_t>& block,
                                                     const std::vector<Vec3>& positions) {
    std::vector<std::uint64_t> key(block.size());
    std::vector<CellLoad> mine;
    mine.reserve(block.size());
    for (std::size_t k = 0; k < block.size(); ++k) {
        key[k] = cells_.key(positions[k].data());
        mine.push_back({key[k], 1, 1});
    }
    partition(merge_cells(std::move(mine)));
    std::vector<Bytes> out(static_cast<std::size_t>(ranks()));
    for (std::size_t k = 0; k < block.size(); ++k) put(out[static_cast<std::size_t>(map_.owner(key[k]))], block[k]);
    std::vector<std::uint32_t> ids;
    for (const Bytes& b : comm_.all_to_all(out)) {
        for (std::size_t at = 0; at < b.size();) ids.push_back(take<std::uint32_t>(b, at));
    }
    std::sort(ids.begin(), ids.end());
    partitioned_ = true;
    return ids;
}

std::string MpiDomain::why() const { return distributed_why(ranks(), cells_.edge()); }

std::vector<std::vector<char>> MpiCollectives::sparse_to(const std::vector<std::vector<char>>& out, int channel) const {
    constexpr int kTagSparse = 40;  // 40-43: apart from the domain's tags
    if (channel < 0 || channel > 3) throw std::logic_error("sparse_to: channel " + std::to_string(channel) + " (0-3)");
    std::map<int, Bytes> send;
    for (int r = 0; r < ranks(); ++r) {
        if (r != rank() && !out[static_cast<std::size_t>(r)].empty()) send.emplace(r, out[static_cast<std::size_t>(r)]);
    }
    std::vector<std::vector<char>> in(static_cast<std::size_t>(ranks()));
    in[static_cast<std::size_t>(rank())] = out[static_cast<std::size_t>(rank())];
    for (auto& [from, bytes] : comm_.sparse_exchange(send, kTagSparse + channel)) in[static_cast<std::size_t>(from)] = std::move(bytes);
    return in;
}

void MpiDomain::setup(World& world, std::vector<WarmImpulse>* warm) {
    world_ = &world;
    std::uint64_t ids = 0;  // the sum of every mixed gid, for the invariant check
    for (std::size_t i = 0; i < world.body_count(); ++i) ids += SplitMix64::mix(world.gid(i));
    comm_.sum_wrapping(&ids, 1);
    id_hash_ = ids;
    if (!partitioned_) repartition(world, warm);  // a restart: positions from the checkpoint
    locate_all(world);
    move_bodies(world, warm);
    exchange_states(world);
}

// Collective: the root gathers every process's occupied cells, partitions
// them and sends the map back.
void MpiDomain::repartition(const World& world, const std::vector<WarmImpulse>* warm) {
    std::vector<CellLoad> mine;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (world.ghost(i)) continue;
        const Vec3 x = position(world, i);
        const auto [first, last] = impulses_of(warm, world.gid(i));
        mine.push_back({cells_.key(x.data()), static_cast<std::int64_t>(1 + last - first), 1});
    }
    partition(merge_cells(std::move(mine)));
}

// Collective: the cells are partitioned, by the root from all of them up to
// kGatherUnits occupied cells (or always for METIS), else by every process
// together (the bisection's tree, partition.hpp).
void MpiDomain::partition(std::vector<CellLoad> cells) {
    std::int64_t occupied = static_cast<std::int64_t>(cells.size());
    comm_.sum(&occupied, 1);
    const std::string& who = scene_.parallel.partitioner;
    const bool together = occupied >= 4 * std::int64_t{ranks()} &&
                          (who == "bisection" || (who == "best" && occupied > kGatherUnits));
    const double t0 = now_seconds();
    if (together) cut_together(cells);
    else gather_and_cut(cells, occupied);
    partition_seconds_ += now_seconds() - t0;
    together_ = together;
    ++epoch_;  // every body's cached owner and holders belong to the old map
}

namespace {

// build_cut_tree's reductions over every process.
class CommReductions : public Reductions {
public:
    explicit CommReductions(const Comm& comm) : comm_(comm) {}
    void sum(std::int64_t* v, int n) override { comm_.sum(v, n); }
    void min(std::uint64_t* v, int n) override { comm_.min(v, n); }
    void max(std::uint64_t* v, int n) override { comm_.max(v, n); }

private:
    const Comm& comm_;
};

}  // namespace

// Collective: the bisection's tree from every process's own cells; its
// balance from each part's work summed over processes; each part to the
// process holding most of its work now (keep_owners's rule, from the
// processes' overlaps alone, gathered: a few entries each).
void MpiDomain::cut_together(const std::vector<CellLoad>& cells) {
    CommReductions reduce(comm_);
    CutTree tree = build_cut_tree(cells, ranks(), reduce);
    const auto np = static_cast<std::size_t>(ranks());
    std::vector<std::int64_t> work(np * 9, 0);  // each part's work by colour (part * 8 + colour), then in all
    std::map<int, std::int64_t> here;           // this process's work in each part
    for (const CellLoad& c : cells) {
        const auto part = static_cast<std::size_t>(tree.part(c.key));
        const std::array<std::int64_t, 8> w = colour_work(c);
        for (std::size_t k = 0; k < 8; ++k) work[part * 8 + k] += w[k];
        work[np * 8 + part] += c.work;
        here[static_cast<int>(part)] += c.work;
    }
    comm_.sum(work.data(), static_cast<int>(work.size()));  // one reduction for both
    const auto split = work.begin() + static_cast<std::ptrdiff_t>(np * 8);
    balance_of(std::vector<std::int64_t>(split, work.end()), std::vector<std::int64_t>(work.begin(), split),
               partition_imbalance_, partition_colour_imbalance_);
    Bytes mine;
    for (const auto& [part, w] : here) put(mine, Overlap{w, part, rank()});
    const auto all = comm_.gather(mine, 0);
    Bytes result;
    if (comm_.rank() == 0) {
        std::vector<Overlap> o;
        for (const Bytes& b : all) {
            for (std::size_t at = 0; at < b.size();) o.push_back(take<Overlap>(b, at));
        }
        for (int r : ranks_by_overlap(std::move(o), ranks())) put(result, static_cast<std::int32_t>(r));
    }
    comm_.broadcast(result, 0);
    std::vector<int> rank_of(np);
    std::size_t at = 0;
    for (int& r : rank_of) r = take<std::int32_t>(result, at);
    tree_nodes_ = static_cast<std::int64_t>(tree.nodes().size());
    map_.assign(std::move(tree), std::move(rank_of));
    bisection_ = true;
    edge_cut_ = -1;  // the edges between cells are not seen whole anywhere
}

// Collective: the root gathers every process's cells (merged), partitions
// them, keeps parts on the processes that hold most of them (keep_owners) and
// sends the map back.
void MpiDomain::gather_and_cut(const std::vector<CellLoad>& cells, std::int64_t occupied) {
    // Blocks of cells, summed here: what reaches the root grows with the
    // machine 64 times slower than the cells (partition.hpp: block_edge).
    const int edge = block_edge(occupied, ranks());
    const std::vector<CellLoad> mine = coarsen(cells, edge);
    Bytes packed(mine.size() * sizeof(CellLoad));
    if (!mine.empty()) std::memcpy(packed.data(), mine.data(), packed.size());
    const auto parts = comm_.gather(packed, 0);
    Bytes result;
    if (comm_.rank() == 0) {
        std::vector<std::vector<CellLoad>> held(parts.size());
        std::vector<CellLoad> all;
        for (std::size_t r = 0; r < parts.size(); ++r) {
            held[r].resize(parts[r].size() / sizeof(CellLoad));
            if (!held[r].empty()) std::memcpy(held[r].data(), parts[r].data(), parts[r].size());
            all.insert(all.end(), held[r].begin(), held[r].end());
        }
        const std::string& who = scene_.parallel.partitioner;
        Partition p = partition_cells(merge_cells(std::move(all)), ranks(),
                                      scene_.parallel.balance_colours ? Balance::Colours : Balance::Total,
                                      who == "metis" ? Partitioner::Metis : who == "bisection" ? Partitioner::Bisection
                                                                                              : Partitioner::Best);
        keep_owners(p, held, ranks());
        put(result, static_cast<std::int32_t>(p.bisection));
        put(result, static_cast<std::uint64_t>(p.keys.size()));
        put(result, p.edge_cut);
        put(result, p.imbalance);
        put(result, p.colour_imbalance);
        for (std::size_t i = 0; i < p.keys.size(); ++i) {
            put(result, p.keys[i]);
            put(result, static_cast<std::int32_t>(p.owner[i]));
        }
    }
    comm_.broadcast(result, 0);
    std::size_t at = 0;
    bisection_ = take<std::int32_t>(result, at) != 0;
    const auto n = take<std::uint64_t>(result, at);
    edge_cut_ = take<std::int64_t>(result, at);
    partition_imbalance_ = take<double>(result, at);
    partition_colour_imbalance_ = take<double>(result, at);
    std::vector<std::uint64_t> keys(n);
    std::vector<int> owners(n);
    for (std::uint64_t i = 0; i < n; ++i) {
        keys[i] = take<std::uint64_t>(result, at);
        owners[i] = take<std::int32_t>(result, at);
    }
    map_.assign(std::move(keys), std::move(owners), ranks(), edge);
    tree_nodes_ = 0;
}

// Collective: max over processes of (owned bodies + contacts) / the mean.
double MpiDomain::load_imbalance(const World& world, const std::vector<WarmImpulse>* warm) const {
    const double load = static_cast<double>(world.owned_count() + (warm ? warm->size() : 0));
    std::int64_t total = static_cast<std::int64_t>(load);
    comm_.sum(&total, 1);
    double most = load;
    comm_.max(&most, 1);
    const double mean = static_cast<double>(total) / ranks();
    return mean > 0 ? most / mean : 1.0;
}

void MpiDomain::migrate(World& world, std::vector<WarmImpulse>* warm, long step) {
    world_ = &world;
    if (steps_ == 0) setup_stats_ = comm_.stats();  // steps' figures count from here
    ++steps_;
    const int every = std::max(1, scene_.parallel.rebalance_every);
    if (step > 0 && step % every == 0) {
        imbalance_ = load_imbalance(world, warm);
        if (imbalance_ > scene_.parallel.rebalance_threshold) {
            repartition(world, warm);
            ++repartitions_;
        }
    }
    locate_all(world);
    move_bodies(world, warm);
}

// Owned bodies whose cell belongs to another process go there, with their
// warm-start impulses; they stay here as ghosts until the next exchange
// says whether this process still holds them. Only the bodies locate_all
// (just before) flagged are looked at.
void MpiDomain::move_bodies(World& world, std::vector<WarmImpulse>* warm) {
    std::map<int, Bytes> out;
    std::vector<unsigned char> gone;  // impulses leaving with their body, sized when one does
    long sent = 0;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (!moved_[i] || world.ghost(i)) continue;
        const int to = place(world, i).owner;
        if (to == rank()) continue;
        Bytes& b = out[to];
        put(b, world.gid(i));
        put(b, world.state(i));
        put(b, world.origin(i));
        const auto [first, last] = impulses_of(warm, world.gid(i));
        put(b, static_cast<std::uint32_t>(last - first));
        if (first < last && gone.empty()) gone.assign(warm->size(), 0);
        for (std::size_t k = first; k < last; ++k) {
            put(b, (*warm)[k]);
            gone[k] = 1;
        }
        world.set_ghost(i, true);
        ++sent;
    }
    if (!gone.empty()) drop_impulses(*warm, gone);
    receive_bodies(world, warm, comm_.sparse_exchange(out, kTagMigrate));
    migrations_ += sent;
}

void MpiDomain::receive_bodies(World& world, std::vector<WarmImpulse>* warm, const std::vector<std::pair<int, Bytes>>& in) {
    const std::size_t first = warm ? warm->size() : 0;
    for (const auto& [from, b] : in) {
        (void)from;
        for (std::size_t at = 0; at < b.size();) {
            const auto gid = take<std::uint32_t>(b, at);
            const auto state = take<BodyState>(b, at);
            const auto origin = take<Vec3>(b, at);
            const auto count = take<std::uint32_t>(b, at);
            for (std::uint32_t k = 0; k < count; ++k) {
                const auto m = take<WarmImpulse>(b, at);
                if (warm) warm->push_back(m);
            }
            std::uint32_t local = world.local_of(gid);
            if (local == IdMap::kNone) {
                world.add_body(gid, false, &state, &origin);
            } else {
                world.set_ghost(local, false);
                world.set_state(local, state);
                world.slot(local).stamp = 0;  // moved: locate again
                world.set_origin(local, origin);
            }
        }
    }
    if (warm) sort_impulses(*warm, first);
}

// The owned bodies that other processes hold (or may: a migrant not located
// this step), in body order: found in chunks on the threads, since most
// owned bodies are held here alone and the scan reads every one. The chunks'
// lists of locals are returned as they are; the states are read as the
// messages are written (kept here too, they were the exchange's largest
// buffer, at the step's peak of memory).
std::vector<std::vector<std::uint32_t>> MpiDomain::outgoing(const World& world) const {
    const std::size_t n = world.body_count(), chunks = chunk_count(loops_, n, 4096);
    std::vector<std::vector<std::uint32_t>> part(chunks);
    const int me = rank();
    loops_.run(chunks, n, [&](std::size_t c) {
        for (std::size_t i = chunk_begin(n, chunks, c); i < chunk_begin(n, chunks, c + 1); ++i) {
            if (world.ghost(i)) continue;
            const DomainSlot& s = world.slot(i);
            if (located(s)) {
                const std::vector<int>& h = holders(s);
                if (std::all_of(h.begin(), h.end(), [me](int r) { return r == me; })) continue;
            }
            part[c].push_back(static_cast<std::uint32_t>(i));
        }
    });
    return part;
}

// Owners send every body to the other holders of its cell; receivers update
// the ghosts they have, add new ones and drop those nobody sent. Each
// message is counted before it is written, so that it takes the bytes it
// needs and no more (appending grew them up to twice that: at the step's
// peak of memory, a sizeable share of a ghost's cost); the messages are
// freed once sent, before the ghosts they bring are made.
void MpiDomain::exchange_states(World& world) {
    world_ = &world;
    const auto parts = outgoing(world);
    std::map<int, std::size_t> count;
    for (const auto& part : parts) {
        for (std::uint32_t i : part) {
            for (int h : holders(place(world, i))) count[h] += h == rank() ? 0 : 1;
        }
    }
    constexpr std::size_t kRecord = sizeof(std::uint32_t) + sizeof(BodyState);
    std::size_t out_bytes = 0;
    std::map<int, std::size_t> at;  // each destination's next record in the buffer
    std::map<int, std::vector<std::uint32_t>> sent;
    for (const auto& [h, n] : count) {
        if (n == 0) continue;
        at[h] = out_bytes;
        out_bytes += n * kRecord;
        sent[h].reserve(n);
    }
    // The messages and what arrives share a buffer of the scratch pool,
    // whose slots are idle between steps (no stage's arrays outlive it):
    // the exchange then takes memory the solve made resident, not more.
    const std::size_t room = std::max(in_bytes_, out_bytes) + out_bytes / 4 + 4096;
    char* buffer = static_cast<char*>(scratch_->take(kSlotMessages, out_bytes + room));
    std::vector<Message> out;
    for (const auto& [h, from] : at) out.push_back({h, buffer + from, count[h] * kRecord});
    for (const auto& part : parts) {
        for (std::uint32_t i : part) {
            BodyState state{};
            bool read = false;  // the set-up's first exchange lists every owned body, most of them held here alone
            for (int h : holders(place(world, i))) {
                if (h == rank()) continue;
                if (!read) state = world.state(i);
                read = true;
                const std::uint32_t gid = world.gid(i);
                char* to = buffer + at[h];
                std::memcpy(to, &gid, sizeof gid);
                std::memcpy(to + sizeof gid, &state, sizeof state);
                at[h] += kRecord;
                sent[h].push_back(gid);
            }
        }
    }
    Landing landing{buffer + out_bytes, room, 0, {}};
    const auto in = comm_.sparse_exchange(out, landing, kTagGhost);
    in_bytes_ = 0;
    for (const Message& m : in) in_bytes_ += m.size;
    std::size_t arriving = 0;  // new ghosts: room for them in one step
    for (const Message& m : in) {
        for (std::size_t k = 0; k < m.size; k += sizeof(BodyState)) {  // take moves past the gid
            arriving += world.local_of(take<std::uint32_t>(m.data, k)) == IdMap::kNone ? 1 : 0;
        }
    }
    world.reserve_bodies(world.body_count() + arriving);
    std::vector<std::uint8_t> seen(world.body_count(), 0);
    std::map<int, std::vector<std::uint32_t>> received;
    for (const Message& m : in) {
        for (std::size_t k = 0; k < m.size;) {
            const auto gid = take<std::uint32_t>(m.data, k);
            const auto state = take<BodyState>(m.data, k);
            std::uint32_t local = world.local_of(gid);
            if (local != IdMap::kNone && !world.ghost(local)) {
                ++conflicts_;  // owned here and sent as a ghost: reported by check_invariants
                continue;
            }
            if (local == IdMap::kNone) {
                local = static_cast<std::uint32_t>(world.add_body(gid, true, &state));
                seen.push_back(1);
            } else {
                world.set_state(local, state);
                world.slot(local).stamp = 0;  // moved: locate again
                seen[local] = 1;
            }
            received[m.rank].push_back(gid);
        }
    }
    for (std::size_t i = world.body_count(); i-- > 0;) {
        if (world.ghost(i) && !seen[i]) world.remove_body(i);
    }
    auto resolve = [&world](const std::map<int, std::vector<std::uint32_t>>& by_rank, std::vector<int>& ranks,
                            std::vector<std::vector<std::uint32_t>>& locals) {
        ranks.clear();
        locals.clear();
        for (const auto& [r, gids] : by_rank) {
            ranks.push_back(r);
            locals.emplace_back();
            for (std::uint32_t g : gids) locals.back().push_back(world.local_of(g));
        }
    };
    resolve(sent, send_to_, send_locals_);
    resolve(received, recv_from_, recv_locals_);
    index_bodies(world);
    next_stamp();  // this step's stamps lapse
}

// The partners of the solver's exchange: every process that holds a copy of
// any body held here. The owned bodies' other holders are the ranks they
// were just sent to, so only the ghosts are located again (a pass over every
// body's holders cost 3.3 ms a step at 10^6 catoms on 2 ranks, against 0.5).
void MpiDomain::index_bodies(World& world) {
    const std::size_t n = world.body_count();

    for (int r : nbrs_) nbr_index_[static_cast<std::size_t>(r)] = -1;
    nbrs_.clear();
    for (int h : send_to_) {
        nbr_index_[static_cast<std::size_t>(h)] = static_cast<int>(nbrs_.size());
        nbrs_.push_back(h);
    }
    for (std::size_t i = 0; i < n; ++i) {
        if (!world.ghost(i)) continue;
        for (int h : holders(place(world, i))) {
            if (h == rank() || nbr_index_[static_cast<std::size_t>(h)] >= 0) continue;
            nbr_index_[static_cast<std::size_t>(h)] = static_cast<int>(nbrs_.size());
            nbrs_.push_back(h);
        }
    }
    std::sort(nbrs_.begin(), nbrs_.end());
    for (std::size_t j = 0; j < nbrs_.size(); ++j) nbr_index_[static_cast<std::size_t>(nbrs_[j])] = static_cast<int>(j);
}

// The body's cell, its owner and holders: cached with the body, looked up
// only when it changed cell or the cells were repartitioned; not even its
// position is read when this step's locate_all found the entry current.
const DomainSlot& MpiDomain::place(World& world, std::size_t i) const {
    DomainSlot& s = world.slot(i);
    if (located(s)) return s;
    const dReal* x = dBodyGetPosition(world.body(i));
    std::uint8_t sides;
    const std::uint64_t key = cells_.key(x, reach_, sides);
    if (s.cell == key && s.sides == sides && s.epoch == epoch_) return s;
    s.cell = key;
    s.sides = sides;
    s.owner = map_.owner(key);
    s.holders = &map_.holders(key, sides);
    s.epoch = epoch_;
    return s;
}

// Once a step, after the solver moved the bodies: every local body's cell
// from its position, in chunks on the threads (a cache miss into ODE's body
// record each, which three scans a step used to pay; the position's line is
// fetched 16 bodies ahead: 13.3 -> 9.6 ms a step at 10^6 catoms on 2
// ranks); the few bodies that
// changed cell get their owner and holders from the map serially (its
// lookups fill caches). Entries found current are stamped; a body whose state
// is set later (a migrant, a ghost's update) loses its stamp, and every stamp
// lapses when exchange_states is done (the solver moves the bodies next).
// moved_ flags, for move_bodies, every body that changed cell and every
// owned body another process owns (a serial pass over every body there
// cost 3.3 ms a step at 10^6 catoms on 2 ranks).
void MpiDomain::locate_all(World& world) {
    constexpr std::size_t kPositionAhead = 16;  // bodies ahead whose position line is fetched
    next_stamp();
    const std::size_t n = world.body_count();
    moved_.resize(n);
    std::uint8_t* moved = moved_.data();
    const std::uint32_t stamp = stamp_, epoch = epoch_;
    const int me = rank();
    for_ranges(loops_, n, 4096, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i) {
            if (i + kPositionAhead < i1) __builtin_prefetch(dBodyGetPosition(world.body(i + kPositionAhead)));
            DomainSlot& s = world.slot(i);
            const dReal* x = dBodyGetPosition(world.body(i));
            std::uint8_t sides;
            const bool current = s.epoch == epoch && s.cell == cells_.key(x, reach_, sides) && s.sides == sides;
            if (current) s.stamp = stamp;
            moved[i] = !current || (s.owner != me && !world.ghost(i));
        }
    });
    for (std::size_t i = 0; i < n; ++i) {
        if (!moved[i]) continue;
        place(world, i);
        world.slot(i).stamp = stamp;
    }
}

void MpiDomain::exchange_forces(World& world) {
    std::vector<Bytes> out(send_to_.size());
    for (std::size_t j = 0; j < send_to_.size(); ++j) {
        for (std::uint32_t i : send_locals_[j]) {
            const dReal* f = dBodyGetForce(world.body(i));
            const dReal* t = dBodyGetTorque(world.body(i));
            for (int k = 0; k < 3; ++k) put(out[j], f[k]);
            for (int k = 0; k < 3; ++k) put(out[j], t[k]);
        }
    }
    std::vector<Bytes> in;
    comm_.exchange(send_to_, out, recv_from_, in, kTagForce);
    for (std::size_t j = 0; j < recv_from_.size(); ++j) {
        std::size_t at = 0;
        for (std::uint32_t i : recv_locals_[j]) {
            double v[6];
            for (double& x : v) x = take<double>(in[j], at);
            dBodySetForce(world.body(i), v[0], v[1], v[2]);
            dBodySetTorque(world.body(i), v[3], v[4], v[5]);
        }
    }
}

// Collective: every ghost's digest against its owner's body.
std::int64_t MpiDomain::ghost_mismatches(const World& world, std::string& detail) const {
    std::map<int, Bytes> out;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (!world.ghost(i)) continue;
        const int owner = world.slot(i).owner;
        put(out[owner], world.gid(i));
        put(out[owner], body_digest(world, i));
    }
    std::int64_t bad = 0;
    std::ostringstream os;
    for (const auto& [from, b] : comm_.sparse_exchange(out, kTagCheck)) {
        for (std::size_t at = 0; at < b.size();) {
            const auto gid = take<std::uint32_t>(b, at);
            const auto digest = take<std::uint64_t>(b, at);
            const std::uint32_t local = world.local_of(gid);
            if (local != IdMap::kNone && !world.ghost(local) && body_digest(world, local) == digest) continue;
            if (bad++ < 5) os << " body " << gid << " (ghost on rank " << from << ", owner rank " << rank() << ")";
        }
    }
    detail = os.str();
    return bad;
}

void MpiDomain::check_invariants(const World& world, long step) {
    std::int64_t counts[4] = {static_cast<std::int64_t>(world.owned_count()), conflicts_, 0, 0};
    std::uint64_t ids = 0;
    std::ostringstream os;
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (world.ghost(i)) continue;
        ids += SplitMix64::mix(world.gid(i));
        const int owner = map_.owner(world.slot(i).cell);  // from the map, not the cache
        if (owner != rank() && counts[2]++ < 5) {
            os << " body " << world.gid(i) << " owned by rank " << rank() << " in a cell of rank " << owner;
        }
    }
    std::string ghosts;
    counts[3] = ghost_mismatches(world, ghosts);
    comm_.sum(counts, 4);
    comm_.sum_wrapping(&ids, 1);
    const bool lost = counts[0] != static_cast<std::int64_t>(world.global_body_count()) || ids != id_hash_;
    if (!lost && !counts[1] && !counts[2] && !counts[3]) return;
    std::ostringstream msg;
    msg << "step " << step << ": distributed invariant violated: " << counts[0] << " bodies owned of "
        << world.global_body_count() << (lost ? " (a body is lost or owned twice)" : "") << ", " << counts[1]
        << " ghosts of owned bodies, " << counts[2] << " bodies outside their owner's cells, " << counts[3]
        << " ghosts that differ from their owners:" << collectives_.all_text(os.str() + ghosts, ";");
    throw SimulationError(msg.str());
}

nlohmann::json MpiDomain::report() const {
    // Communication of the steps, then of setup (partition, distribution,
    // first exchange) apart: setup waits on rank 0 and would swamp a short run.
    const CommStats setup = steps_ ? setup_stats_ : comm_.stats();
    const CommStats& all = comm_.stats();
    std::int64_t c[4] = {0, static_cast<std::int64_t>(all.bytes - setup.bytes), migrations_,
                         static_cast<std::int64_t>(setup.bytes)};
    if (world_) {
        for (std::size_t i = 0; i < world_->body_count(); ++i) c[0] += world_->ghost(i) ? 1 : 0;
    }
    std::uint64_t messages = all.messages - setup.messages;
    const double seconds = all.seconds - setup.seconds;
    comm_.sum(c, 4);
    comm_.sum_wrapping(&messages, 1);
    std::array<std::uint64_t, 8> bytes = colour_bytes_;
    comm_.sum_wrapping(bytes.data(), static_cast<int>(bytes.size()));
    const double n = world_ ? static_cast<double>(world_->global_body_count()) : 1.0;
    return {{"ranks", ranks()},
            {"colour_bytes", bytes},
            {"injected_latency_us", 1e6 * comm_.injected_latency()},
            {"imbalance", imbalance_},
            {"partition_imbalance", partition_imbalance_},
            {"partition_colour_imbalance", partition_colour_imbalance_},
            {"partitioner", bisection_ ? "bisection" : "metis"},
            {"balance", scene_.parallel.balance_colours ? "colours" : "total"},
            {"edge_cut", edge_cut_ >= 0 ? nlohmann::json(edge_cut_) : nlohmann::json(nullptr)},
            {"partition_made_by", together_ ? "every process" : "root"},
            {"partition_seconds", {{"min", collectives_.min(partition_seconds_)}, {"max", collectives_.max(partition_seconds_)}}},
            {"cut_tree_nodes", tree_nodes_},
            {"ghost_fraction", static_cast<double>(c[0]) / n},
            {"migrations", c[2]},
            {"repartitions", repartitions_},
            {"rebalance_threshold", scene_.parallel.rebalance_threshold},
            {"comm_seconds", {{"min", collectives_.min(seconds)}, {"max", collectives_.max(seconds)}}},
            {"comm_bytes", c[1]},
            {"messages_per_step", steps_ ? static_cast<double>(messages) / static_cast<double>(steps_) / ranks() : 0.0},
            {"setup_comm_seconds", {{"min", collectives_.min(setup.seconds)}, {"max", collectives_.max(setup.seconds)}}},
            {"setup_comm_bytes", c[3]},
            {"cell_edge", cells_.edge()},
            {"mapped_blocks", map_.mapped()},
            {"block_edge_cells", map_.edge()}};
}

}  // namespace parode::mpi
