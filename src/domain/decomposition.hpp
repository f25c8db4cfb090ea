// Decomposition: how a run's bodies are spread over processes, the seam
// between the serial core and the distributed layer. The pipeline asks it
// which bodies to build, moves bodies and refreshes ghost copies through it
// (stages "migrate" and "exchange"), hands its CorrectionExchange to the
// contact solver, and checks the invariants of ownership through it. What
// the processes do together for output and reductions is its Collectives
// (collectives.hpp), which the stages that only reduce or write see alone.
// This base class is the single-process decomposition ("single" in the
// stage registry): it owns every body, has no ghosts and exchanges nothing.
// mpi/ implements the distributed one ("mpi") on the same interface.
// Trade-off: one virtual call per stage per step, against a pipeline that
// reads the same whether it runs on one process or many.
#pragma once
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "domain/collectives.hpp"
#include "scene/scene.hpp"

namespace parode {

class World;
struct WarmImpulse;
class CorrectionExchange;

class Decomposition {
public:
    virtual ~Decomposition() = default;
    // The processes of the run, for reductions and output.
    virtual const Collectives& collectives() const { return single_; }
    int rank() const { return collectives().rank(); }
    int ranks() const { return collectives().ranks(); }
    bool root() const { return collectives().root(); }
    bool distributed() const { return collectives().distributed(); }

    // Throws SceneError naming the reason when `scene` cannot run on this
    // decomposition (collide/solver: the chosen backends).
    virtual void check_scene(const Scene& /*scene*/, const std::string& /*collide*/,
                             const std::string& /*solver*/) const {}
    // The global ids this process weighs first: a contiguous block of the
    // scene's (every id on one process).
    virtual std::vector<std::uint32_t> block(const Scene& scene) const;
    // The global ids this process builds, given where the bodies of its
    // block start (`positions[k]` of `block[k]`: the scene's positions for a
    // fresh run, the checkpoint's for a restart). Collective where
    // distributed: the cells are partitioned first, so each process builds
    // the bodies it will own and setup moves none.
    virtual std::vector<std::uint32_t> initial_bodies(const Scene& scene, const std::vector<std::uint32_t>& block,
                                                      const std::vector<Vec3>& positions);
    // initial_bodies for a fresh run: the block at its scene positions.
    std::vector<std::uint32_t> initial_bodies(const Scene& scene);
    // Once, after the World is built: assign cells, move bodies to their
    // owners, make ghosts.
    virtual void setup(World& /*world*/, std::vector<WarmImpulse>* /*warm*/) {}
    // Stage "migrate": bodies whose cell has another owner move there with
    // their warm-start impulses; repartition when the load is imbalanced.
    virtual void migrate(World& /*world*/, std::vector<WarmImpulse>* /*warm*/, long /*step*/) {}
    // Stage "exchange": ghosts take their owners' states, then their forces.
    virtual void exchange_states(World& /*world*/) {}
    virtual void exchange_forces(World& /*world*/) {}
    virtual CorrectionExchange* corrections() { return nullptr; }
    // Invariants (one owner per body, constant count, ghosts equal owners);
    // throws SimulationError naming bodies and ranks.
    virtual void check_invariants(const World& /*world*/, long /*step*/) {}
    // The run report's `parallel` block.
    virtual nlohmann::json report() const;
    // Why the stages run or not, for the run report.
    virtual std::string why() const { return "one process: nothing to exchange"; }

private:
    Collectives single_;
};

}  // namespace parode
