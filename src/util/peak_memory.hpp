// The process's peak resident memory so far, in bytes (getrusage's
// ru_maxrss; Linux reports KiB).
// Trade-off: one system call, about a microsecond, read around every stage
// of every step; the peak only rises, so what a stage adds to it is its share
// of the run's peak, and a stage that reuses memory an earlier one left
// resident adds nothing.
#pragma once
#include <sys/resource.h>

#include <cstdint>

namespace parode {

inline std::int64_t peak_rss_bytes() {
    rusage u{};
    getrusage(RUSAGE_SELF, &u);
    return static_cast<std::int64_t>(u.ru_maxrss) * 1024;
}

}  // namespace parode
