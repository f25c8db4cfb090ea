// Step pipeline (see pipeline.hpp).
#include "pipeline.hpp"

#include <chrono>
#include <sstream>

#include "controller.hpp"
#include "hash.hpp"

namespace parode {

const char* stage_name(Stage s) {
    static const char* names[kStageCount] = {"forces", "collide", "joints", "solve", "observe", "output"};
    return names[static_cast<int>(s)];
}

Pipeline::Pipeline(const Scene& scene, const RunOptions& options) : scene_(scene) {
    backend_ = BackendRegistry::instance().make(options.collide);
    backend_->set_threads(options.threads);
    world_ = std::make_unique<World>(scene, backend_->space_kind());
    plan_stages(scene, options);
    if (stage(Stage::Forces).enabled && scene.any_magnets()) {
        magnets_ = std::make_unique<MagnetField>(scene, *world_);
        wrenches_.resize(magnets_->members().size());
    }
    if (stage(Stage::Output).enabled) {
        snapshot_.open(options.snapshot_path);
        if (!snapshot_) throw std::runtime_error(options.snapshot_path + ": cannot open snapshot file for writing");
        snapshot_ << "step,body,x,y,z,qw,qx,qy,qz\n";
        snapshot_every_ = options.snapshot_every;
    }
}

void Pipeline::plan_stages(const Scene& scene, const RunOptions& options) {
    auto set = [this](Stage s, bool on, std::string why) {
        stages_[static_cast<int>(s)].enabled = on;
        stages_[static_cast<int>(s)].reason = std::move(why);
    };
    const bool magnets = scene.any_magnets();
    const bool driver = scene.controller.enabled;
    set(Stage::Forces, magnets || driver,
        magnets && driver ? "magnets and controller" : magnets ? "magnets on" : driver ? "controller" : "no magnets, no controller");
    set(Stage::Collide, true, "backend " + backend_->name());
    set(Stage::Joints, true, scene.joints.empty() ? "contact joints" : "contact joints; scene joints are persistent");
    set(Stage::Solve, true, scene.solver.stepper == Stepper::Quick ? "dWorldQuickStep" : "dWorldStep");
    set(Stage::Observe, true, "every " + std::to_string(scene.observe_every) + " steps");
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
    timed(Stage::Forces, [this] { run_forces(); });
    timed(Stage::Collide, [this] { run_collide(); });
    timed(Stage::Joints, [this] { run_joints(); });
    timed(Stage::Solve, [this] { run_solve(); });
    ++steps_;
    if (steps_ % scene_.observe_every == 0) timed(Stage::Observe, [this] { run_observe(); });
    if (snapshot_every_ > 0 && steps_ % snapshot_every_ == 0) timed(Stage::Output, [this] { run_output(); });
}

void Pipeline::finish() {
    if (last_observed_ != steps_) timed(Stage::Observe, [this] { run_observe(); });
}

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
    totals_.contacts += contacts_.size();
}

void Pipeline::run_joints() {
    dJointGroupEmpty(world_->contact_group());
    world_->create_contact_joints(contacts_.items());
}

void Pipeline::run_solve() {
    if (scene_.solver.stepper == Stepper::Quick) dWorldQuickStep(world_->id(), scene_.dt);
    else dWorldStep(world_->id(), scene_.dt);
}

void Pipeline::run_observe() {
    last_ = observe(*world_, contacts_);
    last_observed_ = steps_;
    totals_.max_penetration = std::max(totals_.max_penetration, last_.max_penetration);
    totals_.penetration_sum += last_.mean_penetration * static_cast<double>(last_.contacts);
    totals_.observed_contacts += last_.contacts;
    if (last_.nan_count == 0) return;
    std::ostringstream os;
    os << "step " << steps_ << ": " << last_.nan_count << " bodies have a non-finite state (first ids:";
    for (std::size_t id : nan_bodies(*world_, 10)) os << ' ' << id;
    os << "); stopping";
    throw SimulationError(os.str());
}

void Pipeline::run_output() {
    for (std::size_t i = 0; i < world_->body_count(); ++i) {
        const dReal* p = dBodyGetPosition(world_->body(i));
        const dReal* q = dBodyGetQuaternion(world_->body(i));
        snapshot_ << steps_ << ',' << i << ',' << p[0] << ',' << p[1] << ',' << p[2] << ',' << q[0] << ','
                  << q[1] << ',' << q[2] << ',' << q[3] << '\n';
    }
}

}  // namespace parode
