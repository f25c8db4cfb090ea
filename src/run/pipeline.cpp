// Step pipeline (see pipeline.hpp).
#include "run/pipeline.hpp"

#include <chrono>

#include "domain/gather.hpp"
#include "io/checkpoint.hpp"
#include "run/stage_plan.hpp"
#include "run/stages.hpp"
#include "util/hash.hpp"
#include "util/heap_policy.hpp"
#include "util/peak_memory.hpp"

namespace parode {

const char* stage_name(Stage s) {
    static const char* names[kStageCount] = {"migrate", "exchange", "forces", "collide",
                                             "joints",  "solve",    "observe", "output"};
    return names[static_cast<int>(s)];
}

Pipeline::Pipeline(const Scene& scene, const RunOptions& options)
    : scene_(scene), exec_(Stages::instance().execution(options.execution)) {
    fix_mmap_threshold();  // before the world's buffers (util/heap_policy.hpp)
    const Stages& stages = Stages::instance();
    if (!options.decomposition) own_domain_ = stages.domain.make(options.domain, scene, *exec_);
    domain_ = options.decomposition ? options.decomposition : own_domain_.get();
    domain_->check_scene(scene, options.collide, options.solver);
    backend_ = stages.collide.make(options.collide, *exec_);
    if (!options.restart_path.empty()) open_checkpoint(options.restart_path);
    const std::vector<std::uint32_t> gids = checkpoint_ ? restart_bodies() : domain_->initial_bodies(scene);
    world_ = std::make_unique<World>(scene, backend_->space_kind(), &gids);
    backend_->set_geoms(world_->space(), &world_->geoms());
    backend_->set_sphere_bodies(world_->sphere_bodies());
    // Each contact belongs to the owner of its lower-id body. A contact's lo
    // is the id of its first geom, which is its body's gid (one geom a body):
    // looked up in the gid map instead of reading ODE's geom and body records
    // per contact (measured at 10^6 catoms on 2 ranks: 14 ms a step, a ninth
    // of the collide stage, before).
    if (domain_->distributed()) {
        ghost_test_.context = world_.get();
        ghost_test_.ghost = [](const void* w, std::uint32_t id) {
            const World& world = *static_cast<const World*>(w);
            return world.ghost(world.local_of(id));
        };
        ghost_test_.bodies = static_cast<std::uint32_t>(world_->global_body_count());
        backend_drops_ghosts_ = backend_->set_ghost_test(&ghost_test_);
    }
    world_->defer_moves(backend_->reads_sphere_poses() && world_->bodies_are_spheres());
    // A ghost is then an ODE body alone: its geom would be read by nothing.
    if (backend_->spheres_from_hint() && world_->sphere_bodies()) world_->set_ghost_geoms(false);
    solver_ = stages.solver.make(options.solver, scene, *exec_);
    solver_->set_exchange(domain_->corrections());
    if (checkpoint_) restore(gids);
    plan_stages(scene, options);
    if (stage(Stage::Forces).enabled) make_force_passes();
    snapshot_every_ = stage(Stage::Output).enabled ? options.snapshot_every : 0;
#ifdef NDEBUG
    invariants_every_ = options.invariants_every > 0 ? options.invariants_every : 100;
#else
    invariants_every_ = options.invariants_every > 0 ? options.invariants_every : 1;
#endif
    timed(Stage::Migrate, [this] { domain_->setup(*world_, solver_->warm_impulses()); });
    release_free_heap();  // the set-up's temporaries, before the first step's buffers
    if (checkpoint_ && program_) restore_program();  // the records of the catoms owned here after the set-up
    if (program_) program_->prepare(*world_);  // the records of the catoms owned here, made as the bodies were
    const double collide_before = stages_[static_cast<int>(Stage::Collide)].seconds;
    timed(Stage::Collide, [this] { run_collide(); });
    setup_collide_s_ = stages_[static_cast<int>(Stage::Collide)].seconds - collide_before;
    initial_ = observe(*world_, contacts_, collectives(), exec_->loops());
    last_ = initial_;
    guard_ = std::make_unique<Guard>(*world_, initial_, collectives(), exec_->loops(), options.dump_path);
    if (scene.checks.any()) checker_ = std::make_unique<Checker>(*world_, initial_, collectives());
    if (!restart_meta_.is_null()) restore_run_state(restart_meta_.at("run"));
    if (options.record_trajectory) {
        trajectory_ = std::make_unique<Trajectory>(make_trajectory(scene));
        trajectory_->meta["solver"]["backend"] = solver_->name();  // what ran, not only the [solver] table
        trajectory_->meta["collide"] = backend_->name();
        trajectory_->frames.push_back(capture_frame(*world_, initial_, steps_, steps_ * scene.dt, collectives()));
    }
    timed(Stage::Output, [&] {
        snapshot_ = make_snapshot_writer(options.snapshot_path, scene, *world_, collectives(), steps_, steps_ * scene.dt,
                                         planned_frames(options));
    });
    setup_peak_ = last_peak_ = peak_rss_bytes();  // the set-up's stages count here, not in their steps' shares
    for (StageState& st : stages_) st.peak_growth = 0;
}

// The passes the scene needs, in order: the catom program (it switches
// magnets), magnets, then the controller; each the threaded variant where
// one is built.
void Pipeline::make_force_passes() {
    const ForceRegistry& r = Stages::instance().forces;
    if (scene_.program.enabled) {
        forces_.push_back(r.make("program", scene_, *exec_));
        program_ = dynamic_cast<ProgramPass*>(forces_.back().get());
        program_->set_collectives(collectives());
    }
    if (scene_.any_magnets()) forces_.push_back(r.make(Stages::threaded(r, "magnets"), scene_, *exec_));
    if (scene_.controller.enabled) forces_.push_back(r.make(Stages::threaded(r, "controller"), scene_, *exec_));
}

// The checkpoint to restart from, refused unless it is of this scene.
void Pipeline::open_checkpoint(const std::string& path) {
    checkpoint_ = std::make_unique<Checkpoint>(read_checkpoint(path));
    const auto& m = checkpoint_->meta;
    const Checkpoint& c = *checkpoint_;
    if (m.value("scene_digest", std::string()) != hex64(scene_.digest) || c.bodies != scene_.body_count()) {
        throw std::invalid_argument("--restart " + path + ": written for scene '" + m.value("scene", std::string("?")) +
                                    "' (" + m.value("scene_file", std::string("?")) + ", digest " +
                                    m.value("scene_digest", std::string("?")) + ", " + std::to_string(c.bodies) +
                                    " bodies), not for this one (digest " + hex64(scene_.digest) + ", " +
                                    std::to_string(scene_.body_count()) + " bodies): restart with the same scene "
                                    "file and the same --set options");
    }
}

// The ids this process builds on a restart: its block's positions from the
// checkpoint, so that the cells are partitioned where the bodies are and
// each process builds the bodies it will own (none moves at setup). The
// blocks cover every id once, so their checksums verify the whole file
// before any position is used.
std::vector<std::uint32_t> Pipeline::restart_bodies() {
    const std::vector<std::uint32_t> block = domain_->block(scene_);
    std::vector<std::uint64_t> sums;
    const std::vector<CheckpointRecord> records = read_records(*checkpoint_, block, &sums);
    checked_ = verify_checkpoint(*checkpoint_, std::move(sums), collectives());  // collective; throws on damage
    std::vector<Vec3> at(block.size());
    for (std::size_t k = 0; k < block.size(); ++k) at[k] = {records[k].state.x[0], records[k].state.x[1], records[k].state.x[2]};
    return domain_->initial_bodies(scene_, block, at);
}

// Bodies from the checkpoint (this process's initial ids), ODE's dRand, the
// step counter and the warm-start impulses of those bodies.
void Pipeline::restore(const std::vector<std::uint32_t>& gids) {
    const Checkpoint& c = *checkpoint_;
    const auto& m = c.meta;
    const std::vector<CheckpointRecord> records = read_records(c, gids);
    std::int64_t inexact = 0;
    for (std::size_t k = 0; k < gids.size(); ++k) {
        const std::size_t local = world_->local_of(gids[k]);
        if (!world_->restore_state(local, records[k].state, records[k].ode_q)) ++inexact;
        world_->set_origin(local, records[k].origin);
        if (!records[k].enabled) dBodyDisable(world_->body(local));
    }
    inexact_ = collectives().sum(inexact);
    if (auto* warm = solver_->warm_impulses()) *warm = read_impulses(c, gids);
    world_->set_drand_seed(m.at("drand_seed").get<unsigned long>());
    steps_ = first_step_ = static_cast<int>(c.step);
    last_observed_ = steps_;
    restart_meta_ = m;
}

// The catom programs' state, from the checkpoint's extra section.
void Pipeline::restore_program() {
    ExtraReader state(*checkpoint_);  // its checksum checked
    if (state.size() == 0) {
        throw CheckpointError(checkpoint_->path + ": holds no catom programs' state (written without a [program]?)");
    }
    program_->load_state(*world_, state);
    if (checked_.is_object() && checked_.value("verified", false)) checked_["program_state"] = true;  // ExtraReader checked it
}

std::string Pipeline::restart_caveat() const {
    if (inexact_ > 0) return std::to_string(inexact_) + " bodies could not be given their exact quaternion";
    if (scene_.solver.auto_disable) {
        return "solver.auto_disable: ODE keeps its sleep counters to itself, so they start afresh and bodies may fall "
               "asleep a few steps apart from the uninterrupted run";
    }
    return "";
}

// Totals, guard and checks carry on from where the checkpointed run was.
void Pipeline::restore_run_state(const nlohmann::json& run) {
    const auto& t = run.at("totals");
    // The contacts of the restart step (collided at construction, reused by
    // the next step) come on top of the checkpointed sum.
    totals_.contacts = (domain_->root() ? t.at("contacts").get<std::size_t>() : 0) + contacts_.size();
    totals_.max_penetration = t.at("max_penetration").get<double>();
    totals_.penetration_sum = t.at("penetration_sum").get<double>();
    totals_.observed_contacts = t.at("observed_contacts").get<std::size_t>();
    guard_->restore(run.at("guard"));
    if (checker_ && run.contains("checks")) checker_->restore(run.at("checks"));
}

namespace {

// The catom programs' state as a checkpoint's section, piece by piece.
class ProgramSection final : public SectionSource {
public:
    explicit ProgramSection(const ProgramPass* pass) : pass_(pass) {}
    std::size_t pieces() const override { return pass_->state_pieces(); }
    void piece(std::size_t k, std::vector<char>& out) const override { pass_->state_piece(k, out); }

private:
    const ProgramPass* pass_;
};

}  // namespace

void Pipeline::write_checkpoint(const std::string& path) {
    const std::int64_t contacts = collectives().sum(static_cast<std::int64_t>(totals_.contacts));
    nlohmann::json run = {{"totals", {{"contacts", contacts}, {"max_penetration", totals_.max_penetration},
                                      {"penetration_sum", totals_.penetration_sum},
                                      {"observed_contacts", totals_.observed_contacts}}},
                          {"guard", guard_->state()}};
    if (checker_) run["checks"] = checker_->state();
    const nlohmann::json meta = {{"step", steps_}, {"time", steps_ * scene_.dt}, {"dt", scene_.dt},
                                 {"scene", scene_.name}, {"scene_file", scene_.source},
                                 {"scene_digest", hex64(scene_.digest)}, {"seed", scene_.seed},
                                 {"drand_seed", world_->drand_seed()}, {"solver", solver_->name()}, {"run", run}};
    const ProgramSection programs(program_);
    checkpoint_cost_ += parode::write_checkpoint(path, collectives(), *world_, solver_->warm_impulses(), meta,
                                                 program_ ? &programs : nullptr);
}

const Substages* Pipeline::substages(Stage s) const {
    if (s == Stage::Collide) return backend_->substages();
    if (s == Stage::Solve) return solver_->substages();
    if (s == Stage::Forces) return forces_.empty() ? nullptr : &force_times_;
    return nullptr;
}

nlohmann::json Pipeline::checks_result() const {
    return checker_ ? checker_->result(*world_, last_) : nlohmann::json();
}

void Pipeline::plan_stages(const Scene& scene, const RunOptions& options) {
    stages_ = stage_plan(scene, {domain_->distributed(), domain_->why(), backend_->name(), solver_->uses_contact_joints(),
                                 solver_->name(), solver_->why(), options.snapshot_path, options.snapshot_every});
}

template <class F>
void Pipeline::timed(Stage s, F&& f) {
    StageState& st = stages_[static_cast<int>(s)];
    if (!st.enabled) return;
    const auto t0 = std::chrono::steady_clock::now();
    f();
    st.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const std::int64_t peak = peak_rss_bytes();  // one read a stage: what came since the last is this stage's
    st.peak_growth += peak - last_peak_;
    last_peak_ = peak;
}

void Pipeline::step() {
    const double t0 = now_seconds();
    timed(Stage::Migrate, [this] { run_migrate(); });
    timed(Stage::Exchange, [this] {
        domain_->exchange_states(*world_);
        if (invariants_every_ > 0 && steps_ % invariants_every_ == 0) domain_->check_invariants(*world_, steps_);
    });
    timed(Stage::Forces, [this] { run_forces(); });
    if (stage(Stage::Forces).enabled) timed(Stage::Exchange, [this] { domain_->exchange_forces(*world_); });
    if (contacts_of_ != world_->generation()) {
        timed(Stage::Collide, [this] { run_collide(); });
    } else if (steps_ == first_step_) {
        collide_reused_ = true;
    }
    timed(Stage::Joints, [this] { run_joints(); });
    timed(Stage::Solve, [this] { run_solve(); });
    contacts_of_ = ~0ULL;  // bodies moved
    ++steps_;
    timed(Stage::Observe, [this] {
        guard_->check_step(*world_, steps_, solver_->wrote_finite_state(), solver_->max_speed_written());
    });
    if (steps_ % scene_.observe_every == 0) timed(Stage::Observe, [this] { run_observe(); });
    if (snapshot_every_ > 0 && steps_ % snapshot_every_ == 0) timed(Stage::Output, [this] { run_output(); });
    if (steps_ == first_step_ + 1) record_first_step(now_seconds() - t0 + collide_before_steps());
}

void Pipeline::record_first_step(double wall) {
    first_times_.done = true;
    first_times_.wall = wall;
    for (int s = 0; s < kStageCount; ++s) {
        const auto k = static_cast<std::size_t>(s);
        first_times_.stages[k] = stages_[k].seconds;
        if (const Substages* sub = substages(static_cast<Stage>(s))) first_times_.substages[k] = *sub;
    }
}

void Pipeline::finish() {
    if (last_observed_ != steps_) timed(Stage::Observe, [this] { run_observe(); });
    timed(Stage::Output, [this] { snapshot_->close(); });
    world_->sync_moves();  // ODE's spaces up to date for whoever reads them next
}

void Pipeline::run_migrate() { domain_->migrate(*world_, solver_->warm_impulses(), steps_); }

// Each pass timed apart (the forces stage's substages: program, magnets,
// controller).
void Pipeline::run_forces() {
    for (auto& pass : forces_) {
        const double t0 = now_seconds();
        pass->apply(*world_, steps_ * scene_.dt);
        const std::string name = pass->name();
        force_times_.add(name.substr(0, name.find_first_of(":/")).c_str(), now_seconds() - t0);
    }
}

void Pipeline::run_collide() {
    backend_->collide(world_->space(), scene_.solver.max_contacts, contacts_);
    if (domain_->distributed() && !backend_drops_ghosts_) drop_ghost_contacts(contacts_, ghost_test_);
    totals_.contacts += contacts_.size();
    contacts_of_ = world_->generation();
}

void Pipeline::run_joints() {
    dJointGroupEmpty(world_->contact_group());
    world_->create_contact_joints(contacts_);
}

void Pipeline::run_solve() { solver_->step(*world_, contacts_); }

void Pipeline::run_observe() {
    last_ = observe(*world_, contacts_, collectives(), exec_->loops());
    last_observed_ = steps_;
    totals_.max_penetration = std::max(totals_.max_penetration, last_.max_penetration);
    totals_.penetration_sum += last_.mean_penetration * static_cast<double>(last_.contacts);
    totals_.observed_contacts += last_.contacts;
    guard_->check_observed(*world_, last_, steps_);
    if (checker_) checker_->observe(*world_, last_);
    if (trajectory_) trajectory_->frames.push_back(capture_frame(*world_, last_, steps_, steps_ * scene_.dt, collectives()));
}

// The frames of the snapshot file: this step's and every K-th step's to come
// (0: not known).
std::size_t Pipeline::planned_frames(const RunOptions& options) const {
    if (options.planned_steps < 0 || snapshot_every_ <= 0) return 0;
    return static_cast<std::size_t>(1 + (steps_ + options.planned_steps) / snapshot_every_ - steps_ / snapshot_every_);
}

void Pipeline::run_output() { snapshot_->write(*world_, steps_, steps_ * scene_.dt); }

}  // namespace parode
