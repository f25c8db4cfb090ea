// The catom programs' neighbours (see program_pass.hpp): which catoms this
// process holds and owns, and the neighbours of the catoms that need them,
// tested each step among candidates listed with a skin.
// Every held catom has a reference position: where it was when the
// candidates were listed, or, for one that arrived here since, where it was
// when it arrived. A listing gives each held catom the catoms within the
// neighbour range plus the skin of it; an arrival is searched for among all
// catoms with a reference position (a cell grid of the listing, a hash grid of
// the arrivals) and added to the candidates both ways. While no held catom is
// half the skin from its reference, every pair within the range is among the
// candidates (the triangle inequality), so the exact test on them gives the
// lists a full search would, bit for bit.
// Trade-off: arrivals patched in (catoms crossing between processes every
// step no longer cost a listing) at the price of a hash map of them and their
// extra candidates, listed afresh once they outnumber an eighth of the held
// catoms; a listing covers the ghosts too (an owned catom may be a ghost at
// the listing).
#include <algorithm>
#include <cmath>

#include "programs/catom_state.hpp"
#include "programs/program_pass.hpp"
#include "util/cell_hash.hpp"
#include "util/id_map.hpp"

namespace parode {
namespace {

constexpr std::uint32_t kArrived = IdMap::kNone - 1;  // lidx_: a reference position in extra_

double distance2(const Vec3& a, const Vec3& b) {
    return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
}

// Whether two centres are within `bound`: the exact test (a cheap one first
// for those surely beyond); a catom is not its own neighbour.
bool within(const Vec3& a, const Vec3& b, double bound) {
    const double d2 = distance2(a, b);
    if (d2 > bound * bound * (1 + 1e-9)) return false;
    const double d = std::sqrt(d2);
    return d > 0 && d <= bound;
}

}  // namespace

// The catoms held here this step (gids ascending), their local indices,
// and the owned ones; unchanged while the world's bodies are.
void ProgramPass::locate(const World& world) {
    if (world.generation() == located_) return;
    located_ = world.generation();
    relocated_ = true;
    const std::size_t nb = world.body_count(), chunks = chunk_count(exec_.loops(), nb, 4096);
    std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> part(chunks);
    exec_.loops().run(chunks, nb, [&](std::size_t c) {
        for (std::size_t i = chunk_begin(nb, chunks, c); i < chunk_begin(nb, chunks, c + 1); ++i) {
            const std::uint32_t g = world.gid(i);
            if (scene_.body_is_catom(g)) part[c].emplace_back(g, static_cast<std::uint32_t>(i));
        }
    });
    std::vector<std::pair<std::uint32_t, std::uint32_t>> held;
    for (const auto& p : part) held.insert(held.end(), p.begin(), p.end());
    if (!std::is_sorted(held.begin(), held.end())) std::sort(held.begin(), held.end());  // one process: in gid order already
    const std::size_t n = held.size(), hchunks = chunk_count(exec_.loops(), n, 4096);
    present_.resize(n);
    plocal_.resize(n);
    std::vector<std::vector<std::uint32_t>> owned(hchunks);  // places in held
    exec_.loops().run(hchunks, n, [&](std::size_t c) {
        for (std::size_t j = chunk_begin(n, hchunks, c); j < chunk_begin(n, hchunks, c + 1); ++j) {
            const auto [g, i] = held[j];
            present_[j] = g, plocal_[j] = i;
            if (!world.ghost(i)) owned[c].push_back(static_cast<std::uint32_t>(j));
        }
    });
    owned_.clear();
    owned_local_.clear();
    for (const auto& o : owned) {
        for (std::uint32_t j : o) owned_.push_back(held[j].first), owned_local_.push_back(held[j].second);
    }
    owned_rec_.clear();  // bound again once the records are (hold_records)
}

// The held catoms' centres (by local index), and their candidates brought up
// to date: arrivals added, listed afresh when a catom moved half the skin.
void ProgramPass::update_candidates(const World& world) {
    xl_.resize(world.body_count());
    const std::size_t n = present_.size();
    for_ranges(exec_.loops(), n, 4096, [&](std::size_t j0, std::size_t j1) {
        for (std::size_t j = j0; j < j1; ++j) {
            const dReal* p = dBodyGetPosition(world.body(plocal_[j]));
            xl_[plocal_[j]] = {p[0], p[1], p[2]};
        }
    });
    if (counts_.lists == 0 || arrivals_ > n / 8 + 64) return list_candidates();
    add_arrivals();
    if (stale()) list_candidates();
}

// The neighbours of every owned catom into now_ (keys: owned_), from their
// candidates, and each one's place in last step's lists (before_at_).
// Chunks of catoms fill their own lists, joined in order.
void ProgramPass::find_neighbours(const World& world) {
    std::swap(before_, now_);
    const std::size_t n = owned_.size(), chunks = chunk_count(exec_.loops(), n, 1024);
    std::vector<std::vector<std::uint32_t>> part(chunks);
    now_.keys = owned_;
    now_.at.assign(n + 1, 0);
    before_at_ = sorted_places(owned_, before_.keys);
    exec_.loops().run(chunks, n, [&](std::size_t c) {
        std::vector<std::uint32_t> mine;
        for (std::size_t o = chunk_begin(n, chunks, c); o < chunk_begin(n, chunks, c + 1); ++o) {
            const std::size_t from = mine.size();
            neighbours_of(world, owned_[o], owned_local_[o], mine);
            now_.at[o + 1] = static_cast<std::uint32_t>(mine.size() - from);
        }
        part[c] = std::move(mine);
    });
    for (std::size_t o = 0; o < n; ++o) now_.at[o + 1] += now_.at[o];
    join(part, now_.ids);
}

// Held catom g's neighbours now (gids, ascending), appended to `out`;
// `local`: its local index.
void ProgramPass::neighbours_of(const World& world, std::uint32_t g, std::uint32_t local,
                                std::vector<std::uint32_t>& out) const {
    const std::size_t from = out.size();
    const Vec3& x = xl_[local];
    const double rg = catom_radius(scene_, g) + reach_;
    const auto test = [&](std::uint32_t c) {
        const std::uint32_t lc = world.local_of(c);
        if (lc != IdMap::kNone && within(x, xl_[lc], rg + catom_radius(scene_, c))) out.push_back(c);
    };
    const std::uint32_t l = lidx_.find(g);
    if (l < kArrived) {
        for (std::uint32_t q = cand_.at[l]; q < cand_.at[l + 1]; ++q) test(cand_.ids[q]);
    }
    const auto e = extra_.find(g);
    if (e == extra_.end()) return;  // the listing's candidates alone: ascending already
    for (std::uint32_t c : e->second.cand) test(c);
    std::sort(out.begin() + static_cast<std::ptrdiff_t>(from), out.end());
    out.erase(std::unique(out.begin() + static_cast<std::ptrdiff_t>(from), out.end()), out.end());
}

// The chunks' lists one after the other in `out`, copied on the threads.
void ProgramPass::join(const std::vector<std::vector<std::uint32_t>>& part, std::vector<std::uint32_t>& out) const {
    std::vector<std::size_t> at(part.size() + 1, 0);
    for (std::size_t c = 0; c < part.size(); ++c) at[c + 1] = at[c] + part[c].size();
    out.resize(at.back());
    exec_.loops().run(part.size(), at.back(), [&](std::size_t c) {
        std::copy(part[c].begin(), part[c].end(), out.begin() + static_cast<std::ptrdiff_t>(at[c]));
    });
}

// A held catom's reference position.
const Vec3& ProgramPass::reference(std::uint32_t g) const {
    const std::uint32_t l = lidx_.find(g);
    return l < kArrived ? listed_x_[l] : extra_.at(g).x;
}

// Whether a held catom is half the skin from its reference position.
bool ProgramPass::stale() const {
    const double half = 0.5 * skin_ * (1 - 1e-9);
    const std::size_t n = present_.size(), chunks = chunk_count(exec_.loops(), n, 4096);
    std::vector<double> most(chunks, 0.0);  // a maximum: the same for any split
    exec_.loops().run(chunks, n, [&](std::size_t c) {
        for (std::size_t j = chunk_begin(n, chunks, c); j < chunk_begin(n, chunks, c + 1); ++j) {
            most[c] = std::max(most[c], distance2(xl_[plocal_[j]], reference(present_[j])));
        }
    });
    return *std::max_element(most.begin(), most.end()) > half * half;
}

// Held catoms without a reference position (arrived since the listing, in
// gid order): each one's candidates among all catoms with one (itself
// added to theirs), then its reference is where it is now.
void ProgramPass::add_arrivals() {
    const double edge = edge_ + skin_;
    std::vector<std::uint32_t> found;
    for (std::size_t j = 0; j < present_.size(); ++j) {
        const std::uint32_t a = present_[j];
        if (lidx_.find(a) != IdMap::kNone) continue;
        const Vec3& x = xl_[plocal_[j]];
        const double ra = catom_radius(scene_, a) + reach_ + skin_;
        found.clear();
        listed_near(x, ra, found);
        std::int64_t c[3];
        for (int d = 0; d < 3; ++d) c[d] = cell_index(x[d] / edge);
        for (int d = 0; d < 27; ++d) {
            const auto cell = arrived_cells_.find(cell_hash_key(c[0] + d % 3 - 1, c[1] + d / 3 % 3 - 1, c[2] + d / 9 - 1));
            if (cell == arrived_cells_.end()) continue;
            for (std::uint32_t b : cell->second) {
                if (within(x, extra_.at(b).x, ra + catom_radius(scene_, b))) found.push_back(b);
            }
        }
        Extra& e = extra_[a];
        e.x = x;
        e.cand.insert(e.cand.end(), found.begin(), found.end());
        for (std::uint32_t b : found) extra_[b].cand.push_back(a);
        arrived_cells_[cell_hash_key(c[0], c[1], c[2])].push_back(a);
        lidx_.set(a, kArrived);
        ++arrivals_;
    }
}

// The listed catoms within `ra` plus their radius of `x` (by their
// reference positions), appended to `out` as gids: the 27 cells
// around x's, as 9 runs of 3 cells along z (consecutive in the listing).
void ProgramPass::listed_near(const Vec3& x, double ra, std::vector<std::uint32_t>& out) const {
    const double edge = edge_ + skin_;
    std::int64_t c[3];
    for (int a = 0; a < 3; ++a) c[a] = cell_index((x[a] - low_[a]) / edge);
    const std::int64_t z0 = std::max<std::int64_t>(c[2] - 1, 0), z1 = std::min<std::int64_t>(c[2] + 1, dims_[2] - 1);
    if (z0 > z1) return;
    for (int d = 0; d < 9; ++d) {
        const std::int64_t cx = c[0] + d % 3 - 1, cy = c[1] + d / 3 - 1;
        if (cx < 0 || cy < 0 || cx >= dims_[0] || cy >= dims_[1]) continue;
        const auto test = [&](std::size_t s0, std::size_t s1) {
            for (std::size_t l = s0; l < s1; ++l) {
                const Listed& e = listed_[l];
                if (within(x, e.x, ra + static_cast<double>(e.r))) out.push_back(e.k);
            }
        };
        if (!start_.empty()) {  // the three cells along z are consecutive
            const auto cell = [&](std::int64_t cz) { return static_cast<std::size_t>((cx * dims_[1] + cy) * dims_[2] + cz); };
            test(start_[cell(z0)], start_[cell(z1) + 1]);
            continue;
        }
        for (std::int64_t cz = z0; cz <= z1; ++cz) {
            const auto run = std::equal_range(keys_.begin(), keys_.end(), cell_hash_key(cx, cy, cz));
            test(static_cast<std::size_t>(run.first - keys_.begin()), static_cast<std::size_t>(run.second - keys_.begin()));
        }
    }
}

// Every held catom's candidates afresh, from a cell list of edge
// 2 r_max + reach + skin: the held catoms sorted by cell (a counting sort
// over a dense grid of their bounding box when it has at most 8 cells a
// catom, O(N); else by cell key), each then looking at the 27 cells around
// its own.
void ProgramPass::list_candidates() {
    extra_.clear();
    arrived_cells_.clear();
    arrivals_ = 0;
    grid_listed();
    const std::size_t n = present_.size();
    listed_k_ = present_;
    listed_x_.resize(n);
    const std::size_t chunks = chunk_count(exec_.loops(), n, 1024);
    std::vector<std::vector<std::uint32_t>> part(chunks);
    cand_.at.assign(n + 1, 0);
    exec_.loops().run(chunks, n, [&](std::size_t c) {
        std::vector<std::uint32_t> mine;
        for (std::size_t j = chunk_begin(n, chunks, c); j < chunk_begin(n, chunks, c + 1); ++j) {
            const std::size_t from = mine.size();
            const Vec3& x = listed_x_[j] = xl_[plocal_[j]];
            listed_near(x, catom_radius(scene_, present_[j]) + reach_ + skin_, mine);
            std::sort(mine.begin() + static_cast<std::ptrdiff_t>(from), mine.end());
            cand_.at[j + 1] = static_cast<std::uint32_t>(mine.size() - from);
        }
        part[c] = std::move(mine);
    });
    lidx_.reset(scene_.body_count(), n);
    for (std::size_t j = 0; j < n; ++j) cand_.at[j + 1] += cand_.at[j], lidx_.set(present_[j], static_cast<std::uint32_t>(j));
    join(part, cand_.ids);
    ++counts_.lists;
}

// The held catoms, with their centres and radii, into listed_ sorted by
// cell: start_ (dense grid) or keys_ (each entry's cell key) find a cell's.
void ProgramPass::grid_listed() {
    const std::size_t n = present_.size();
    const double edge = edge_ + skin_;
    Vec3 high{-1e300, -1e300, -1e300};
    low_ = {1e300, 1e300, 1e300};
    for (std::size_t j = 0; j < n; ++j) {
        const Vec3& x = xl_[plocal_[j]];
        for (int a = 0; a < 3; ++a) low_[a] = std::min(low_[a], x[a]), high[a] = std::max(high[a], x[a]);
    }
    double cells = 1;
    for (int a = 0; a < 3; ++a) {
        dims_[a] = n ? cell_index((high[a] - low_[a]) / edge) + 1 : 1;
        cells *= static_cast<double>(dims_[a]);
    }
    const auto cell = [&](const Vec3& p, int a) { return cell_index((p[a] - low_[a]) / edge); };
    const auto entry = [&](std::size_t j) {
        const double r = catom_radius(scene_, present_[j]);
        float rf = static_cast<float>(r);
        if (static_cast<double>(rf) < r) rf = std::nextafter(rf, 2 * rf + 1);  // never below the radius
        return Listed{xl_[plocal_[j]], rf, present_[j]};
    };
    listed_.resize(n);
    start_.clear();
    keys_.clear();
    if (cells <= 8.0 * static_cast<double>(n) + 64) {
        start_.assign(static_cast<std::size_t>(cells) + 1, 0);
        std::vector<std::uint32_t> of(n);
        for (std::size_t j = 0; j < n; ++j) {
            const Vec3& x = xl_[plocal_[j]];
            of[j] = static_cast<std::uint32_t>((cell(x, 0) * dims_[1] + cell(x, 1)) * dims_[2] + cell(x, 2));
            ++start_[of[j] + 1];
        }
        for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
        std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
        for (std::size_t j = 0; j < n; ++j) listed_[fill[of[j]]++] = entry(j);
    } else {
        std::vector<std::pair<std::int64_t, std::uint32_t>> sorted(n);
        for (std::size_t j = 0; j < n; ++j) {
            const Vec3& x = xl_[plocal_[j]];
            sorted[j] = {cell_hash_key(cell(x, 0), cell(x, 1), cell(x, 2)), static_cast<std::uint32_t>(j)};
        }
        std::sort(sorted.begin(), sorted.end());
        keys_.resize(n);
        for (std::size_t l = 0; l < n; ++l) keys_[l] = sorted[l].first, listed_[l] = entry(sorted[l].second);
    }
}

}  // namespace parode
