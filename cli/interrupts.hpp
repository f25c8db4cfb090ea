// SIGTERM and SIGINT during a run: a scheduler's wall-time warning or Ctrl-C.
// The handler only records the signal (and restores the default, so that a
// second Ctrl-C ends the process at once); after each step the run asks
// whether one arrived on any process (a reduction, so every process stops
// after the same step), then finishes that step's bookkeeping, writes a
// checkpoint and the run report marked "interrupted", and exits with 7.
// Trade-off: one small reduction per step on several processes; a signal is
// acted on at a step boundary only, so a single step must fit in the warning.
#pragma once
#include <string>

#include "domain/collectives.hpp"

namespace parode::cli {

class Interrupts {
public:
    Interrupts();   // installs the handlers
    ~Interrupts();  // restores the previous ones
    Interrupts(const Interrupts&) = delete;
    Interrupts& operator=(const Interrupts&) = delete;
    // Collective: true when any process got SIGTERM or SIGINT.
    bool requested(const Collectives& domain) const;
    // "SIGTERM" or "SIGINT" (of this process, or of any when none here).
    std::string name() const;
};

}  // namespace parode::cli
