// The serial loop runner and the choice of runner (see parallel.hpp).
#include "util/parallel.hpp"

#include <algorithm>

namespace parode {
namespace {
const LoopRunner serial_runner;
const LoopRunner* current = &serial_runner;
}  // namespace

int LoopRunner::threads(std::size_t /*items*/) const { return 1; }

void LoopRunner::run(std::size_t chunks, std::size_t /*items*/, const std::function<void(std::size_t)>& f) const {
    for (std::size_t c = 0; c < chunks; ++c) f(c);
}

const LoopRunner& loops() { return *current; }
void set_loop_runner(const LoopRunner* runner) { current = runner ? runner : &serial_runner; }

std::size_t chunk_count(std::size_t n, std::size_t grain) {
    const std::size_t t = static_cast<std::size_t>(loops().threads(n));
    const std::size_t wanted = (n + grain - 1) / std::max<std::size_t>(grain, 1);
    return std::max<std::size_t>(1, std::min(wanted, t == 1 ? 1 : 16 * t));
}

}  // namespace parode
