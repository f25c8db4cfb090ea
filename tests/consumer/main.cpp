// An ODE program colliding spheres through parode's parallel collision entry
// point (parode::collide_space), built against an installed parode. Five
// spheres of radius 0.5 in a row, 0.9 m apart, 0.4 m above a floor plane:
// 4 sphere-sphere and 5 sphere-plane contacts. Checks that count on 1 and 2
// threads, that ODE's own dSpaceCollide finds the same pairs, and that the
// pairs arrive in canonical order (lower id first, ids ascending).
// Then two whole pipelines (parode::Pipeline, stages from the registry with
// parode::omp::add_stages) of two scenes, one on 1 thread and one on 2,
// stepped in turns: each must end with the state hash it has when run alone.
// Trade-off: geoms without bodies for the collision check; small scenes
// given as text for the pipelines, so the program needs no file of parode's.
#include <ode/ode.h>

#include <cstdio>
#include <vector>

#include <parode/collide/contacts.hpp>    // parode::set_geom_id (core headers under include/parode/)
#include <parode/omp/grid/parallel_collide.hpp>  // parode::collide_space
#include <parode/omp/stages.hpp>             // parode::omp::add_stages
#include <parode/run/pipeline.hpp>
#include <parode/scene/scene_file.hpp>
#include <parode/util/hash.hpp>
#include <memory>
#include <string>

namespace {

struct Tally {
    int pairs = 0, contacts = 0;
    long last = -1;  // lower id * 100 + higher id of the previous pair
    bool ordered = true;
};

void count_pair(void* data, dGeomID g1, dGeomID g2, const dContactGeom* /*contacts*/, int n) {
    auto* t = static_cast<Tally*>(data);
    const long key = static_cast<long>(parode::geom_id(g1)) * 100 + static_cast<long>(parode::geom_id(g2));
    t->ordered = t->ordered && key > t->last && parode::geom_id(g1) < parode::geom_id(g2);
    t->last = key;
    ++t->pairs;
    t->contacts += n;
}

void count_ode(void* data, dGeomID g1, dGeomID g2) {
    dContactGeom c[4];
    static_cast<Tally*>(data)->contacts += dCollide(g1, g2, 4, c, sizeof(dContactGeom));
}

std::string scene_text(int seed, bool magnets) {
    return "[scene]\nname = \"consumer\"\nseed = " + std::to_string(seed) + "\n[catoms]\ncount = 400\njitter = 0.01\n" +
           "[[planes]]\nnormal = [0.0, 0.0, 1.0]\n" + (magnets ? "[magnets]\nenabled = true\n" : "");
}

std::unique_ptr<parode::Pipeline> pipeline(const parode::Scene& scene, int threads) {
    parode::RunOptions opt;
    opt.collide = "grid";
    opt.solver = "parallel";
    opt.execution.threads = threads;
    opt.execution.min_parallel = 0;  // every loop on its threads, however small
    return std::make_unique<parode::Pipeline>(scene, opt);
}

std::uint64_t hash_alone(const parode::Scene& scene, int threads, int steps) {
    auto p = pipeline(scene, threads);
    for (int s = 0; s < steps; ++s) p->step();
    p->finish();
    return p->last().state_hash;
}

// Two pipelines with their own thread counts, stepped in turns.
int two_pipelines() {
    parode::omp::add_stages();
    const parode::Scene a = parode::load_scene_text(scene_text(1, false), "a.toml");
    const parode::Scene b = parode::load_scene_text(scene_text(2, true), "b.toml");
    const int steps = 30;
    const std::uint64_t ha = hash_alone(a, 1, steps), hb = hash_alone(b, 2, steps);
    auto pa = pipeline(a, 1), pb = pipeline(b, 2);
    for (int s = 0; s < steps; ++s) {
        pa->step();
        pb->step();
    }
    pa->finish();
    pb->finish();
    const bool ok = pa->last().state_hash == ha && pb->last().state_hash == hb && ha != hb;
    std::printf("pipelines in turns: %s %s (alone %s %s) on %d and %d threads: %s\n",
                parode::hex64(pa->last().state_hash).c_str(), parode::hex64(pb->last().state_hash).c_str(),
                parode::hex64(ha).c_str(), parode::hex64(hb).c_str(), pa->execution().threads(),
                pb->execution().threads(), ok ? "same" : "DIFFERENT");
    return ok ? 0 : 1;
}

}  // namespace

int main() {
    dInitODE2(0);
    dSpaceID space = dHashSpaceCreate(nullptr);
    std::vector<dGeomID> geoms;
    for (int i = 0; i < 5; ++i) {
        dGeomID s = dCreateSphere(space, 0.5);
        dGeomSetPosition(s, 0.9 * i, 0, 0.4);
        geoms.push_back(s);
    }
    geoms.push_back(dCreatePlane(space, 0, 0, 1, 0));
    for (std::size_t i = 0; i < geoms.size(); ++i) parode::set_geom_id(geoms[i], static_cast<std::uint32_t>(i));

    int failures = 0;
    for (int threads : {1, 2}) {
        Tally t;
        parode::collide_space(space, 4, &t, count_pair, threads);
        std::printf("threads %d: %d pairs, %d contacts, %s order\n", threads, t.pairs, t.contacts,
                    t.ordered ? "canonical" : "WRONG");
        failures += t.pairs != 9 || t.contacts != 9 || !t.ordered;
    }
    Tally ode;
    dSpaceCollide(space, &ode, count_ode);
    std::printf("dSpaceCollide: %d contacts\n", ode.contacts);
    failures += ode.contacts != 9;
    failures += two_pipelines();

    dSpaceDestroy(space);
    dCloseODE();
    std::printf(failures ? "consumer: FAILED\n" : "consumer: ok\n");
    return failures ? 1 : 0;
}
