// An ODE program colliding spheres through parode's parallel collision entry
// point (parode::collide_space), built against an installed parode. Five
// spheres of radius 0.5 in a row, 0.9 m apart, 0.4 m above a floor plane:
// 4 sphere-sphere and 5 sphere-plane contacts. Checks that count on 1 and 2
// threads, that ODE's own dSpaceCollide finds the same pairs, and that the
// pairs arrive in canonical order (lower id first, ids ascending).
// Trade-off: geoms without bodies, so the check is the collision alone.
#include <ode/ode.h>

#include <cstdio>
#include <vector>

#include <parode/collide/contacts.hpp>    // parode::set_geom_id (core headers under include/parode/)
#include <parode/omp/parallel_collide.hpp>  // parode::collide_space

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

    dSpaceDestroy(space);
    dCloseODE();
    std::printf(failures ? "consumer: FAILED\n" : "consumer: ok\n");
    return failures ? 1 : 0;
}
