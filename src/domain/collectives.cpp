// The single-process collectives and those built on the primitives (see
// collectives.hpp).
#include "domain/collectives.hpp"

#include "util/errors.hpp"

#include <fstream>
#include <stdexcept>

namespace parode {

void Collectives::sum(std::int64_t*, int) const {}
void Collectives::sum_wrapping(std::uint64_t*, int) const {}
void Collectives::max(double*, int) const {}

void Collectives::write_file(const std::string& path, const FilePieces& f) const {
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

std::vector<std::vector<char>> Collectives::all_gather(const std::vector<char>& mine) const { return {mine}; }
std::vector<std::vector<char>> Collectives::gather(const std::vector<char>& mine) const { return {mine}; }
std::vector<std::vector<char>> Collectives::all_to_all(const std::vector<std::vector<char>>& out) const { return out; }

void Collectives::sum(ExactSum* s, int n) const {
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

double Collectives::max(double v) const {
    max(&v, 1);
    return v;
}

double Collectives::min(double v) const { return -max(-v); }

std::int64_t Collectives::sum(std::int64_t v) const {
    sum(&v, 1);
    return v;
}

std::string Collectives::all_text(const std::string& mine, const std::string& separator) const {
    std::string out;
    for (const auto& part : all_gather(std::vector<char>(mine.begin(), mine.end()))) {
        if (part.empty()) continue;
        if (!out.empty()) out += separator;
        out.append(part.begin(), part.end());
    }
    return out;
}

}  // namespace parode
