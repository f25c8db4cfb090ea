// FNV-1a 64-bit digest over raw bytes: the state hash and contact digests.
// Trade-off: not cryptographic, but bitwise (any last-bit change shows) and fast.
#pragma once
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>

namespace parode {

class Fnv1a {
public:
    void add_bytes(const void* p, std::size_t n) {
        const auto* b = static_cast<const unsigned char*>(p);
        for (std::size_t i = 0; i < n; ++i) {
            h_ ^= b[i];
            h_ *= 1099511628211ULL;
        }
    }
    void add(std::uint32_t v) { add_bytes(&v, sizeof v); }
    void add_doubles(const double* p, std::size_t n) { add_bytes(p, n * sizeof(double)); }
    std::uint64_t value() const { return h_; }

private:
    std::uint64_t h_ = 1469598103934665603ULL;
};

inline std::string hex64(std::uint64_t v) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(v));
    return buf;
}

}  // namespace parode
