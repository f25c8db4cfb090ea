// Per-body data of a distributed world brought together in global-id order:
// each process packs (gid, row) for its owned bodies, the root places the
// rows by gid. Used for trajectory frames, snapshots, the guard's dump and
// the checks, so that their files and verdicts do not depend on the number
// of processes.
// Trade-off: the root holds every row (width x 8 bytes a body) while it
// writes; fine for output, not for anything on the hot path.
#pragma once
#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "domain/domain.hpp"
#include "world/world.hpp"

namespace parode {

// Rows of `width` doubles for every body of the scene, in gid order, on the
// root (an empty vector elsewhere). row(local, out) fills an owned body's row;
// `only` (sorted gids) restricts the gather to those bodies (rows of the
// others stay NaN).
template <class Row>
std::vector<double> gather_rows(const Domain& domain, const World& world, int width, Row row,
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

// The root's text on every process.
inline std::string from_root(const Domain& domain, const std::string& text) {
    const std::vector<char> mine = domain.root() ? std::vector<char>(text.begin(), text.end()) : std::vector<char>{};
    const auto parts = domain.all_gather(mine);
    return std::string(parts.front().begin(), parts.front().end());
}

}  // namespace parode
