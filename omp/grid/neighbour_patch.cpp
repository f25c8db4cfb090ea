// Patching the neighbour list of neighbour_list.hpp for a table whose slots
// hold other geoms than at the build: a rank's table every step that bodies
// cross its boundaries (a migrant changes hands, a ghost leaves the halo and
// another comes, the last body moving into the gap each leaves). The geoms
// that stayed keep their references and their pairs (renumbered to the new
// walk in id order, which keeps each list ascending); those that left drop
// out of every list; those that came get their position as reference and
// pairs with every listed geom whose reference lies within the two radii and
// twice the skin (the bound the check keeps valid), found by one pass over the
// references against a hash of the arrivals' cells. The list then covers the
// table as a build would: every pair that can touch while no geom is the
// skin's length from its reference.
// Trade-off: a pass over the table and one over the lists, serial and in
// walk order (the same list on any thread count), against a build's pair
// search over every sphere (at 500,000 spheres on one thread: about 60 ms a
// build); with more than an eighth of the table changed, or a geom bigger
// than the build's largest, it is built afresh.
#include <algorithm>
#include <cmath>

#include "omp/grid/neighbour_list.hpp"
#include "util/cell_hash.hpp"
#include "util/scratch.hpp"

namespace parode::omp {
namespace {

constexpr std::uint32_t kNone = ~0u;
constexpr std::size_t kMaxArrivalPairs = 64;  // room made for an arrival's pairs (more: built afresh)

// A set of cell keys: open addressing, at most half full.
class KeySet {
public:
    explicit KeySet(std::size_t n) {
        std::size_t size = 16;
        while (size < 2 * n) size *= 2;
        keys_.assign(size, kEmpty);
        mask_ = size - 1;
    }
    void insert(std::uint64_t k) {
        std::size_t i = home(k);
        while (keys_[i] != kEmpty && keys_[i] != k) i = (i + 1) & mask_;
        keys_[i] = k;
    }
    bool contains(std::uint64_t k) const {
        for (std::size_t i = home(k); keys_[i] != kEmpty; i = (i + 1) & mask_) {
            if (keys_[i] == k) return true;
        }
        return false;
    }

private:
    static constexpr std::uint64_t kEmpty = ~0ULL;
    std::size_t home(std::uint64_t k) const { return static_cast<std::size_t>((k * 0x9E3779B97F4A7C15ULL) >> 20) & mask_; }
    std::vector<std::uint64_t> keys_;
    std::size_t mask_ = 0;
};

// Cells of edge `edge` (util/cell_hash.hpp).
struct Cells {
    double edge;
    std::int64_t index(double v) const { return cell_index(v / edge); }
    static std::uint64_t key(std::int64_t x, std::int64_t y, std::int64_t z) {
        return static_cast<std::uint64_t>(cell_hash_key(x, y, z));
    }
    std::uint64_t key_of(const float* r) const { return key(index(r[0]), index(r[1]), index(r[2])); }
};

}  // namespace

// What a patch makes before it replaces the list (nothing is replaced when
// it fails): arrays carved from one slot of the scratch pool, which the
// grid's boxes and the solver's bodies use at other times of the step (the
// list path builds no grid), so that a patch every step takes neither fresh
// pages nor a place in the step's peak.
struct NeighbourList::Patch {
    std::uint8_t* moved;    // old table index -> its geom changed
    std::uint32_t* now;     // old walk position -> table index now (kNone: left)
    std::uint32_t* to;      // old walk position -> new one (kNone: left)
    std::uint32_t* walk;    // new walk position -> table index
    std::uint32_t* from;    // new walk position -> old one (kNone: arrived)
    std::uint32_t* ids;     // table index -> geom id
    std::uint32_t* start;   // the new lists' starts (m + 1)
    float* ref;             // table index -> reference
    ListEntry* next;        // the new lists (room for `room` entries)
    std::size_t room = 0, size = 0;
    std::vector<std::uint32_t> outside, arrived;  // arrived: listed arrivals' new walk positions
    std::uint64_t slots = 0;

    // Room for tables of n and m entries and `entries` list entries.
    Patch(ScratchPool& pool, std::size_t n, std::size_t m, std::size_t entries) : room(entries) {
        const std::size_t sizes[] = {n, 4 * n, 4 * n, 4 * m, 4 * m, 4 * m, 4 * (m + 1), 16 * m, sizeof(ListEntry) * entries};
        std::size_t total = 0;
        for (std::size_t b : sizes) total += (b + 63) / 64 * 64;
        auto* at = static_cast<char*>(pool.take(kSlotEntries, total));
        char* parts[9];
        for (int k = 0; k < 9; ++k) parts[k] = at, at += (sizes[k] + 63) / 64 * 64;
        moved = reinterpret_cast<std::uint8_t*>(parts[0]);
        now = reinterpret_cast<std::uint32_t*>(parts[1]);
        to = reinterpret_cast<std::uint32_t*>(parts[2]);
        walk = reinterpret_cast<std::uint32_t*>(parts[3]);
        from = reinterpret_cast<std::uint32_t*>(parts[4]);
        ids = reinterpret_cast<std::uint32_t*>(parts[5]);
        start = reinterpret_cast<std::uint32_t*>(parts[6]);
        ref = reinterpret_cast<float*>(parts[7]);
        next = reinterpret_cast<ListEntry*>(parts[8]);
    }
};

bool NeighbourList::patch(const GeomTable& infos) {
    const GeomView t = infos.view();
    const std::size_t m = infos.size(), n = n_;
    // The table indices whose geom changed, as (id, index).
    std::vector<std::pair<std::uint32_t, std::uint32_t>> changed;
    std::uint64_t slots = 0;
    for (std::size_t j = 0; j < m; ++j) {
        const std::uint32_t id = t.info[j].prim.id;
        slots += slot_digest(j, id);
        if (j < n && ids_[j] == id) continue;
        changed.emplace_back(id, static_cast<std::uint32_t>(j));
        if (changed.size() > n / 8 + 64) return false;
    }
    Patch p(*pool_, n, m, next_.size() + kMaxArrivalPairs * changed.size());
    p.slots = slots;
    std::fill(p.moved, p.moved + n, std::uint8_t{0});
    for (const auto& c : changed) {
        if (c.second < n) p.moved[c.second] = 1;
    }
    for (std::size_t s = m; s < n; ++s) p.moved[s] = 1;
    // Each old walk position's table index now (kNone: left), and the arrivals.
    for (std::size_t w = 0; w < n; ++w) p.now[w] = p.moved[walked_slot(w)] ? kNone : walked_slot(w);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> arrivals;  // (id, table index)
    for (const auto& [id, j] : changed) {
        std::size_t lo = 0, hi = n;  // the old walk is in id order
        while (lo < hi) {
            const std::size_t mid = (lo + hi) / 2;
            if (ids_[walked_slot(mid)] < id) lo = mid + 1;
            else hi = mid;
        }
        if (lo < n && ids_[walked_slot(lo)] == id) p.now[lo] = j;
        else arrivals.emplace_back(id, j);
    }
    std::sort(arrivals.begin(), arrivals.end());
    if (!new_walk(p, arrivals, m) || !new_references(p, t, m)) return false;
    if (!link_arrivals(p, m)) return false;
    commit(p, m);
    return true;
}

// The new walk: the geoms that stayed, in their order, and the arrivals, by id.
bool NeighbourList::new_walk(Patch& p, const std::vector<std::pair<std::uint32_t, std::uint32_t>>& arrivals,
                             std::size_t m) const {
    const std::size_t n = n_;
    std::size_t a = 0, wn = 0;
    for (std::size_t w = 0; w <= n; ++w) {
        const std::uint32_t id = w < n ? ids_[walked_slot(w)] : kNone;
        for (; a < arrivals.size() && (w == n || arrivals[a].first < id); ++a) {
            if (wn == m) return false;
            p.walk[wn] = arrivals[a].second;
            p.from[wn++] = kNone;
        }
        if (w == n) break;
        p.to[w] = kNone;
        if (p.now[w] == kNone) continue;
        if (wn == m) return false;
        p.to[w] = static_cast<std::uint32_t>(wn);
        p.walk[wn] = p.now[w];
        p.from[wn++] = static_cast<std::uint32_t>(w);
    }
    return wn == m;  // else not a table of distinct ids
}

// References: kept for the geoms that stayed (which must still be near
// them), their position for the arrivals; and the geoms not listed.
bool NeighbourList::new_references(Patch& p, const GeomView& t, std::size_t m) {
    const float rmax = radius_up(rmax_);
    const double skin2 = skin_ * skin_;
    for (std::size_t wn = 0; wn < m; ++wn) {
        const std::uint32_t j = p.walk[wn];
        const PrimData& g = t.info[j].prim;
        float* r = p.ref + 4 * j;
        p.ids[j] = g.id;
        if (p.from[wn] != kNone) {
            const float* old = ref_.data() + 4 * walked_slot(p.from[wn]);
            const bool listed = old[3] >= 0;
            const double dx = g.p[0] - old[0], dy = g.p[1] - old[1], dz = g.p[2] - old[2];
            const bool near = dx * dx + dy * dy + dz * dz <= skin2 && g.p[3] <= old[3];
            if (listable(g.flags) != listed || (listed && !near)) return false;
            std::copy(old, old + 4, r);
        } else if (listable(g.flags)) {
            for (int k = 0; k < 3; ++k) r[k] = static_cast<float>(g.p[k]);
            r[3] = radius_up(g.p[3]);
            if (r[3] > rmax) return false;  // the build's cells and skin are for its radii
            p.arrived.push_back(static_cast<std::uint32_t>(wn));
        } else {
            r[3] = -1;
        }
    }
    std::size_t enabled_outside = 0;
    for (std::size_t j = 0; j < m; ++j) {
        if (p.ref[4 * j + 3] >= 0) continue;
        p.outside.push_back(static_cast<std::uint32_t>(j));
        enabled_outside += (t.info[j].prim.flags & kEnabled) != 0;
    }
    return enabled_outside <= kMaxOutside;
}

// The arrivals' pairs (lower << 32 | higher walk positions, sorted): every
// listed geom whose reference lies within the two radii and twice the skin
// of an arrival's, found by a pass over the references against the cells
// around the arrivals.
std::vector<std::uint64_t> NeighbourList::arrival_pairs(const Patch& p, std::size_t m) const {
    const double reach = 2 * skin_;
    const Cells cells{2 * static_cast<double>(radius_up(rmax_)) + reach};
    std::vector<std::pair<std::uint64_t, std::uint32_t>> at;  // (cell key, arrival's walk position)
    KeySet near(27 * p.arrived.size());
    for (std::uint32_t wa : p.arrived) {
        const float* r = p.ref + 4 * p.walk[wa];
        at.emplace_back(cells.key_of(r), wa);
        const std::int64_t x = cells.index(r[0]), y = cells.index(r[1]), z = cells.index(r[2]);
        for (int d = 0; d < 27; ++d) near.insert(Cells::key(x + d % 3 - 1, y + d / 3 % 3 - 1, z + d / 9 - 1));
    }
    std::sort(at.begin(), at.end());
    std::vector<std::uint64_t> added;
    for (std::size_t wn = 0; wn < m && !at.empty(); ++wn) {
        const float* rb = p.ref + 4 * p.walk[wn];
        if (rb[3] < 0 || !near.contains(cells.key_of(rb))) continue;
        const std::int64_t x = cells.index(rb[0]), y = cells.index(rb[1]), z = cells.index(rb[2]);
        for (int d = 0; d < 27; ++d) {
            const std::uint64_t k = Cells::key(x + d % 3 - 1, y + d / 3 % 3 - 1, z + d / 9 - 1);
            auto q = std::lower_bound(at.begin(), at.end(), std::make_pair(k, std::uint32_t{0}));
            for (; q != at.end() && q->first == k; ++q) {
                const std::uint32_t wa = q->second;
                if (wa == wn || (p.from[wn] == kNone && wa < wn)) continue;  // two arrivals: once, from the first
                const float* ra = p.ref + 4 * p.walk[wa];
                const double dx = double{ra[0]} - rb[0], dy = double{ra[1]} - rb[1], dz = double{ra[2]} - rb[2];
                const double bound = (double{ra[3]} + rb[3] + reach) * (1 + 1e-9);
                if (dx * dx + dy * dy + dz * dz > bound * bound) continue;
                const std::uint64_t lo = std::min<std::uint64_t>(wn, wa), hi = std::max<std::uint64_t>(wn, wa);
                added.push_back(lo << 32 | hi);
            }
        }
    }
    std::sort(added.begin(), added.end());
    return added;
}

// The lists renumbered to the new walk, without the geoms that left and with
// the arrivals' pairs merged in (each list stays ascending).
bool NeighbourList::link_arrivals(Patch& p, std::size_t m) {
    const std::vector<std::uint64_t> added = arrival_pairs(p, m);
    std::size_t size = 0;
    auto extra = added.begin();
    const auto put = [&p, &size](std::uint32_t w) {
        if (size < p.room) p.next[size].w = w;
        ++size;
    };
    for (std::size_t wn = 0; wn < m; ++wn) {
        p.start[wn] = static_cast<std::uint32_t>(size);
        const std::uint32_t w = p.from[wn];
        const std::uint32_t k0 = w == kNone ? 0 : start_[w], k1 = w == kNone ? 0 : start_[w + 1];
        for (std::uint32_t k = k0; k < k1; ++k) {
            const std::uint32_t b = p.to[next_[k].w];
            if (b == kNone) continue;
            for (; extra != added.end() && (*extra >> 32) == wn && static_cast<std::uint32_t>(*extra) < b; ++extra) {
                put(static_cast<std::uint32_t>(*extra));
            }
            put(b);
        }
        for (; extra != added.end() && (*extra >> 32) == wn; ++extra) put(static_cast<std::uint32_t>(*extra));
    }
    p.start[m] = static_cast<std::uint32_t>(size);
    p.size = size;
    return size <= p.room;
}

// The patch becomes the list (its arrays copied into the list's own, whose
// room they mostly fit).
void NeighbourList::commit(const Patch& p, std::size_t m) {
    scratch_resize(ref_, 4 * m);
    std::copy(p.ref, p.ref + 4 * m, ref_.begin());
    scratch_resize(ids_, m);
    std::copy(p.ids, p.ids + m, ids_.begin());
    scratch_resize(walk_, m);
    std::copy(p.walk, p.walk + m, walk_.begin());
    scratch_resize(start_, m + 1);
    std::copy(p.start, p.start + m + 1, start_.begin());
    scratch_resize(next_, p.size);
    std::copy(p.next, p.next + p.size, next_.begin());
    outside_ = p.outside;
    n_ = m;
    slots_ = p.slots;
}

}  // namespace parode::omp
