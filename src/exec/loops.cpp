// The serial loop runner ("loops") and the chunking of a loop (see loops.hpp).
#include "exec/loops.hpp"

#include <algorithm>

namespace parode {

int LoopRunner::threads(std::size_t /*items*/) const { return 1; }

void LoopRunner::run(std::size_t chunks, std::size_t /*items*/, const std::function<void(std::size_t)>& f) const {
    for (std::size_t c = 0; c < chunks; ++c) f(c);
}

std::size_t chunk_count(const LoopRunner& loops, std::size_t n, std::size_t grain) {
    const std::size_t t = static_cast<std::size_t>(loops.threads(n));
    const std::size_t wanted = (n + grain - 1) / std::max<std::size_t>(grain, 1);
    return std::max<std::size_t>(1, std::min(wanted, t == 1 ? 1 : 16 * t));
}

}  // namespace parode
