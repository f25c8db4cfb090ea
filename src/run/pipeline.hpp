// The step pipeline: migrate -> exchange -> forces -> collide -> joints ->
// solve -> observe -> output, each stage timed, each enabled only when the
// scene and the domain need it (the reason is recorded for the run report).
// Every stage implementation comes from the one stage registry
// (run/stages.hpp) and gets the pipeline's own execution context
// (exec/execution.hpp: threads, crossovers, loop runner, scratch pool), built
// from RunOptions::execution: the collide backend, the solver, the force
// passes the scene needs, and the decomposition over processes (migrate and
// exchange do nothing on one process). The contacts of the initial state are
// computed at construction, so the first observed frame has its penetration,
// and the first step reuses them (nothing has moved in between).
// Trade-off: one virtual call per stage per step; negligible next to the work.
#pragma once
#include <array>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>

#include "collide/collide.hpp"
#include "domain/decomposition.hpp"
#include "exec/execution.hpp"
#include "forces/force_pass.hpp"
#include "io/checkpoint.hpp"
#include "io/snapshot.hpp"
#include "io/trajectory.hpp"
#include "observe/diagnostics.hpp"
#include "observe/guard.hpp"
#include "programs/program_pass.hpp"
#include "run/checks.hpp"
#include "solve/solver.hpp"
#include "util/errors.hpp"
#include "util/substages.hpp"
#include "world/world.hpp"

namespace parode {

enum class Stage : int { Migrate, Exchange, Forces, Collide, Joints, Solve, Observe, Output, Count };
constexpr int kStageCount = static_cast<int>(Stage::Count);
const char* stage_name(Stage s);

struct StageState {
    bool enabled = false;
    std::string reason;
    double seconds = 0;
    std::int64_t peak_growth = 0;  // bytes the process's peak memory rose by from the end of the stage before to this one's (steps only)
};

struct RunOptions {
    std::string collide = "ode-hash";  // a name of the stage registry's `collide`
    std::string solver = "ode";        // ... of its `solver`: "ode", "pgs", "parallel" (pgs/omp), ...
    ExecutionConfig execution;         // threads and how the stages use them
    std::string domain = "single";     // ... of its `domain`: "single", or "mpi" under a launcher
    std::string snapshot_path;  // snapshot file (io/snapshot.hpp: H5MD or CSV); empty: no output stage
    int snapshot_every = 0;
    long planned_steps = -1;  // the steps this run will take (-1: not known); sizes the snapshot file ahead
    bool record_trajectory = false;  // keep a Frame per observed step (and step 0)
    std::string dump_path;           // guard: where to write the last good state on failure
    Decomposition* decomposition = nullptr;  // a caller's own (a test's stand-in), instead of `domain`
    std::string restart_path;        // continue from this checkpoint
    int invariants_every = 0;        // steps between invariant checks; 0: the build's default
};

struct RunTotals {
    std::size_t contacts = 0;        // summed over all steps
    double max_penetration = 0;      // over observed steps
    double penetration_sum = 0;      // over contacts of observed steps
    std::size_t observed_contacts = 0;
    double mean_penetration() const { return observed_contacts ? penetration_sum / static_cast<double>(observed_contacts) : 0; }
};

class Pipeline {
public:
    Pipeline(const Scene& scene, const RunOptions& options);
    Pipeline(Scene&&, const RunOptions&) = delete;  // keeps a reference to the scene
    void step();
    // Observe now unless the last step was observed, and complete the
    // snapshot files (call once at the end).
    void finish();

    int steps_done() const { return steps_; }
    World& world() { return *world_; }
    const World& world() const { return *world_; }
    const ContactBuffer& contacts() const { return contacts_; }
    const StageState& stage(Stage s) const { return stages_[static_cast<int>(s)]; }
    const Diagnostics& last() const { return last_; }
    const RunTotals& totals() const { return totals_; }
    const CollideBackend& backend() const { return *backend_; }
    const Diagnostics& initial() const { return initial_; }
    const Decomposition& decomposition() const { return *domain_; }
    const Collectives& collectives() const { return domain_->collectives(); }
    const Execution& execution() const { return *exec_; }
    Execution& execution() { return *exec_; }
    // The force passes that run, in order (empty when the stage does not run).
    const std::vector<std::unique_ptr<ForcePass>>& force_passes() const { return forces_; }
    // The catom program's pass, or null.
    const ProgramPass* program() const { return program_; }
    const Guard& guard() const { return *guard_; }
    // Recorded frames (null unless RunOptions::record_trajectory).
    const Trajectory* trajectory() const { return trajectory_.get(); }
    // The [checks] verdict for the current state (null when the scene has no [checks]).
    nlohmann::json checks_result() const;
    const SolverBackend& solver() const { return *solver_; }
    // Collective: writes everything the next step depends on (io/checkpoint.hpp).
    void write_checkpoint(const std::string& path);
    // What the checkpoints written so far cost.
    const CheckpointCost& checkpoint_cost() const { return checkpoint_cost_; }
    // Restarted runs: bodies whose stored quaternion ODE could not be given
    // exactly (0 means the restart is bit for bit).
    std::int64_t inexact_restores() const { return inexact_; }
    // Empty when a restart continues the checkpointed run bit for bit, else why not.
    std::string restart_caveat() const;
    // What a restart checked of its checkpoint (verify_checkpoint), or null.
    const nlohmann::json& restart_checked() const { return checked_; }
    int first_step() const { return first_step_; }
    // Seconds of the collision run while the pipeline was built, when the first
    // step solved its contacts (that collision is then part of the steps'
    // work, not of the set-up); else 0.
    double collide_before_steps() const { return collide_reused_ ? setup_collide_s_ : 0.0; }
    // The process's peak memory when the set-up was done (bytes); what each
    // stage added to it since is StageState::peak_growth.
    std::int64_t setup_peak() const { return setup_peak_; }
    // The substage timers of a stage's backend (collide, solve), or null.
    const Substages* substages(Stage s) const;
    // The first step of this run alone (its collision included where it ran
    // while the pipeline was built): it pays one-time costs the later steps
    // do not (first touch of the step's buffers, the growth of the pile's
    // contacts), so the report shows it apart. Empty until that step is done.
    struct StepTimes {
        bool done = false;
        double wall = 0;
        std::array<double, kStageCount> stages{};
        std::array<std::optional<Substages>, kStageCount> substages;  // as Pipeline::substages gives them
    };
    const StepTimes& first_step_times() const { return first_times_; }

private:
    void plan_stages(const Scene& scene, const RunOptions& options);
    void make_force_passes();
    void open_checkpoint(const std::string& path);
    std::vector<std::uint32_t> restart_bodies();
    void restore(const std::vector<std::uint32_t>& gids);
    void restore_program();
    std::unique_ptr<Checkpoint> checkpoint_;  // a restart's, until the steps begin
    nlohmann::json checked_;                  // what the restart verified of it
    CheckpointCost checkpoint_cost_;
    void restore_run_state(const nlohmann::json& run);
    void run_migrate();
    void run_forces();
    void run_collide();
    GhostTest ghost_test_;               // distributed runs: contacts left to other processes
    bool backend_drops_ghosts_ = false;  // the backend leaves them out itself (set_ghost_test)
    void run_joints();
    void run_solve();
    void run_observe();
    void run_output();
    std::size_t planned_frames(const RunOptions& options) const;
    template <class F>
    void timed(Stage s, F&& f);

    const Scene& scene_;
    std::unique_ptr<Execution> exec_;  // first: every stage below keeps a reference to it
    std::unique_ptr<Decomposition> own_domain_;
    Decomposition* domain_ = nullptr;
    std::unique_ptr<CollideBackend> backend_;
    std::unique_ptr<World> world_;
    std::unique_ptr<SolverBackend> solver_;
    std::vector<std::unique_ptr<ForcePass>> forces_;
    ProgramPass* program_ = nullptr;
    Substages force_times_;  // per force pass
    ContactBuffer contacts_;
    std::array<StageState, kStageCount> stages_;
    Diagnostics initial_;
    Diagnostics last_;
    RunTotals totals_;
    std::unique_ptr<Guard> guard_;
    std::unique_ptr<Checker> checker_;
    std::unique_ptr<Trajectory> trajectory_;
    std::unique_ptr<SnapshotWriter> snapshot_;
    int snapshot_every_ = 0;
    int invariants_every_ = 0;
    int steps_ = 0;
    int first_step_ = 0;
    int last_observed_ = -1;
    std::int64_t inexact_ = 0;
    nlohmann::json restart_meta_;
    std::uint64_t contacts_of_ = ~0ULL;  // world generation the contacts are current for; ~0: stale
    double setup_collide_s_ = 0;          // the collision run by the constructor
    std::int64_t setup_peak_ = 0;         // peak memory at the end of the constructor
    std::int64_t last_peak_ = 0;          // ... when the last timed stage ended
    bool collide_reused_ = false;         // the first step solved those contacts
    StepTimes first_times_;
    void record_first_step(double wall);
};

}  // namespace parode
