// Step pipeline (see pipeline.hpp).
#include "run/pipeline.hpp"

#include <chrono>

#include "domain/gather.hpp"
#include "forces/controller.hpp"

namespace parode {

const char* stage_name(Stage s) {
    static const char* names[kStageCount] = {"migrate", "exchange", "forces", "collide",
                                             "joints",  "solve",    "observe", "output"};
    return names[static_cast<int>(s)];
}

Pipeline::Pipeline(const Scene& scene, const RunOptions& options) : scene_(scene) {
    if (!options.domain) own_domain_ = std::make_unique<Domain>();
    domain_ = options.domain ? options.domain : own_domain_.get();
    domain_->check_scene(scene, options.collide, options.solver);
    backend_ = BackendRegistry::instance().make(options.collide);
    backend_->set_threads(options.threads);
    backend_->set_scratch(&scratch_);
    const std::vector<std::uint32_t> gids = domain_->initial_bodies(scene);
    world_ = std::make_unique<World>(scene, backend_->space_kind(), &gids);
    backend_->set_geoms(world_->space(), &world_->geoms());
    solver_ = SolverRegistry::instance().make(options.solver, scene, options.threads);
    solver_->set_exchange(domain_->corrections());
    solver_->set_scratch(&scratch_);
    plan_stages(scene, options);
    if (stage(Stage::Forces).enabled && scene.any_magnets()) magnets_ = std::make_unique<MagnetField>(scene);
    if (stage(Stage::Output).enabled && domain_->root()) {
        snapshot_.open(options.snapshot_path);
        if (!snapshot_) throw std::runtime_error(options.snapshot_path + ": cannot open snapshot file for writing");
        snapshot_ << "step,body,x,y,z,qw,qx,qy,qz\n";
    }
    snapshot_every_ = stage(Stage::Output).enabled ? options.snapshot_every : 0;
    snapshot_path_ = options.snapshot_path;
#ifdef NDEBUG
    invariants_every_ = options.invariants_every > 0 ? options.invariants_every : 100;
#else
    invariants_every_ = options.invariants_every > 0 ? options.invariants_every : 1;
#endif
    timed(Stage::Migrate, [this] { domain_->setup(*world_, solver_->warm_impulses()); });
    timed(Stage::Collide, [this] { run_collide(); });
    initial_ = observe(*world_, contacts_, *domain_);
    guard_ = std::make_unique<Guard>(*world_, initial_, *domain_, options.dump_path);
    if (scene.checks.any()) checker_ = std::make_unique<Checker>(*world_, initial_, *domain_);
    if (options.record_trajectory) {
        trajectory_ = std::make_unique<Trajectory>(make_trajectory(scene));
        trajectory_->frames.push_back(capture_frame(*world_, initial_, 0, 0.0, *domain_));
    }
}

const Substages* Pipeline::substages(Stage s) const {
    if (s == Stage::Collide) return backend_->substages();
    if (s == Stage::Solve) return solver_->substages();
    return nullptr;
}

nlohmann::json Pipeline::checks_result() const {
    return checker_ ? checker_->result(*world_, last_) : nlohmann::json();
}

void Pipeline::plan_stages(const Scene& scene, const RunOptions& options) {
    auto set = [this](Stage s, bool on, std::string why) {
        stages_[static_cast<int>(s)].enabled = on;
        stages_[static_cast<int>(s)].reason = std::move(why);
    };
    const bool many = domain_->distributed();
    set(Stage::Migrate, many, domain_->why());
    set(Stage::Exchange, many, domain_->why());
    const bool magnets = scene.any_magnets();
    const bool driver = scene.controller.enabled;
    set(Stage::Forces, magnets || driver,
        magnets && driver ? "magnets and controller" : magnets ? "magnets on" : driver ? "controller" : "no magnets, no controller");
    set(Stage::Collide, true, "backend " + backend_->name());
    const bool joints = solver_->uses_contact_joints();
    set(Stage::Joints, joints, joints ? "ODE contact joints for " + solver_->name() : solver_->name() + " reads the contacts directly");
    set(Stage::Solve, true, solver_->why());
    set(Stage::Observe, true, "every " + std::to_string(scene.observe_every) + " steps; finite check every step");
    const bool out = !options.snapshot_path.empty() && options.snapshot_every > 0;
    set(Stage::Output, out, out ? "snapshot every " + std::to_string(options.snapshot_every) + " steps" : "no output requested");
}

template <class F>
void Pipeline::timed(Stage s, F&& f) {
    StageState& st = stages_[static_cast<int>(s)];
    if (!st.enabled) return;
    const auto t0 = std::chrono::steady_clock::now();
    f();
    st.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void Pipeline::step() {
    timed(Stage::Migrate, [this] { run_migrate(); });
    timed(Stage::Exchange, [this] {
        domain_->exchange_states(*world_);
        if (invariants_every_ > 0 && steps_ % invariants_every_ == 0) domain_->check_invariants(*world_, steps_);
    });
    timed(Stage::Forces, [this] { run_forces(); });
    if (stage(Stage::Forces).enabled) timed(Stage::Exchange, [this] { domain_->exchange_forces(*world_); });
    if (contacts_of_ != world_->generation()) timed(Stage::Collide, [this] { run_collide(); });
    timed(Stage::Joints, [this] { run_joints(); });
    timed(Stage::Solve, [this] { run_solve(); });
    contacts_of_ = ~0ULL;  // bodies moved
    ++steps_;
    timed(Stage::Observe, [this] { guard_->check_step(*world_, steps_, solver_->wrote_finite_state()); });
    if (steps_ % scene_.observe_every == 0) timed(Stage::Observe, [this] { run_observe(); });
    if (snapshot_every_ > 0 && steps_ % snapshot_every_ == 0) timed(Stage::Output, [this] { run_output(); });
}

void Pipeline::finish() {
    if (last_observed_ != steps_) timed(Stage::Observe, [this] { run_observe(); });
}

void Pipeline::run_migrate() { domain_->migrate(*world_, solver_->warm_impulses(), steps_); }

void Pipeline::run_forces() {
    if (magnets_) {
        magnets_->prepare(*world_);
        gather_magnets(*magnets_, wrenches_);
        magnets_->apply(*world_, wrenches_);
    }
    if (scene_.controller.enabled) apply_controller(*world_, scene_.controller, steps_ * scene_.dt);
}

void Pipeline::run_collide() {
    backend_->collide(world_->space(), scene_.solver.max_contacts, contacts_);
    if (domain_->distributed()) {  // each contact belongs to the owner of its lower-id body
        auto& items = contacts_.items();
        items.erase(std::remove_if(items.begin(), items.end(),
                                   [this](const ContactRecord& c) { return world_->ghost(World::local_of_geom(c.geom.g1)); }),
                    items.end());
    }
    totals_.contacts += contacts_.size();
    contacts_of_ = world_->generation();
}

void Pipeline::run_joints() {
    dJointGroupEmpty(world_->contact_group());
    world_->create_contact_joints(contacts_.items());
}

void Pipeline::run_solve() { solver_->step(*world_, contacts_); }

void Pipeline::run_observe() {
    last_ = observe(*world_, contacts_, *domain_);
    last_observed_ = steps_;
    totals_.max_penetration = std::max(totals_.max_penetration, last_.max_penetration);
    totals_.penetration_sum += last_.mean_penetration * static_cast<double>(last_.contacts);
    totals_.observed_contacts += last_.contacts;
    guard_->check_observed(*world_, last_, steps_);
    if (checker_) checker_->observe(*world_, last_);
    if (trajectory_) trajectory_->frames.push_back(capture_frame(*world_, last_, steps_, steps_ * scene_.dt, *domain_));
}

void Pipeline::run_output() {
    const std::vector<double> rows = gather_rows(*domain_, *world_, 7, [this](std::size_t i, double* out) {
        const dReal* p = dBodyGetPosition(world_->body(i));
        const dReal* q = dBodyGetQuaternion(world_->body(i));
        for (int k = 0; k < 3; ++k) out[k] = p[k];
        for (int k = 0; k < 4; ++k) out[3 + k] = q[k];
    });
    for (std::size_t i = 0; i < rows.size() / 7; ++i) {
        const double* r = rows.data() + 7 * i;
        snapshot_ << steps_ << ',' << i << ',' << r[0] << ',' << r[1] << ',' << r[2] << ',' << r[3] << ',' << r[4]
                  << ',' << r[5] << ',' << r[6] << '\n';
    }
    if (domain_->root() && !snapshot_.flush()) throw std::runtime_error(snapshot_path_ + ": the snapshot could not be written (disk full?)");
}

}  // namespace parode
