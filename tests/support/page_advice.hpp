// Reading back huge-page advice from the kernel's own account of the process's
// mappings (/proc/self/smaps, VmFlags "hg"), for tests of buffers' advice.
// Trade-off: Linux only; callers skip where the kernel refuses the advice.
#pragma once
#include <sys/mman.h>

#include <cstdint>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "util/huge_pages.hpp"

namespace parode::test {

struct Mapping {
    std::uintptr_t begin = 0, end = 0;
    bool huge = false;  // advised MADV_HUGEPAGE
};

inline std::vector<Mapping> mappings() {
    std::vector<Mapping> out;
    std::ifstream smaps("/proc/self/smaps");
    std::string line;
    while (std::getline(smaps, line)) {
        std::uintptr_t b = 0, e = 0;
        char dash = 0;
        std::istringstream range(line);
        // A mapping's header ("begin-end perms offset dev:inode ...") has its
        // first ':' after a space; a field line ("Size:  4 kB") before one.
        if (range >> std::hex >> b >> dash >> e && dash == '-' && line.find(' ') != std::string::npos &&
            line.find(':') > line.find(' ')) {
            out.push_back(Mapping{b, e, false});
        } else if (line.rfind("VmFlags:", 0) == 0 && !out.empty()) {
            out.back().huge = (" " + line.substr(8) + " ").find(" hg ") != std::string::npos;
        }
    }
    return out;
}

// Whether the kernel advises huge pages at all (MADV_HUGEPAGE accepted).
inline bool huge_pages_supported() {
    void* p = mmap(nullptr, 2 * kHugePage, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (p == MAP_FAILED) return false;
    const bool ok = madvise(p, 2 * kHugePage, MADV_HUGEPAGE) == 0;
    munmap(p, 2 * kHugePage);
    return ok;
}

// Whether the byte at `a` lies in a mapping advised huge pages.
inline bool advised(std::uintptr_t a) {
    for (const Mapping& m : mappings()) {
        if (a >= m.begin && a < m.end) return m.huge;
    }
    return false;
}

}  // namespace parode::test
