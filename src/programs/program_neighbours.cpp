// The catom programs' neighbours (see program_pass.hpp): which catoms this
// process holds and owns, and each owned catom's neighbours, tested each step
// among candidates listed with a skin.
// Trade-off: candidates listed again whenever the catoms held or owned here
// change (on several processes, every step that catoms cross between them),
// instead of patching the lists: simple, and exact by construction.
#include <algorithm>
#include <cmath>

#include "programs/catom_state.hpp"
#include "programs/program_pass.hpp"
#include "util/id_map.hpp"

namespace parode {

// The catoms held here this step (ascending catom index), their local
// indices, and the owned ones.
void ProgramPass::locate(const World& world) {
    for_ranges(exec_.loops(), present_.size(), 4096, [&](std::size_t j0, std::size_t j1) {
        for (std::size_t j = j0; j < j1; ++j) local_k_[present_[j]] = IdMap::kNone, owned_now_[present_[j]] = 0;
    });
    const std::size_t nb = world.body_count(), chunks = chunk_count(exec_.loops(), nb, 4096);
    std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> part(chunks);
    exec_.loops().run(chunks, nb, [&](std::size_t c) {
        for (std::size_t i = chunk_begin(nb, chunks, c); i < chunk_begin(nb, chunks, c + 1); ++i) {
            const std::uint32_t g = world.gid(i);
            if (g < kof_.size() && kof_[g] != IdMap::kNone) part[c].emplace_back(kof_[g], static_cast<std::uint32_t>(i));
        }
    });
    std::vector<std::pair<std::uint32_t, std::uint32_t>> held;
    for (const auto& p : part) held.insert(held.end(), p.begin(), p.end());
    if (!std::is_sorted(held.begin(), held.end())) std::sort(held.begin(), held.end());  // one process: in gid order already
    const std::size_t n = held.size(), hchunks = chunk_count(exec_.loops(), n, 4096);
    present_.resize(n);
    plocal_.resize(n);
    std::vector<std::vector<std::uint32_t>> owned(hchunks);
    exec_.loops().run(hchunks, n, [&](std::size_t c) {
        for (std::size_t j = chunk_begin(n, hchunks, c); j < chunk_begin(n, hchunks, c + 1); ++j) {
            const auto [k, i] = held[j];
            present_[j] = k, plocal_[j] = i, local_k_[k] = i;
            if (!world.ghost(i)) owned[c].push_back(k), owned_now_[k] = 1;
        }
    });
    owned_.clear();
    for (const auto& o : owned) owned_.insert(owned_.end(), o.begin(), o.end());
}

// Each owned catom's neighbours from its candidates: the held catoms within
// the neighbour range plus a skin when the candidates were listed. While no
// held catom has moved half the skin since, every neighbour is a candidate
// (the triangle inequality), so testing the candidates with the exact
// distance test gives the lists a full search would, bit for bit; the lists
// are made again when a catom moved farther, or the catoms held or owned
// here changed. Chunks of catoms fill their own lists, joined in order.
void ProgramPass::find_neighbours(const World& world) {
    const std::size_t n = present_.size();
    std::vector<Vec3> x(n);
    for_ranges(exec_.loops(), n, 4096, [&](std::size_t j0, std::size_t j1) {
        for (std::size_t j = j0; j < j1; ++j) {
            const dReal* p = dBodyGetPosition(world.body(plocal_[j]));
            x[j] = {p[0], p[1], p[2]};
        }
    });
    if (stale(x)) list_candidates(x);
    std::swap(before_, now_);
    const std::size_t chunks = chunk_count(exec_.loops(), n, 1024);
    std::vector<std::vector<std::uint32_t>> part(chunks);
    now_.at.assign(ids_.size() + 1, 0);
    exec_.loops().run(chunks, n, [&](std::size_t c) {
        std::vector<std::uint32_t> mine;
        for (std::size_t j = chunk_begin(n, chunks, c); j < chunk_begin(n, chunks, c + 1); ++j) {
            if (!owned_now_[present_[j]]) continue;
            const std::size_t from = mine.size();
            for (std::uint32_t q = cand_.at[j]; q < cand_.at[j + 1]; ++q) {
                const std::uint32_t i = cand_.ids[q];
                if (close(x, j, i, 0.0)) mine.push_back(present_[i]);
            }
            now_.at[present_[j] + 1] = static_cast<std::uint32_t>(mine.size() - from);
        }
        part[c] = std::move(mine);
    });
    for (std::size_t k = 0; k < ids_.size(); ++k) now_.at[k + 1] += now_.at[k];
    join(part, now_.ids);
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

// Whether held catoms i and j are within the neighbour range plus `extra`:
// the exact test on the centre distance (a cheap test first for those surely
// beyond).
bool ProgramPass::close(const std::vector<Vec3>& x, std::size_t j, std::size_t i, double extra) const {
    if (i == j) return false;
    const double d2 = (x[i][0] - x[j][0]) * (x[i][0] - x[j][0]) + (x[i][1] - x[j][1]) * (x[i][1] - x[j][1]) +
                      (x[i][2] - x[j][2]) * (x[i][2] - x[j][2]);
    const double bound = rad_[j] + rad_[i] + reach_ + extra;
    if (d2 > bound * bound * (1 + 1e-9)) return false;
    const double d = std::sqrt(d2);
    return d > 0 && d <= bound;
}

// Whether the candidates must be listed again.
bool ProgramPass::stale(const std::vector<Vec3>& x) const {
    if (listed_present_ != present_ || listed_owned_ != owned_) return true;
    const double half = 0.5 * skin_ * (1 - 1e-9);
    const std::size_t n = x.size(), chunks = chunk_count(exec_.loops(), n, 4096);
    std::vector<double> most(chunks, 0.0);  // a maximum: the same for any split
    exec_.loops().run(chunks, n, [&](std::size_t c) {
        for (std::size_t j = chunk_begin(n, chunks, c); j < chunk_begin(n, chunks, c + 1); ++j) {
            const double d2 = (x[j][0] - listed_x_[j][0]) * (x[j][0] - listed_x_[j][0]) +
                              (x[j][1] - listed_x_[j][1]) * (x[j][1] - listed_x_[j][1]) +
                              (x[j][2] - listed_x_[j][2]) * (x[j][2] - listed_x_[j][2]);
            most[c] = std::max(most[c], d2);
        }
    });
    return *std::max_element(most.begin(), most.end()) > half * half;
}

// Centres in a cell list of edge 2 r_max + reach + skin: a dense grid over
// the bounding box when it has at most 8 cells a catom (counting sort,
// O(N)), else the catoms sorted by cell key; each owned catom then looks at
// the 27 cells around its own for its candidates.
void ProgramPass::list_candidates(const std::vector<Vec3>& x) {
    const std::size_t n = x.size();
    rad_.resize(n);
    for (std::size_t j = 0; j < n; ++j) rad_[j] = catom_radius(scene_, ids_[present_[j]]);
    const double edge = edge_ + skin_;
    Vec3 high{-1e300, -1e300, -1e300};
    low_ = {1e300, 1e300, 1e300};
    for (std::size_t j = 0; j < n; ++j) {
        for (int a = 0; a < 3; ++a) low_[a] = std::min(low_[a], x[j][a]), high[a] = std::max(high[a], x[j][a]);
    }
    double cells = 1;
    for (int a = 0; a < 3; ++a) {
        dims_[a] = n ? static_cast<std::int64_t>((high[a] - low_[a]) / edge) + 1 : 1;
        cells *= static_cast<double>(dims_[a]);
    }
    const auto cell = [&](const Vec3& p, int a) { return static_cast<std::int64_t>((p[a] - low_[a]) / edge); };
    sorted_.clear();
    start_.clear();
    if (cells <= 8.0 * static_cast<double>(n) + 64) {
        start_.assign(static_cast<std::size_t>(cells) + 1, 0);
        order_.resize(n);
        std::vector<std::uint32_t> of(n);
        for (std::size_t j = 0; j < n; ++j) {
            of[j] = static_cast<std::uint32_t>((cell(x[j], 0) * dims_[1] + cell(x[j], 1)) * dims_[2] + cell(x[j], 2));
            ++start_[of[j] + 1];
        }
        for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
        std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
        for (std::size_t j = 0; j < n; ++j) order_[fill[of[j]]++] = static_cast<std::uint32_t>(j);
    } else {
        sorted_.resize(n);
        for (std::size_t j = 0; j < n; ++j) {
            sorted_[j] = {(cell(x[j], 0) << 42) | (cell(x[j], 1) << 21) | cell(x[j], 2), static_cast<std::uint32_t>(j)};
        }
        std::sort(sorted_.begin(), sorted_.end());
    }
    const std::size_t chunks = chunk_count(exec_.loops(), n, 1024);
    std::vector<std::vector<std::uint32_t>> part(chunks);
    cand_.at.assign(n + 1, 0);
    exec_.loops().run(chunks, n, [&](std::size_t c) {
        std::vector<std::uint32_t> mine;
        for (std::size_t j = chunk_begin(n, chunks, c); j < chunk_begin(n, chunks, c + 1); ++j) {
            if (!owned_now_[present_[j]]) continue;
            const std::size_t from = mine.size();
            candidates_of(j, x, mine);
            cand_.at[j + 1] = static_cast<std::uint32_t>(mine.size() - from);
        }
        part[c] = std::move(mine);
    });
    for (std::size_t j = 0; j < n; ++j) cand_.at[j + 1] += cand_.at[j];
    join(part, cand_.ids);
    listed_x_ = x;
    listed_present_ = present_;
    listed_owned_ = owned_;
    ++counts_.lists;
}

// The candidates (held-catom indices, ascending) of held catom j, appended to `out`.
void ProgramPass::candidates_of(std::size_t j, const std::vector<Vec3>& x, std::vector<std::uint32_t>& out) const {
    const std::size_t from = out.size();
    const double edge = edge_ + skin_;
    std::int64_t c[3];
    for (int a = 0; a < 3; ++a) c[a] = static_cast<std::int64_t>((x[j][a] - low_[a]) / edge);
    for (int d = 0; d < 27; ++d) {
        const std::int64_t cx = c[0] + d % 3 - 1, cy = c[1] + d / 3 % 3 - 1, cz = c[2] + d / 9 - 1;
        if (!start_.empty()) {
            if (cx < 0 || cy < 0 || cz < 0 || cx >= dims_[0] || cy >= dims_[1] || cz >= dims_[2]) continue;
            const std::size_t cell = static_cast<std::size_t>((cx * dims_[1] + cy) * dims_[2] + cz);
            for (std::uint32_t s = start_[cell]; s < start_[cell + 1]; ++s) {
                if (close(x, j, order_[s], skin_)) out.push_back(order_[s]);
            }
        } else {
            const std::int64_t want = (cx << 42) | (cy << 21) | cz;
            auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::make_pair(want, std::uint32_t{0}));
            for (; it != sorted_.end() && it->first == want; ++it) {
                if (close(x, j, it->second, skin_)) out.push_back(it->second);
            }
        }
    }
    std::sort(out.begin() + static_cast<std::ptrdiff_t>(from), out.end());
}

}  // namespace parode
