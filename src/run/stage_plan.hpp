// Which stages of the step run and why, decided from the scene and the run's
// choices alone: the pipeline plans its stages with it once its backends
// exist, and `parode info` plans the same stages without building a world.
// Trade-off: the inputs are plain names and flags copied from the backends,
// so a new stage rule goes here once and both callers follow.
#pragma once
#include <array>
#include <string>

#include "run/pipeline.hpp"

namespace parode {

// What the plan depends on besides the scene.
struct StagePlanInput {
    bool distributed = false;      // two or more processes
    std::string domain_why;        // Domain::why()
    std::string backend;           // CollideBackend::name()
    bool contact_joints = true;    // SolverBackend::uses_contact_joints()
    std::string solver;            // SolverBackend::name()
    std::string solver_why;        // SolverBackend::why()
    std::string snapshot_path;     // empty: no output stage
    long snapshot_every = 0;
};

std::array<StageState, kStageCount> stage_plan(const Scene& scene, const StagePlanInput& in);

}  // namespace parode
