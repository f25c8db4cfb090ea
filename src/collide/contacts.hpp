// Contact buffers and the canonical contact order: the determinism contract.
// A pair is always collided as dCollide(lower-id geom, higher-id geom) and the
// contacts of a step are ordered by (lower id, higher id, index within pair).
// Trade-off: a sort per step (cheap next to narrowphase) buys results that do not
// depend on the broadphase, the space type or the thread count.
#pragma once
#include <ode/ode.h>

#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
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

// A contact's point, normal and depth, as dCollide wrote them.
struct ContactPoint {
    dReal pos[3];
    dReal normal[3];
    dReal depth;
};

// ODE's sides of a contact: -1 but for the contacts of a few colliders
// (trimesh, heightfield), which name a triangle or a cell.
struct ContactSides {
    int side1 = -1, side2 = -1;
    bool none() const { return side1 == -1 && side2 == -1; }
};

// One contact of a step: ODE's dContactGeom less what can be had elsewhere,
// in 64 bytes, not 96. g1 and g2 are the geoms of lo and hi
// (dCollide's first and second argument); the contact's index within its
// pair is its position among the consecutive records of that pair
// (contact_index); the sides are the buffer's (ContactBuffer::sides), kept
// only once some contact has sides other than -1.
// Trade-off: whoever needs the geoms looks them up by id (World::geom_of,
// GeomsById), and a buffer with sides keeps a second array, for a third less
// memory traffic wherever contacts are written and read: the merge writes
// 1.7 million of them a step at 10^6 catoms.
struct ContactRecord {
    // Left uninitialised: the merge sizes the step's buffer (1.7 million
    // records at 10^6 catoms) and then writes every record on its threads; a
    // zeroing resize was a serial pass over all of it first.
    ContactRecord() {}
    ContactRecord(std::uint32_t lo_, std::uint32_t hi_, const dContactGeom& c)
        : lo(lo_), hi(hi_), geom{{c.pos[0], c.pos[1], c.pos[2]}, {c.normal[0], c.normal[1], c.normal[2]}, c.depth} {}
    // As ODE's contact, given the geoms of lo and hi and the sides (fourth
    // components zero).
    dContactGeom ode(dGeomID g1, dGeomID g2, ContactSides s) const {
        dContactGeom c;
        for (int k = 0; k < 3; ++k) c.pos[k] = geom.pos[k], c.normal[k] = geom.normal[k];
        c.pos[3] = c.normal[3] = 0;
        c.depth = geom.depth;
        c.g1 = g1;
        c.g2 = g2;
        c.side1 = s.side1;
        c.side2 = s.side2;
        return c;
    }
    std::uint32_t lo;  // id of geom passed first to dCollide
    std::uint32_t hi;  // id of geom passed second
    ContactPoint geom;
};
// Not over-aligned: libstdc++'s stable_sort buffers ignore an alignment above
// 16 (the sanitizers flag it), and the records are read and written in order.
static_assert(sizeof(ContactRecord) == 64, "two ids and the contact, no padding");

inline bool same_pair(const ContactRecord& a, const ContactRecord& b) { return a.lo == b.lo && a.hi == b.hi; }

// The index within its pair of contact k of a buffer in canonical order.
inline std::uint32_t contact_index(const ContactRecord* items, std::size_t k) {
    std::uint32_t i = 0;
    while (i < k && same_pair(items[k - i - 1], items[k])) ++i;
    return i;
}

// The same for k > 0, given the index of contact k - 1 (a pass in order).
inline std::uint32_t next_index(const ContactRecord* items, std::size_t k, std::uint32_t before) {
    return same_pair(items[k - 1], items[k]) ? before + 1 : 0;
}

// Canonical order by pair; within a pair, records keep the order dCollide
// wrote them in (every sort of records is stable).
inline bool canonical_less(const ContactRecord& a, const ContactRecord& b) {
    if (a.lo != b.lo) return a.lo < b.lo;
    return a.hi < b.hi;
}

// The geoms of a collision call by id (ids are dense): for turning records
// back into ODE's contacts.
class GeomsById {
public:
    void add(dGeomID g) {
        const std::uint32_t id = geom_id(g);
        if (id >= geoms_.size()) geoms_.resize(id + 1, nullptr);
        geoms_[id] = g;
    }
    // The geom of `id`; throws std::invalid_argument, naming the id, when no
    // geom of that id was added (a contact of a geom outside the call).
    dGeomID operator[](std::uint32_t id) const {
        if (id >= geoms_.size() || geoms_[id] == nullptr) {
            throw std::invalid_argument("GeomsById: no geom with id " + std::to_string(id) +
                                        " was added (add every geom the contacts name)");
        }
        return geoms_[id];
    }

private:
    std::vector<dGeomID> geoms_;
};

class ContactBuffer {
public:
    void clear() {
        items_.clear();
        sides_.clear();
    }
    std::size_t size() const { return items_.size(); }
    const std::vector<ContactRecord>& items() const { return items_; }
    // For a writer that sizes the records and fills them in place (the
    // merge); it sets the sides table too (side_table).
    std::vector<ContactRecord>& items() { return items_; }
    // Whether some contact has sides: the sides table then holds one entry
    // per record; otherwise it is empty and every contact's sides are -1.
    bool has_sides() const { return !sides_.empty(); }
    ContactSides sides(std::size_t k) const { return sides_.empty() ? ContactSides{} : sides_[k]; }
    std::vector<ContactSides>& side_table() { return sides_; }
    // Contact k as ODE's, given the geoms of its ids.
    dContactGeom ode(std::size_t k, dGeomID g1, dGeomID g2) const { return items_[k].ode(g1, g2, sides(k)); }
    // Appends one contact.
    void push(const ContactRecord& r, ContactSides s = {});
    // Collide a and b (any order) as dCollide(lower id, higher id) and append
    // every contact. Returns the number of contacts appended.
    int collide_pair(dGeomID a, dGeomID b, int max_contacts);
    // Append all of another buffer (used to merge per-task buffers).
    void append(const ContactBuffer& other);
    // Sort into canonical order. Stable, so each pair's contacts keep their order.
    void sort_canonical();
    // Removes the contacts whose lower id `drop` names, keeping the others' order.
    template <class Drop>
    void remove_lo(Drop drop) {
        std::size_t n = 0;
        for (std::size_t k = 0; k < items_.size(); ++k) {
            if (drop(items_[k].lo)) continue;
            if (!sides_.empty()) sides_[n] = sides_[k];
            items_[n++] = items_[k];
        }
        items_.resize(n);
        if (!sides_.empty()) sides_.resize(n);
    }

private:
    void need_sides();  // the sides table, one entry per record
    std::vector<ContactRecord> items_;
    std::vector<ContactSides> sides_;
};

// Bitwise digest of a contact set, for tests that compare backends.
std::uint64_t contact_digest(const ContactBuffer& buf);

}  // namespace parode
