// Contact buffers and the canonical contact order: the determinism contract.
// A pair is always collided as dCollide(lower-id geom, higher-id geom) and the
// contacts of a step are ordered by (lower id, higher id, index within pair).
// Trade-off: a sort per step (cheap next to narrowphase) buys results that do not
// depend on the broadphase, the space type or the thread count.
#pragma once
#include <ode/ode.h>

#include <cstdint>
#include <vector>

namespace parode {

// Global id of a geom, stored in its user data by World (and by any program using
// the collision library). Ids are dense, 0-based and stable for a run.
inline std::uint32_t geom_id(dGeomID g) {
    return static_cast<std::uint32_t>(reinterpret_cast<std::uintptr_t>(dGeomGetData(g)));
}
inline void set_geom_id(dGeomID g, std::uint32_t id) {
    dGeomSetData(g, reinterpret_cast<void*>(static_cast<std::uintptr_t>(id)));
}

// ODE's dContactGeom without the unused fourth components of its two vectors
// (80 bytes, not 96): the same values, and the same fields by name.
struct ContactGeom {
    ContactGeom() {}  // left uninitialised, as dContactGeom
    explicit ContactGeom(const dContactGeom& c)
        : pos{c.pos[0], c.pos[1], c.pos[2]}, normal{c.normal[0], c.normal[1], c.normal[2]}, depth(c.depth),
          g1(c.g1), g2(c.g2), side1(c.side1), side2(c.side2) {}
    // As an ODE contact, the fourth components set to zero.
    dContactGeom ode() const {
        dContactGeom c;
        for (int k = 0; k < 3; ++k) c.pos[k] = pos[k], c.normal[k] = normal[k];
        c.pos[3] = c.normal[3] = 0;
        c.depth = depth;
        c.g1 = g1;
        c.g2 = g2;
        c.side1 = side1;
        c.side2 = side2;
        return c;
    }
    dReal pos[3];
    dReal normal[3];
    dReal depth;
    dGeomID g1, g2;
    int side1, side2;
};

struct ContactRecord {
    // Left uninitialised: the merge sizes the step's buffer (1.9 million
    // records, 180 MB at 10^6 catoms) and then writes every record on its
    // threads; a zeroing resize was a serial pass over all of it first.
    ContactRecord() {}
    ContactRecord(std::uint32_t lo_, std::uint32_t hi_, std::uint32_t index_, const dContactGeom& geom_)
        : lo(lo_), hi(hi_), index(index_), geom(geom_) {}
    std::uint32_t lo;     // id of geom passed first to dCollide
    std::uint32_t hi;     // id of geom passed second
    std::uint32_t index;  // index of the contact within its pair
    ContactGeom geom;     // what dCollide wrote
};
static_assert(sizeof(ContactRecord) == 96, "three words of ids, then the contact without padding");

inline bool canonical_less(const ContactRecord& a, const ContactRecord& b) {
    if (a.lo != b.lo) return a.lo < b.lo;
    if (a.hi != b.hi) return a.hi < b.hi;
    return a.index < b.index;
}

class ContactBuffer {
public:
    void clear() { items_.clear(); }
    std::size_t size() const { return items_.size(); }
    const std::vector<ContactRecord>& items() const { return items_; }
    std::vector<ContactRecord>& items() { return items_; }
    // Collide a and b (any order) as dCollide(lower id, higher id) and append
    // every contact. Returns the number of contacts appended.
    int collide_pair(dGeomID a, dGeomID b, int max_contacts);
    // Append all of another buffer (used to merge per-task buffers).
    void append(const ContactBuffer& other);
    // Sort into canonical order. Stable within a pair, so index order is kept.
    void sort_canonical();

private:
    std::vector<ContactRecord> items_;
};

// Bitwise digest of a contact set, for tests that compare backends.
std::uint64_t contact_digest(const ContactBuffer& buf);

}  // namespace parode
