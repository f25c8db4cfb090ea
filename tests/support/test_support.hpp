// Helpers shared by the tests: load a scene of the repository, run a pipeline
// for a number of steps, read a body's pose. Trade-off: tests drive the same
// Pipeline the CLI uses, so they test the real step, not a copy of it.
#pragma once
#include <memory>
#include <string>
#include <vector>

#include "run/pipeline.hpp"
#include "run/stages.hpp"
#include "scene/scene_file.hpp"

namespace parode::test {

std::string repo_path(const std::string& rel);
Scene repo_scene(const std::string& rel, const std::vector<std::string>& sets = {});
// Run `steps` steps (then finish()) and return the pipeline for inspection.
// `scene` must outlive the pipeline. `force_parallel` runs the OpenMP paths at
// any size (results are the same; only the cost differs).
std::unique_ptr<Pipeline> run(const Scene& scene, int steps, const std::string& collide = "ode-hash", int threads = 1,
                              const std::string& solver = "ode", bool force_parallel = true);
std::uint64_t hash_after(const Scene& scene, int steps, const std::string& collide = "ode-hash", int threads = 1);
Vec3 position(const Pipeline& p, std::size_t body);
Vec3 velocity(const Pipeline& p, std::size_t body);
// A gtest parameter's name made of a scene's (which may hold '-', gtest's
// names may not).
std::string param_name(std::string name);
// The hard cases (jobs/scenes/hard/) that parode's contact solvers run, for
// the tests every such solver passes.
inline constexpr const char* kContactHardCases[] = {"column",  "pyramid", "mass-ratio",
                                                    "fast-catom", "overlap", "magnetic-lattice"};

}  // namespace parode::test
