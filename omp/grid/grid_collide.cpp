// The collision engine (see grid_collide.hpp). One OpenMP team per call; a
// single thread walks the stages and spawns taskloops for the parallel ones:
//   read geoms -> split small/big -> grid -> grid pairs + big pairs (tasks,
//   fused broadphase and narrowphase) -> nested spaces -> deferred pairs
//   (serial) -> canonical merge.
// Nested spaces and dSpaceCollide2 follow ODE's rules: a space meets a geom
// through the space's collide2 (its enabled geoms against the geom, enabled or
// not); two spaces meet by running the one with fewer geoms (all of them)
// against the other, unless their sublevels differ, in which case the deeper
// one is treated as a plain geom.
// Trade-off: deferred pairs run on one thread; they are rare in the scenes this
// engine targets (primitives), and that keeps trimesh/heightfield safe.
#include "omp/grid/grid_collide.hpp"
#include "omp/runtime/task_split.hpp"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "omp/grid/cell_grid.hpp"
#include "omp/grid/geom_info.hpp"
#include "omp/grid/grid_pairs.hpp"
#include "omp/grid/lanes.hpp"
#include "omp/grid/neighbour_list.hpp"
#include "omp/runtime/loop_runner.hpp"
#include "util/substages.hpp"

#ifdef _OPENMP
#include <omp.h>
#endif

namespace parode::omp {
namespace {

constexpr std::size_t kGridChunk = 256;  // sorted geoms per task in the grid pass
// Geoms below which a call runs on one thread (measured:
// docs/performance/threads-and-small-scenes.md).
constexpr std::size_t kCollideCrossover = 2000;
constexpr std::size_t kScanChunk = 512;  // geoms per task in scans against a few geoms

// Extent above which a geom goes to the big list: a few times the typical
// (90th percentile of a sample) extent, so one outlier cannot coarsen the grid.
double big_threshold(const GeomTable& infos) {
    std::vector<double> sample;
    const GeomView t = infos.view();
    const std::size_t stride = std::max<std::size_t>(1, infos.size() / 512);
    for (std::size_t i = 0; i < infos.size(); i += stride) {
        if ((t.flags(i) & kEnabled) && (t.flags(i) & kFinite)) sample.push_back(t.extent(i));
    }
    if (sample.empty()) return 0;
    auto p90 = sample.begin() + static_cast<long>(sample.size() * 9 / 10);
    std::nth_element(sample.begin(), p90, sample.end());
    if (*p90 > 0) return 4 * *p90;
    return *std::max_element(sample.begin(), sample.end());
}

// The runs whose lower id `test` drops, out of every lane (in tasks, a lane
// each, order kept): their contacts are then never written.
void drop_runs(std::vector<Lane>& lanes, const GhostTest& test) {
    Lane* lane = lanes.data();
    const std::size_t n = lanes.size();
    const GhostTest* t = &test;
#pragma omp taskloop num_tasks(task_count(n, 1)) default(none) firstprivate(lane, n, t)
    for (std::size_t j = 0; j < n; ++j) {
        std::vector<PairRun>& runs = lane[j].runs;
        runs.erase(std::remove_if(runs.begin(), runs.end(), [t](const PairRun& r) { return t->drops(r.lo); }),
                   runs.end());
    }
}

}  // namespace

struct CollideEngine::Impl {
    std::unique_ptr<Execution> own_exec;             // a standalone engine's
    Execution* exec = nullptr;                       // threads, crossovers, scratch pool, SIMD
    int max_contacts = 1;
    bool use_reference = false;
    std::vector<Lane> lanes;
    std::vector<dGeomID> list;
    dSpaceID flat_space = nullptr;                   // set_geoms hint
    const std::vector<dGeomID>* flat_geoms = nullptr;
    const SphereBodies* spheres = nullptr;           // set_sphere_bodies hint
    ScratchPool unset_pool;                          // until attach() points the tables at exec's
    GeomTable infos{&unset_pool, kSlotGeoms};
    std::vector<std::uint32_t> small, big;
    std::vector<std::uint8_t> bucket;
    struct SplitPart {
        std::size_t small = 0, big = 0;
        CellBounds bounds;
    };
    std::vector<SplitPart> parts;
    CellBounds small_bounds;
    CellGrid grid;
    std::vector<GridEntry> big_entries;
    std::vector<PrimData> big_prims;
    std::vector<DeferredPair> pending;
    MergeScratch merge;
    NeighbourList neighbours;                        // for the flat space's spheres
    bool use_list = true;
    const GhostTest* ghost_test = nullptr;           // collide(): runs it drops are not merged
    std::size_t merges_in_order = 0, merges_sorted = 0;  // collide()'s merges, by path (lanes.hpp)
    PhaseTimes times;

    // The per-call tables in `e`'s scratch pool; threads and SIMD from `e`.
    void attach(Execution* e) {
        exec = e;
        infos.set_pool(&e->scratch());
        grid.set_scratch(&e->scratch());
        neighbours.set_scratch(&e->scratch());
    }
    int team_size() const { return exec->threads(); }
    // One thread below the measured crossover or on shared cores (exec/team.hpp).
    int team_for(dSpaceID space) const {
        const std::size_t n = static_cast<std::size_t>(dSpaceGetNumGeoms(space));
        return exec->threads_for(n, kCollideCrossover) > 1 ? team_size() : 1;
    }
    // The pair tasks' wall time in proportion to the threads' time in each part.
    void split_pairs() {
        double b = 0, n = 0;
        for (const Lane& l : lanes) {
            b += l.broad;
            n += l.narrow;
        }
        times.broad = b + n > 0 ? times.pairs * b / (b + n) : 0.0;
        times.narrow = times.pairs - times.broad;
    }
    FastSource fast_source() const {
        FastSource f;
        f.table = infos.view().info;
        f.big = big_prims.data();
        f.max_contacts = max_contacts;
        return f;
    }
    Lane& lane() { return lanes[static_cast<std::size_t>(thread_index())]; }
    // Whether `space` is the one set_geoms describes, still holding just those.
    // Ghosts without a geom are in the list (as nulls), not in the space.
    bool is_flat(dSpaceID space) const {
        const std::size_t missing = spheres ? spheres->missing() : 0;
        return space == flat_space && flat_geoms &&
               flat_geoms->size() == static_cast<std::size_t>(dSpaceGetNumGeoms(space)) + missing;
    }

    void start(int max, int team);
    void emit(Lane& l, std::uint32_t fa, const PrimData& pa, std::uint32_t fb, const PrimData& pb);
    PairInputs pair_inputs() const;
    void read_space(dSpaceID space);
    void split_items();
    void list_split(std::size_t blocks);
    void build_big();
    void all_pairs();
    bool list_ready(dSpaceID space);
    void list_pairs();
    void space_internal(dSpaceID space, bool recurse);
    void pair2(dGeomID g1, dGeomID g2);
    void space_vs_geoms(dSpaceID space, const std::vector<dGeomID>& geoms, bool swap);
    void drain_deferred();
};

void CollideEngine::Impl::start(int max, int team) {
    max_contacts = max;
    use_reference = false;
    times = PhaseTimes{};
    // Lanes beyond the team's (the neighbour list's blocks) are kept with
    // their room, empty.
    lanes.resize(std::max(lanes.size(), static_cast<std::size_t>(team)));
    for (Lane& l : lanes) l.clear();
}

void CollideEngine::Impl::emit(Lane& l, std::uint32_t fa, const PrimData& pa, std::uint32_t fb,
                               const PrimData& pb) {
    if (fast_pair(fa, fb)) {
        l.fast(pa, (fa & kSphere) != 0, pb, (fb & kSphere) != 0, max_contacts);
    } else if (fa & fb & kSafe) {
        l.generic(pa.geom, pb.geom, max_contacts);
    } else {
        l.deferred.push_back(DeferredPair{pa.geom, pb.geom});
    }
}

PairInputs CollideEngine::Impl::pair_inputs() const {
    PairInputs in;
    in.grid = &grid;
    in.big = big_entries.data();
    in.big_prims = big_prims.data();
    in.nbig = big_entries.size();
    in.infos = infos.view();
    in.max_contacts = max_contacts;
    return in;
}

// Unstored runs name entries of the table this overwrites: they are stored
// first (a nested space or a pair of spaces reads its geoms here).
void CollideEngine::Impl::read_space(dSpaceID space) {
    for (Lane& l : lanes) store_fast_runs(l, fast_source());
    const bool flat = is_flat(space);
    if (!flat && space == flat_space && spheres && spheres->missing() > 0) {
        throw std::logic_error("grid collide: World's space no longer holds the geoms set_geoms named, and " +
                               std::to_string(spheres->missing()) + " ghosts have no geom to be read from it");
    }
    const std::uint32_t any = flat ? read_geoms(*flat_geoms, infos, spheres) : read_space_pipelined(space, list, infos);
    if (any & kStaleAabb) refresh_stale(infos);
    if (any & kUser) use_reference = true;
}

// Marks each geom skipped (0), small (1) or big (2), counting and bounding the
// small ones per block, then lists them block by block (all in tasks; only the
// prefix over blocks is serial). The lists keep the geoms' order.
void CollideEngine::Impl::split_items() {
    const double limit = big_threshold(infos);
    const std::size_t n = infos.size();
    const std::size_t blocks = task_count(n, 2048);
    bucket.resize(n);
    parts.assign(blocks, SplitPart{});
    const GeomView info = infos.view();
    std::uint8_t* mark = bucket.data();
    SplitPart* part = parts.data();
#pragma omp taskloop num_tasks(blocks) default(none) firstprivate(info, mark, part, n, blocks, limit)
    for (std::size_t b = 0; b < blocks; ++b) {
        SplitPart p;  // a local, stored once: neighbouring blocks' parts share cache lines
        for (std::size_t i = task_begin(n, blocks, b); i < task_begin(n, blocks, b + 1); ++i) {
            const std::uint32_t f = info.flags(i);
            dReal box[6];
            dReal extent = 0;  // GeomView::extent, from the AABB read once
            if (f & kFinite) {
                info.aabb(i, box);
                extent = aabb_extent(box);
            }
            const bool is_small = (f & kFinite) && extent <= limit;
            const std::uint8_t m = !(f & kEnabled) ? 0 : is_small ? 1 : 2;
            mark[i] = m;
            if (m == 1) p.bounds.add(box, extent);
            p.small += m == 1;
            p.big += m == 2;
        }
        part[b] = p;
    }
    list_split(blocks);
}

void CollideEngine::Impl::list_split(std::size_t blocks) {
    small_bounds = CellBounds{};
    std::vector<std::array<std::size_t, 2>> counts(blocks);
    for (std::size_t b = 0; b < blocks; ++b) {
        small_bounds.add(parts[b].bounds);
        counts[b] = {parts[b].small, parts[b].big};
    }
    const std::uint8_t* mark = bucket.data();
    split_in_order(infos.size(), counts, [mark](std::size_t i) { return int{mark[i]}; }, small, big);
}

void CollideEngine::Impl::build_big() {
    big_entries.resize(big.size());
    big_prims.resize(big.size());
    const GeomView t = infos.view();
    for (std::size_t j = 0; j < big.size(); ++j) {
        big_entries[j] = grid_entry(t, big[j]);
        big_prims[j] = infos[big[j]].prim;
    }
}

// The pair search (grid_pairs.hpp) in tasks of kGridChunk sorted geoms, and
// the big geoms among themselves in one more task.
void CollideEngine::Impl::all_pairs() {
    const PairInputs in = pair_inputs();
    const PairInputs* pin = &in;  // a task would copy the struct itself: fine, but one pointer is less
    const std::size_t n = grid.size();
    const std::size_t chunks = (n + kGridChunk - 1) / kGridChunk;
#pragma omp taskgroup
    {
#pragma omp taskloop num_tasks(task_count(chunks, 1)) nogroup firstprivate(pin)
        for (std::size_t c = 0; c < chunks; ++c) chunk_pairs(*pin, c * kGridChunk, std::min(n, (c + 1) * kGridChunk), lane());
#pragma omp task firstprivate(pin)
        big_pairs(*pin, lane());
    }
}

// Whether the flat space's geoms, just read, take the neighbour list: it
// covers them still, or it is due to be built and builds.
bool CollideEngine::Impl::list_ready(dSpaceID space) {
    if (!use_list || !is_flat(space)) return false;
    if (neighbours.covers(space, infos)) return true;
    return neighbours.due() && neighbours.build(space, infos, grid);
}

// The list's pairs, each sphere against the other geoms, and those among
// themselves.
void CollideEngine::Impl::list_pairs() {
    neighbours.others(infos, big);
    build_big();
    // A lane per block of the table (their runs in canonical order for the
    // merge, lanes.hpp), and the big pairs in the last; the first lanes still
    // serve the threads afterwards (deferred pairs).
    const std::size_t blocks = neighbours.blocks();
    if (lanes.size() < blocks + 1) lanes.resize(blocks + 1);
    const PairInputs in = pair_inputs();
    neighbours.pairs(in, lanes.data());
    big_pairs(in, lanes[blocks]);
}

// Pairs among the geoms of `space` (ODE's dSpaceCollide), then, if `recurse`,
// the internal pairs of every nested space (as collide_space_reference does).
void CollideEngine::Impl::space_internal(dSpaceID space, bool recurse) {
    const double t0 = now_seconds();
    read_space(space);
    if (use_reference) return;
    const double t1 = now_seconds();
    if (list_ready(space)) {
        const double t2 = now_seconds();
        list_pairs();
        times.read += t1 - t0;
        times.build += t2 - t1;
        times.pairs += now_seconds() - t2;
        return;  // a flat space: nothing nested
    }
    split_items();
    grid.build(infos, small, small_bounds);
    build_big();
    const double t2 = now_seconds();
    all_pairs();
    const double t3 = now_seconds();
    times.read += t1 - t0;
    times.build += t2 - t1;
    times.pairs += t3 - t2;
    if (!recurse) return;
    std::vector<dSpaceID> nested;
    for (std::size_t i = 0; i < infos.size(); ++i) {
        if (infos[i].prim.flags & kSpace) nested.push_back(reinterpret_cast<dSpaceID>(infos[i].prim.geom));
    }
    for (dSpaceID s : nested) space_internal(s, true);
}

// The enabled geoms of `space` against each of `geoms` (ODE's collide2 of the
// space with each geom). The callback order is (space geom, geom), or the
// reverse when `swap`, as ODE's swap_callback gives it.
void CollideEngine::Impl::space_vs_geoms(dSpaceID space, const std::vector<dGeomID>& geoms,
                                         bool swap) {
    std::vector<GeomFull> others;
    for (dGeomID g : geoms) {
        dReal aabb[6];
        dGeomGetAABB(g, aabb);  // serial: brings the AABB up to date
        others.push_back(read_geom(g));
    }
    read_space(space);
    if (use_reference) return;
    const GeomFull* other = others.data();  // a task would copy the vector itself
    const GeomView table = infos.view();
    const std::size_t nothers = others.size();
    const std::size_t n = infos.size();
    const std::size_t chunks = (n + kScanChunk - 1) / kScanChunk;
#pragma omp taskloop num_tasks(task_count(chunks, 1))
    for (std::size_t c = 0; c < chunks; ++c) {
        Lane& l = lane();
        const std::size_t end = std::min(n, (c + 1) * kScanChunk);
        for (std::size_t h = c * kScanChunk; h < end; ++h) {
            if (!(table.flags(h) & kEnabled)) continue;
            const GeomFull a = table.full(h);
            for (std::size_t j = 0; j < nothers; ++j) {
                const GeomFull& b = other[j];
                if (!ode_pair_filter(a, b)) continue;
                if (swap) {
                    emit(l, b.flags, b.prim, a.flags, a.prim);
                } else {
                    emit(l, a.flags, a.prim, b.flags, b.prim);
                }
            }
        }
    }
}

// ODE's dSpaceCollide2(g1, g2), reached from a near-callback or from collide2.
void CollideEngine::Impl::pair2(dGeomID g1, dGeomID g2) {
    dSpaceID s1 = dGeomIsSpace(g1) ? reinterpret_cast<dSpaceID>(g1) : nullptr;
    dSpaceID s2 = dGeomIsSpace(g2) ? reinterpret_cast<dSpaceID>(g2) : nullptr;
    if (s1 && s2 && dSpaceGetSublevel(s1) != dSpaceGetSublevel(s2)) {
        if (dSpaceGetSublevel(s1) > dSpaceGetSublevel(s2)) s2 = nullptr; else s1 = nullptr;
    }
    if (s1 && s2) {
        if (s1 == s2) return space_internal(s1, false);
        std::vector<dGeomID> geoms;
        if (dSpaceGetNumGeoms(s1) < dSpaceGetNumGeoms(s2)) {
            list_space(s1, geoms);
            dSpaceClean(s1);
            return space_vs_geoms(s2, geoms, true);
        }
        list_space(s2, geoms);
        dSpaceClean(s2);
        return space_vs_geoms(s1, geoms, false);
    }
    if (s1) return space_vs_geoms(s1, {g2}, false);
    if (s2) return space_vs_geoms(s2, {g1}, true);
    dReal aabb[6];
    dGeomGetAABB(g1, aabb);
    dGeomGetAABB(g2, aabb);
    const GeomFull a = read_geom(g1), b = read_geom(g2);
    if (ode_pair_filter(a, b)) lane().generic(g1, g2, max_contacts);
}

// Serial pass over the pairs the parallel passes set aside, until none is left
// (a nested space pair may reveal more).
void CollideEngine::Impl::drain_deferred() {
    for (;;) {
        pending.clear();
        for (Lane& l : lanes) {
            pending.insert(pending.end(), l.deferred.begin(), l.deferred.end());
            l.deferred.clear();
        }
        if (pending.empty() || use_reference) return;
        // Trimesh and heightfield colliders use per-thread data in ODE builds
        // with thread-local storage; this thread may not be the caller's.
        dAllocateODEDataForThread(dAllocateMaskAll);
        const std::vector<DeferredPair> work(pending);
        for (const DeferredPair& d : work) {
            if (dGeomIsSpace(d.a) || dGeomIsSpace(d.b)) {
                pair2(d.a, d.b);
            } else {
                lane().generic(d.a, d.b, max_contacts);
            }
        }
    }
}

CollideEngine::CollideEngine(Execution* exec) : impl_(std::make_unique<Impl>()) {
    if (exec) impl_->attach(exec);
    else set_threads(0);
}

CollideEngine::CollideEngine(const ExecutionConfig& config) : impl_(std::make_unique<Impl>()) {
    impl_->own_exec = omp_execution(config);
    impl_->attach(impl_->own_exec.get());
}

CollideEngine::~CollideEngine() = default;

void CollideEngine::set_threads(int threads) {
    if (impl_->exec && !impl_->own_exec) {
        throw std::logic_error("CollideEngine::set_threads: the engine runs on its pipeline's execution");
    }
    ExecutionConfig c = impl_->own_exec ? impl_->own_exec->config() : ExecutionConfig{};
    c.threads = threads > 0 ? threads : default_threads();
    if (impl_->own_exec && impl_->own_exec->threads() == c.threads) return;  // keeps its warm buffers
    c.threads_from = threads > 0 ? "CollideEngine::set_threads" : "OpenMP's default";
    impl_->own_exec = omp_execution(c);
    impl_->attach(impl_->own_exec.get());
}
void CollideEngine::set_geoms(dSpaceID space, const std::vector<dGeomID>* geoms) {
    impl_->flat_space = geoms ? space : nullptr;
    impl_->flat_geoms = geoms;
}
void CollideEngine::set_sphere_bodies(const SphereBodies* spheres) { impl_->spheres = spheres; }
int CollideEngine::threads() const { return impl_->team_size(); }
const CollideEngine::PhaseTimes& CollideEngine::last_phase_times() const { return impl_->times; }
void CollideEngine::set_neighbour_list(bool on) { impl_->use_list = on; }
bool CollideEngine::neighbour_list() const { return impl_->use_list; }
std::uint64_t CollideEngine::list_digest() const { return impl_->neighbours.digest(); }

CollideEngine::ListCounts CollideEngine::list_counts() const {
    const NeighbourList::Counts& c = impl_->neighbours.counts();
    return ListCounts{c.builds, c.uses, c.declined, c.patches, impl_->merges_in_order, impl_->merges_sorted};
}

void CollideEngine::collide(dSpaceID space, int max_contacts, ContactBuffer& out) {
    Impl& m = *impl_;
    const int team = m.team_for(space);
    m.start(max_contacts, team);
    m.neighbours.set_simd(m.exec->simd());
    // No dSpaceClean: the parallel read refreshes the primitives' AABBs and the
    // rest serially (refresh_stale); ODE's dirty flags stay set, harmlessly.
#pragma omp parallel num_threads(team) default(none) shared(m, space, out)
#pragma omp single
    {
        m.space_internal(space, true);
        const double t0 = now_seconds();
        m.drain_deferred();
        const double t1 = now_seconds();
        if (!m.use_reference && m.ghost_test) drop_runs(m.lanes, *m.ghost_test);
        if (!m.use_reference) ++(merge_lanes(m.lanes, m.fast_source(), out, m.merge) ? m.merges_in_order : m.merges_sorted);
        m.times.deferred += t1 - t0;
        m.times.merge += now_seconds() - t1;
    }
    if (m.use_reference) {
        collide_space_reference(space, max_contacts, out);
        if (m.ghost_test) drop_ghost_contacts(out, *m.ghost_test);
    }
    m.split_pairs();
}

void CollideEngine::set_ghost_test(const GhostTest* test) { impl_->ghost_test = test; }

void GridBackend::collide(dSpaceID space, int max_contacts, ContactBuffer& out) {
    engine_.collide(space, max_contacts, out);
    const auto& t = engine_.last_phase_times();
    times_.add("refresh", t.read);
    times_.add("broadphase", t.build + t.broad);
    times_.add("narrowphase", t.narrow + t.deferred);
    times_.add("merge", t.merge);
}

std::vector<std::pair<std::string, std::int64_t>> GridBackend::counts() const {
    const CollideEngine::ListCounts c = engine_.list_counts();
    return {{"neighbour_list_builds", static_cast<std::int64_t>(c.builds)},
            {"neighbour_list_uses", static_cast<std::int64_t>(c.uses)},
            {"neighbour_list_declined", static_cast<std::int64_t>(c.declined)},
            {"neighbour_list_patches", static_cast<std::int64_t>(c.patches)},
            {"merges_in_order", static_cast<std::int64_t>(c.merges_in_order)},
            {"merges_sorted", static_cast<std::int64_t>(c.merges_sorted)}};
}

void CollideEngine::collide2(dGeomID geom, dSpaceID space, int max_contacts, ContactBuffer& out) {
    Impl& m = *impl_;
    const int team = m.team_for(space);
    m.start(max_contacts, team);
    dSpaceClean(space);
    if (dGeomIsSpace(geom)) dSpaceClean(reinterpret_cast<dSpaceID>(geom));
#pragma omp parallel num_threads(team) default(none) shared(m, geom, space, out)
#pragma omp single
    {
        m.pair2(geom, reinterpret_cast<dGeomID>(space));
        m.drain_deferred();
        if (!m.use_reference) merge_lanes(m.lanes, m.fast_source(), out, m.merge);
    }
    if (m.use_reference) collide2_reference(geom, space, max_contacts, out);
}

}  // namespace parode::omp
