// The single-process domain and the collectives built on the primitives
// (see domain.hpp).
#include "domain/domain.hpp"

#include "io/output_error.hpp"

#include <fstream>
#include <numeric>
#include <stdexcept>

namespace parode {

std::vector<std::uint32_t> Domain::initial_bodies(const Scene& scene) { return restart_bodies(scene); }

std::vector<std::uint32_t> Domain::restart_bodies(const Scene& scene) const {
    std::vector<std::uint32_t> ids(scene.body_count());
    std::iota(ids.begin(), ids.end(), 0u);
    return ids;
}

nlohmann::json Domain::report() const {
    return {{"ranks", 1}, {"imbalance", 1.0}, {"edge_cut", 0}, {"ghost_fraction", 0.0}, {"migrations", 0},
            {"repartitions", 0}, {"comm_seconds", 0.0}, {"comm_bytes", 0}, {"messages_per_step", 0.0},
            {"setup_comm_seconds", 0.0}, {"setup_comm_bytes", 0}};
}

void Domain::sum(std::int64_t*, int) const {}
void Domain::sum_wrapping(std::uint64_t*, int) const {}
void Domain::max(double*, int) const {}

void Domain::write_file(const std::string& path, const FilePieces& f) const {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    if (!out) throw OutputError(path + ": cannot open for writing");
    out.write(f.head.data(), static_cast<std::streamsize>(f.head.size()));
    for (std::size_t i = 0; i < f.gids.size(); ++i) {
        out.seekp(static_cast<std::streamoff>(f.records_at + f.gids[i] * f.record));
        out.write(f.records.data() + i * f.record, static_cast<std::streamsize>(f.record));
    }
    out.seekp(static_cast<std::streamoff>(f.tail_at));
    out.write(f.tail.data(), static_cast<std::streamsize>(f.tail.size()));
    out.flush();
    if (!out) throw OutputError(path + ": write failed (disk full?)");
}

std::vector<std::vector<char>> Domain::all_gather(const std::vector<char>& mine) const { return {mine}; }
std::vector<std::vector<char>> Domain::gather(const std::vector<char>& mine) const { return {mine}; }
std::vector<std::vector<char>> Domain::all_to_all(const std::vector<std::vector<char>>& out) const { return out; }

void Domain::sum(ExactSum* s, int n) const {
    if (!distributed()) return;
    constexpr int w = ExactSum::kDigits + 3;
    std::vector<std::int64_t> flat(static_cast<std::size_t>(w) * static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) {
        s[i].normalise();
        std::int64_t* f = flat.data() + static_cast<std::size_t>(w) * static_cast<std::size_t>(i);
        for (int d = 0; d < ExactSum::kDigits; ++d) f[d] = s[i].digits()[static_cast<std::size_t>(d)];
        f[ExactSum::kDigits] = s[i].nan_count();
        f[ExactSum::kDigits + 1] = s[i].pos_inf();
        f[ExactSum::kDigits + 2] = s[i].neg_inf();
    }
    sum(flat.data(), static_cast<int>(flat.size()));
    for (int i = 0; i < n; ++i) {
        const std::int64_t* f = flat.data() + static_cast<std::size_t>(w) * static_cast<std::size_t>(i);
        for (int d = 0; d < ExactSum::kDigits; ++d) s[i].digits()[static_cast<std::size_t>(d)] = f[d];
        s[i].nan_count() = f[ExactSum::kDigits];
        s[i].pos_inf() = f[ExactSum::kDigits + 1];
        s[i].neg_inf() = f[ExactSum::kDigits + 2];
    }
}

double Domain::max(double v) const {
    max(&v, 1);
    return v;
}

double Domain::min(double v) const { return -max(-v); }

std::int64_t Domain::sum(std::int64_t v) const {
    sum(&v, 1);
    return v;
}

std::string Domain::all_text(const std::string& mine, const std::string& separator) const {
    std::string out;
    for (const auto& part : all_gather(std::vector<char>(mine.begin(), mine.end()))) {
        if (part.empty()) continue;
        if (!out.empty()) out += separator;
        out.append(part.begin(), part.end());
    }
    return out;
}

}  // namespace parode
