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

struct ContactRecord {
    // Left uninitialised: the merge sizes the step's buffer (1.7 million
    // records, 190 MB at 10^6 catoms) and then writes every record on its
    // threads; a zeroing resize was a serial pass over all of it first.
    ContactRecord() {}
    ContactRecord(std::uint32_t lo_, std::uint32_t hi_, std::uint32_t index_, const dContactGeom& geom_)
        : lo(lo_), hi(hi_), index(index_), geom(geom_) {}
    std::uint32_t lo;     // id of geom passed first to dCollide
    std::uint32_t hi;     // id of geom passed second
    std::uint32_t index;  // index of the contact within its pair
    dContactGeom geom;    // exactly as dCollide wrote it
};

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
