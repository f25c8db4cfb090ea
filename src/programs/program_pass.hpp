// The catom programs' pass, the first of the forces stage: each step it finds
// every catom's neighbours (centres within the two radii plus the reach),
// runs each catom's handlers — start (first step), neighbours lost, then
// gained (by id), the messages sent to it the step before (by sender id, then
// sending order), its timer — on the run's threads, one catom per call, and
// then, serially and in id order, switches the magnets the programs asked
// for (the magnets pass that follows sees them) and files the messages sent
// for delivery next step. Every catom's values, magnets, timer, pending
// messages and program bytes go into the state hash.
// Errors (a handler's exception, a message to a non-neighbour, a sender past
// its budget) end the run with a ProgramError naming the lowest such catom,
// its event and the message: the same on every thread count.
// Trade-off: one process only for now (the pass refuses a distributed run:
// ghosts would need the programs' magnets and messages exchanged); neighbours
// by a sorted cell list of the catoms each step, O(N log N).
#pragma once
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "exec/execution.hpp"
#include "forces/force_pass.hpp"
#include "programs/program.hpp"

namespace parode {

struct ProgramCounts {
    std::uint64_t steps = 0, messages = 0, events = 0;
    double seconds = 0;
};

class ProgramPass final : public ForcePass {
public:
    ProgramPass(const Scene& scene, Execution& exec);
    ~ProgramPass() override;
    ProgramPass(Scene&&, Execution&) = delete;  // keeps a reference to the scene
    std::string name() const override { return "program:" + spec_->name; }
    void apply(World& world, double time) override;
    const ProgramCounts& counts() const { return counts_; }
    const ProgramSpec& spec() const { return *spec_; }
    // Catom gids in order, and value k of each (after the last step).
    const std::vector<std::uint32_t>& catoms() const { return ids_; }
    double value(std::size_t catom, int k) const;

    struct Catom;  // per catom: program, neighbours, mail, values (program_pass.cpp)

private:
    void find_neighbours(const World& world);
    void run_handlers(const World& world, double time);
    void finish_step(World& world);

    const Scene& scene_;
    Execution& exec_;
    const ProgramSpec* spec_;
    double reach_;
    std::vector<std::uint32_t> ids_;  // catom gids, ascending
    std::vector<Catom> catoms_;
    long step_ = 0;
    ProgramCounts counts_;
};

}  // namespace parode
