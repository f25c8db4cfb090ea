// Library entry points (see parallel_collide.hpp): one engine per calling
// thread, kept between calls so its buffers are reused.
// Trade-off: a thread_local engine keeps the free functions stateless for the
// caller at the cost of one engine's buffers per thread that ever calls them.
#include "omp/grid/parallel_collide.hpp"

#include <vector>

#include "omp/grid/grid_collide.hpp"

namespace parode {
namespace {

omp::CollideEngine& engine(int threads) {
    thread_local omp::CollideEngine e;
    e.set_threads(threads);
    return e;
}

}  // namespace

void collide(dSpaceID space, int max_contacts, ContactBuffer& out, int threads) {
    engine(threads).collide(space, max_contacts, out);
}

void collide2(dGeomID geom, dSpaceID space, int max_contacts, ContactBuffer& out, int threads) {
    engine(threads).collide2(geom, space, max_contacts, out);
}

void add_geoms(dGeomID g, GeomsById& out) {
    if (!dGeomIsSpace(g)) {
        out.add(g);
        return;
    }
    const dSpaceID space = reinterpret_cast<dSpaceID>(g);
    const int n = dSpaceGetNumGeoms(space);
    for (int i = 0; i < n; ++i) add_geoms(dSpaceGetGeom(space, i), out);
}

void for_each_pair(const ContactBuffer& contacts, const GeomsById& geoms, void* data, ContactPairCallback callback) {
    const std::vector<ContactRecord>& items = contacts.items();
    std::vector<dContactGeom> pair;
    std::size_t i = 0;
    while (i < items.size()) {
        pair.clear();
        const std::uint32_t lo = items[i].lo, hi = items[i].hi;
        const dGeomID g1 = geoms[lo], g2 = geoms[hi];
        for (; i < items.size() && items[i].lo == lo && items[i].hi == hi; ++i) pair.push_back(contacts.ode(i, g1, g2));
        callback(data, g1, g2, pair.data(), static_cast<int>(pair.size()));
    }
}

void collide_space(dSpaceID space, int max_contacts, void* data, ContactPairCallback callback,
                   int threads) {
    thread_local ContactBuffer buf;
    collide(space, max_contacts, buf, threads);
    GeomsById geoms;
    add_geoms(reinterpret_cast<dGeomID>(space), geoms);
    for_each_pair(buf, geoms, data, callback);
}

void collide_space2(dGeomID geom, dSpaceID space, int max_contacts, void* data,
                    ContactPairCallback callback, int threads) {
    thread_local ContactBuffer buf;
    collide2(geom, space, max_contacts, buf, threads);
    GeomsById geoms;
    add_geoms(geom, geoms);
    add_geoms(reinterpret_cast<dGeomID>(space), geoms);
    for_each_pair(buf, geoms, data, callback);
}

}  // namespace parode
