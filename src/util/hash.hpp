// FNV-1a 64-bit digest over raw bytes: the state hash and contact digests.
// FNV-1a is one multiply per byte, each waiting for the last (a body's 108
// bytes are a chain of over 400 cycles), so digests of many equal-sized
// records are summed K at a time, their K chains advanced together.
// Trade-off: not cryptographic, but bitwise (any last-bit change shows) and fast.
#pragma once
#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace parode {

class Fnv1a {
public:
    static constexpr std::uint64_t kBasis = 1469598103934665603ULL;
    static constexpr std::uint64_t kPrime = 1099511628211ULL;
    void add_bytes(const void* p, std::size_t n) {
        const auto* b = static_cast<const unsigned char*>(p);
        for (std::size_t i = 0; i < n; ++i) {
            h_ ^= b[i];
            h_ *= kPrime;
        }
    }
    void add(std::uint32_t v) { add_bytes(&v, sizeof v); }
    void add_doubles(const double* p, std::size_t n) { add_bytes(p, n * sizeof(double)); }
    std::uint64_t value() const { return h_; }

private:
    std::uint64_t h_ = kBasis;
};

// The sum modulo 2^64 of the FNV-1a digests of records of N bytes each,
// the same bits as adding Fnv1a values one by one. Records are gathered K at
// a time; their K digests then run byte by byte side by side.
template <std::size_t N, std::size_t K = 8>
class Fnv1aSum {
public:
    // The next record's bytes, to be filled (all N of them) by the caller.
    unsigned char* next() {
        if (filled_ == K) flush();
        return rec_[filled_++].data();
    }
    // The sum over every record given so far.
    std::uint64_t value() {
        flush();
        return sum_;
    }

private:
    void flush() {
        if (filled_ == 0) return;
        std::uint64_t h[K];
        for (std::size_t k = 0; k < K; ++k) h[k] = Fnv1a::kBasis;
        for (std::size_t i = 0; i < N; ++i) {
            for (std::size_t k = 0; k < K; ++k) h[k] = (h[k] ^ rec_[k][i]) * Fnv1a::kPrime;
        }
        for (std::size_t k = 0; k < filled_; ++k) sum_ += h[k];
        filled_ = 0;
    }
    std::array<std::array<unsigned char, N>, K> rec_{};
    std::size_t filled_ = 0;
    std::uint64_t sum_ = 0;
};

inline std::string hex64(std::uint64_t v) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
    return buf;
}

}  // namespace parode
