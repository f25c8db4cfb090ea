// Reference collision: ODE's serial dSpaceCollide / dSpaceCollide2, with a
// near-callback that recurses into nested spaces and collects contacts via
// ContactBuffer::collide_pair (canonical argument order), then sorts them.
// Trade-off: serial and O(space) in memory as ODE is; it is the ground truth.
#include "collide/collide.hpp"

#include <algorithm>

namespace parode {
namespace {

struct CallbackData {
    ContactBuffer* out;
    int max_contacts;
};

void near_callback(void* data, dGeomID a, dGeomID b) {
    auto* d = static_cast<CallbackData*>(data);
    if (dGeomIsSpace(a) || dGeomIsSpace(b)) {
        // A nested space on one side: collide its contents against the other
        // side. Its internal pairs are collided once, by collide_internal.
        dSpaceCollide2(a, b, data, &near_callback);
        return;
    }
    d->out->collide_pair(a, b, d->max_contacts);
}

class OdeSpaceBackend final : public CollideBackend {
public:
    OdeSpaceBackend(std::string name, SpaceKind kind) : name_(std::move(name)), kind_(kind) {}
    std::string name() const override { return name_; }
    SpaceKind space_kind() const override { return kind_; }
    void collide(dSpaceID space, int max_contacts, ContactBuffer& out) override {
        collide_space_reference(space, max_contacts, out);
    }

private:
    std::string name_;
    SpaceKind kind_;
};

// Pairs inside `space` and, recursively, inside each nested space, once each.
void collide_internal(dSpaceID space, CallbackData* data) {
    dSpaceCollide(space, data, &near_callback);
    const int n = dSpaceGetNumGeoms(space);
    for (int i = 0; i < n; ++i) {
        dGeomID g = dSpaceGetGeom(space, i);
        if (dGeomIsSpace(g)) collide_internal(reinterpret_cast<dSpaceID>(g), data);
    }
}

}  // namespace

void drop_ghost_contacts(ContactBuffer& out, const GhostTest& test) {
    out.remove_lo([&test](std::uint32_t lo) { return test.drops(lo); });
}

void collide_space_reference(dSpaceID space, int max_contacts, ContactBuffer& out) {
    out.clear();
    CallbackData data{&out, max_contacts};
    collide_internal(space, &data);
    out.sort_canonical();
}

void collide2_reference(dGeomID geom, dSpaceID space, int max_contacts, ContactBuffer& out) {
    out.clear();
    CallbackData data{&out, max_contacts};
    dSpaceCollide2(geom, reinterpret_cast<dGeomID>(space), &data, &near_callback);
    out.sort_canonical();
}

void add_reference_backends(CollideRegistry& r) {
    r.add("ode-hash", [](Execution&) { return std::make_unique<OdeSpaceBackend>("ode-hash", SpaceKind::Hash); }, {},
          "ODE's hash space (dSpaceCollide), serial: the reference");
    r.add("ode-sap", [](Execution&) { return std::make_unique<OdeSpaceBackend>("ode-sap", SpaceKind::SweepAndPrune); },
          {}, "ODE's sweep-and-prune space, serial");
    r.add("ode-simple", [](Execution&) { return std::make_unique<OdeSpaceBackend>("ode-simple", SpaceKind::Simple); },
          {}, "ODE's simple space (all pairs), serial");
}

}  // namespace parode
