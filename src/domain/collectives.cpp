// The single-process collectives and those built on the primitives (see
// collectives.hpp).
#include "domain/collectives.hpp"

#include "util/errors.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

namespace parode {

void Collectives::sum(std::int64_t*, int) const {}
void Collectives::sum_wrapping(std::uint64_t*, int) const {}
void Collectives::max(double*, int) const {}

bool write_at(int fd, const char* data, std::size_t n, std::uint64_t at) {
    while (n > 0) {
        const ssize_t w = ::pwrite(fd, data, n, static_cast<off_t>(at));
        if (w < 0 && errno == EINTR) continue;
        if (w <= 0) return false;
        data += w;
        n -= static_cast<std::size_t>(w);
        at += static_cast<std::uint64_t>(w);
    }
    return true;
}

// The records a piece at a time, each run of consecutive ids in a piece in
// one write, then the tail a piece at a time; then fsync, so that the bytes
// are on the disk before the caller renames the file into place.
void Collectives::write_file(const std::string& path, const FilePieces& f) const {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) throw OutputError(path + ": cannot open for writing (" + std::strerror(errno) + ")");
    bool ok = write_at(fd, f.head.data(), f.head.size(), 0);
    std::vector<char> piece(std::min(f.gids.size(), f.piece) * f.record);
    each_piece(f.gids.size(), f.piece, [&](std::size_t first, std::size_t n) {
        if (!ok) return;
        f.pack(first, n, piece.data());
        for (std::size_t i = first; ok && i < first + n;) {
            std::size_t j = i + 1;
            while (j < first + n && f.gids[j] == f.gids[j - 1] + 1) ++j;
            ok = write_at(fd, piece.data() + (i - first) * f.record, (j - i) * f.record, f.records_at + f.gids[i] * f.record);
            i = j;
        }
    });
    piece.resize(std::min(f.tail_count, f.piece) * f.tail_record);
    each_piece(f.tail_count, f.piece, [&](std::size_t first, std::size_t n) {
        if (!ok) return;
        f.pack_tail(first, n, piece.data());
        ok = write_at(fd, piece.data(), n * f.tail_record, f.tail_at + first * f.tail_record);
    });
    ok = ok && ::fsync(fd) == 0;
    const int err = errno;
    ok = (::close(fd) == 0) && ok;
    if (!ok) throw OutputError(path + ": write failed (" + std::strerror(err) + ")");
}

std::vector<std::vector<char>> Collectives::all_gather(const std::vector<char>& mine) const { return {mine}; }
std::vector<std::vector<char>> Collectives::gather(const std::vector<char>& mine) const { return {mine}; }
std::vector<std::vector<char>> Collectives::all_to_all(const std::vector<std::vector<char>>& out) const { return out; }
std::vector<char> Collectives::all_to_all(std::vector<char> flat, const std::vector<std::size_t>& /*counts*/) const {
    return flat;
}

std::vector<std::vector<char>> Collectives::sparse_to(const std::vector<std::vector<char>>& out, int /*channel*/) const {
    return out;
}

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
