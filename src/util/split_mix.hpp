// SplitMix64: the seeded random source of scene generators (catom jitter).
// Counter-based: draw k of a stream is a pure function of (seed, k), so any
// range of draws is produced without the ones before it, and a process that
// builds only some catoms gets the same bits as one that builds them all.
// Trade-off: a statistically good but not cryptographic generator, chosen for
// its portability across standard libraries (std:: distributions are not).
#pragma once
#include <cstdint>

namespace parode {

class SplitMix64 {
public:
    explicit SplitMix64(std::uint64_t seed) : s_(seed) {}
    std::uint64_t next() { return mix(s_ += kGolden); }
    double uniform() { return to_unit(next()); }  // [0, 1)
    // Draw k (0-based) of the stream seeded with `seed`, without the draws before it.
    static std::uint64_t at(std::uint64_t seed, std::uint64_t k) { return mix(seed + (k + 1) * kGolden); }
    static double uniform_at(std::uint64_t seed, std::uint64_t k) { return to_unit(at(seed, k)); }
    static std::uint64_t mix(std::uint64_t z) {
        z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
        z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
        return z ^ (z >> 31);
    }

private:
    static constexpr std::uint64_t kGolden = 0x9E3779B97F4A7C15ULL;
    static double to_unit(std::uint64_t x) { return static_cast<double>(x >> 11) * 0x1.0p-53; }
    std::uint64_t s_;
};

}  // namespace parode
