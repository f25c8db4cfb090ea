// Test helpers (see test_support.hpp).
#include "test_support.hpp"

#include "omp/stages.hpp"

namespace parode::test {

std::string repo_path(const std::string& rel) { return std::string(PARODE_SOURCE_DIR) + "/" + rel; }

Scene repo_scene(const std::string& rel, const std::vector<std::string>& sets) {
    return load_scene(repo_path(rel), sets);
}

std::unique_ptr<Pipeline> run(const Scene& scene, int steps, const std::string& collide, int threads,
                              const std::string& solver, bool force_parallel) {
    parode::omp::add_stages();
    RunOptions opt;
    opt.collide = collide;
    opt.solver = solver;
    opt.execution.threads = threads;
    opt.execution.min_parallel = force_parallel ? 0 : -1;
    auto p = std::make_unique<Pipeline>(scene, opt);
    for (int s = 0; s < steps; ++s) p->step();
    p->finish();
    return p;
}

std::uint64_t hash_after(const Scene& scene, int steps, const std::string& collide, int threads) {
    return run(scene, steps, collide, threads)->last().state_hash;
}

Vec3 position(const Pipeline& p, std::size_t body) {
    const dReal* x = dBodyGetPosition(p.world().body(body));
    return {x[0], x[1], x[2]};
}

Vec3 velocity(const Pipeline& p, std::size_t body) {
    const dReal* v = dBodyGetLinearVel(p.world().body(body));
    return {v[0], v[1], v[2]};
}

std::string param_name(std::string name) {
    for (char& ch : name) ch = ch == '-' ? '_' : ch;
    return name;
}

}  // namespace parode::test
