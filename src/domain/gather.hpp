// Per-body data of a distributed world brought together in global-id order:
// each process packs (gid, row) for its owned bodies, and either the root
// places every row by gid (gather_rows: trajectory frames, CSV snapshots, the
// guard's dump, the checks) or each process gets the rows of one contiguous
// block of ids (block_rows: H5MD snapshots, which every process writes
// together), so that files and verdicts do not depend on the number of
// processes.
// Trade-off: gather_rows has the root hold every row (width x 8 bytes a
// body) while it writes; block_rows spreads them, at the price of an
// all-to-all exchange. Both are for output, not for the hot path.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "domain/collectives.hpp"
#include "world/world.hpp"

namespace parode {

// Rows of `width` doubles for every body of the scene, in gid order, on the
// root (an empty vector elsewhere). row(local, out) fills an owned body's row;
// `only` (sorted gids) restricts the gather to those bodies (rows of the
// others stay NaN).
template <class Row>
std::vector<double> gather_rows(const Collectives& domain, const World& world, int width, Row row,
                                const std::vector<std::uint32_t>* only = nullptr) {
    const std::size_t w = static_cast<std::size_t>(width);
    const std::size_t rec = sizeof(std::uint32_t) + w * sizeof(double);
    std::vector<char> mine;
    std::vector<double> buf(w);
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (world.ghost(i)) continue;
        const std::uint32_t gid = world.gid(i);
        if (only && !std::binary_search(only->begin(), only->end(), gid)) continue;
        row(i, buf.data());
        const std::size_t at = mine.size();
        mine.resize(at + rec);
        std::memcpy(mine.data() + at, &gid, sizeof gid);
        std::memcpy(mine.data() + at + sizeof gid, buf.data(), w * sizeof(double));
    }
    const auto parts = domain.gather(mine);
    if (!domain.root()) return {};
    std::vector<double> out(world.global_body_count() * w, std::nan(""));
    for (const auto& part : parts) {
        for (std::size_t at = 0; at + rec <= part.size(); at += rec) {
            std::uint32_t gid;
            std::memcpy(&gid, part.data() + at, sizeof gid);
            std::memcpy(out.data() + gid * w, part.data() + at + sizeof gid, w * sizeof(double));
        }
    }
    return out;
}

// The ids [first, first + count) whose rows process `rank` of `ranks` holds
// in block_rows: equal blocks in gid order, the first ones one smaller.
struct IdBlock {
    std::uint64_t first = 0;
    std::uint64_t count = 0;
};
inline IdBlock id_block(std::uint64_t total, int rank, int ranks) {
    const auto at = [&](int r) { return total * static_cast<std::uint64_t>(r) / static_cast<std::uint64_t>(ranks); };
    return {at(rank), at(rank + 1) - at(rank)};
}

// The process whose id block holds `gid`, given every block's end (ascending).
inline std::size_t block_of(const std::vector<std::uint64_t>& ends, std::uint32_t gid) {
    return static_cast<std::size_t>(std::upper_bound(ends.begin(), ends.end(), gid) - ends.begin());
}

// Rows of `width` doubles for the bodies of this process's id block (count x
// width, in gid order); row(local, out) fills an owned body's row. Every row
// of the block is filled, since every body has one owner. One process fills
// its rows in place; several pack (gid, row) records into one buffer in
// destination order, sized exactly, and exchange it in one all-to-all, the
// rows made only once the records sent are freed (at most two of the three
// buffers, each about a row a body, are held at once).
template <class Row>
std::vector<double> block_rows(const Collectives& domain, const World& world, int width, Row row) {
    const std::size_t w = static_cast<std::size_t>(width);
    const IdBlock mine = id_block(world.global_body_count(), domain.rank(), domain.ranks());
    if (!domain.distributed()) {
        std::vector<double> rows(mine.count * w, std::nan(""));
        for (std::size_t i = 0; i < world.body_count(); ++i) row(i, rows.data() + world.gid(i) * w);
        return rows;
    }
    std::vector<std::uint64_t> ends(static_cast<std::size_t>(domain.ranks()));
    for (int r = 0; r < domain.ranks(); ++r) {
        const IdBlock b = id_block(world.global_body_count(), r, domain.ranks());
        ends[static_cast<std::size_t>(r)] = b.first + b.count;
    }
    const std::size_t rec = sizeof(std::uint32_t) + w * sizeof(double);
    std::vector<std::size_t> counts(ends.size(), 0);
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (!world.ghost(i)) counts[block_of(ends, world.gid(i))] += rec;
    }
    std::vector<std::size_t> fill(ends.size(), 0);  // where each destination's next record goes
    for (std::size_t r = 1; r < ends.size(); ++r) fill[r] = fill[r - 1] + counts[r - 1];
    std::vector<char> flat(fill.back() + counts.back());
    std::vector<double> buf(w);
    for (std::size_t i = 0; i < world.body_count(); ++i) {
        if (world.ghost(i)) continue;
        const std::uint32_t gid = world.gid(i);
        const std::size_t to = block_of(ends, gid);
        row(i, buf.data());
        std::memcpy(flat.data() + fill[to], &gid, sizeof gid);
        std::memcpy(flat.data() + fill[to] + sizeof gid, buf.data(), w * sizeof(double));
        fill[to] += rec;
    }
    const std::vector<char> in = domain.all_to_all(std::move(flat), counts);  // the records sent, freed
    std::vector<double> rows(mine.count * w, std::nan(""));
    for (std::size_t at = 0; at + rec <= in.size(); at += rec) {
        std::uint32_t gid;
        std::memcpy(&gid, in.data() + at, sizeof gid);
        std::memcpy(rows.data() + (gid - mine.first) * w, in.data() + at + sizeof gid, w * sizeof(double));
    }
    return rows;
}

// The root's text on every process.
inline std::string from_root(const Collectives& domain, const std::string& text) {
    const std::vector<char> mine = domain.root() ? std::vector<char>(text.begin(), text.end()) : std::vector<char>{};
    const auto parts = domain.all_gather(mine);
    return std::string(parts.front().begin(), parts.front().end());
}

}  // namespace parode
