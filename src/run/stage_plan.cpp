// Stage plan (see stage_plan.hpp).
#include "run/stage_plan.hpp"

namespace parode {

std::array<StageState, kStageCount> stage_plan(const Scene& scene, const StagePlanInput& in) {
    std::array<StageState, kStageCount> stages;
    auto set = [&stages](Stage s, bool on, std::string why) {
        stages[static_cast<int>(s)].enabled = on;
        stages[static_cast<int>(s)].reason = std::move(why);
    };
    set(Stage::Migrate, in.distributed, in.domain_why);
    set(Stage::Exchange, in.distributed, in.domain_why);
    const bool magnets = scene.any_magnets();
    const bool driver = scene.controller.enabled;
    const std::string program = scene.program.enabled ? "program " + scene.program.name + (magnets || driver ? ", " : "") : "";
    set(Stage::Forces, magnets || driver || scene.program.enabled,
        program + (magnets && driver ? "magnets and controller" : magnets ? "magnets on" : driver ? "controller"
                   : program.empty() ? "no magnets, no controller" : ""));
    set(Stage::Collide, true, "backend " + in.backend);
    set(Stage::Joints, in.contact_joints,
        in.contact_joints ? "ODE contact joints for " + in.solver : in.solver + " reads the contacts directly");
    set(Stage::Solve, true, in.solver_why);
    set(Stage::Observe, true, "every " + std::to_string(scene.observe_every) + " steps; finite check every step");
    const bool out = !in.snapshot_path.empty() && in.snapshot_every > 0;
    set(Stage::Output, out, out ? "snapshot every " + std::to_string(in.snapshot_every) + " steps" : "no output requested");
    return stages;
}

}  // namespace parode
