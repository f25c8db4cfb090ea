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
// Its whole state goes into checkpoints (save_state / load_state).
// Trade-off: one process only for now (the pass refuses a distributed run:
// ghosts would need the programs' magnets and messages exchanged); neighbours
// found afresh each step from a cell list of the catoms (a dense grid, O(N)),
// kept as catom indices, and handed to a handler with their directions only
// when it runs: 24 bytes a catom a step instead of 40 a neighbour.
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
    // Everything the next step depends on (each catom's values, magnets,
    // timer, pending messages, program bytes and last neighbours; the step
    // and counts), for checkpoints; load_state takes it back (and sets the
    // world's magnet switches and values). Throws CheckpointError if it does
    // not fit this scene.
    std::vector<char> save_state() const;
    void load_state(World& world, const std::vector<char>& state);
    const ProgramSpec& spec() const { return *spec_; }
    // Catom gids in order, and value k of each (after the last step).
    const std::vector<std::uint32_t>& catoms() const { return ids_; }
    double value(std::size_t catom, int k) const;

    struct Catom;  // per catom: program, neighbours, mail, values (program_pass.cpp)

private:
    void bind(const World& world);
    void find_neighbours(const World& world);
    void neighbours_of(std::size_t k, const std::vector<Vec3>& x, std::vector<std::uint32_t>& out) const;
    void run_handlers(const World& world, double time);
    void finish_step(World& world);

    const Scene& scene_;
    Execution& exec_;
    const ProgramSpec* spec_;
    double reach_, edge_ = 0;
    std::vector<std::uint32_t> ids_;     // catom gids, ascending
    std::vector<std::uint32_t> locals_;  // their local indices (one process: fixed)
    std::vector<Catom> catoms_;
    // Neighbours as catom indices, this step's and last step's (CSR: the
    // neighbours of catom k are ids[at[k] .. at[k + 1]), ascending).
    struct Csr {
        std::vector<std::uint32_t> at, ids;
    } now_, before_;
    // The cell list of this step: a dense grid over the catoms' bounding box
    // (cell starts into `order`), or, when that would hold more than 8 cells
    // a catom, the catoms sorted by cell key.
    std::vector<std::uint32_t> start_, order_;
    std::vector<std::pair<std::int64_t, std::uint32_t>> sorted_;
    Vec3 low_{0, 0, 0};
    std::int64_t dims_[3] = {0, 0, 0};
    long step_ = 0;
    ProgramCounts counts_;
};

}  // namespace parode
