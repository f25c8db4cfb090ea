// Contact buffer: pairwise dCollide in canonical argument order, merge and sort.
// Trade-off: contacts are copied once into a flat vector so per-task buffers can
// be merged and sorted without touching ODE again.
#include "collide/contacts.hpp"

#include <algorithm>
#include <array>
#include <cstring>

#include "util/hash.hpp"

namespace parode {

void ContactBuffer::need_sides() {
    if (sides_.size() < items_.size()) sides_.resize(items_.size());
}

void ContactBuffer::push(const ContactRecord& r, ContactSides s) {
    items_.push_back(r);
    if (s.none() && sides_.empty()) return;
    need_sides();
    sides_.back() = s;
}

int ContactBuffer::collide_pair(dGeomID a, dGeomID b, int max_contacts) {
    std::uint32_t ia = geom_id(a), ib = geom_id(b);
    if (ib < ia) {
        std::swap(a, b);
        std::swap(ia, ib);
    }
    constexpr int kMax = 64;
    std::array<dContactGeom, kMax> tmp;
    const int n = dCollide(a, b, std::min(max_contacts, kMax), tmp.data(), sizeof(dContactGeom));
    for (int k = 0; k < n; ++k) push(ContactRecord(ia, ib, tmp[k]), ContactSides{tmp[k].side1, tmp[k].side2});
    return n;
}

void ContactBuffer::append(const ContactBuffer& other) {
    if (other.has_sides()) need_sides();
    const bool sides = has_sides();
    items_.insert(items_.end(), other.items_.begin(), other.items_.end());
    if (!sides) return;
    for (std::size_t k = 0; k < other.size(); ++k) sides_.push_back(other.sides(k));
}

void ContactBuffer::sort_canonical() {
    if (std::is_sorted(items_.begin(), items_.end(), canonical_less)) return;
    if (sides_.empty()) {
        std::stable_sort(items_.begin(), items_.end(), canonical_less);
        return;
    }
    std::vector<std::size_t> order(items_.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::stable_sort(order.begin(), order.end(),
                     [this](std::size_t a, std::size_t b) { return canonical_less(items_[a], items_[b]); });
    std::vector<ContactRecord> items(items_.size());
    std::vector<ContactSides> sides(items_.size());
    for (std::size_t k = 0; k < order.size(); ++k) items[k] = items_[order[k]], sides[k] = sides_[order[k]];
    items_.swap(items);
    sides_.swap(sides);
}

std::uint64_t contact_digest(const ContactBuffer& buf) {
    Fnv1a h;
    const std::vector<ContactRecord>& items = buf.items();
    std::uint32_t index = 0;
    for (std::size_t k = 0; k < items.size(); ++k) {
        const ContactRecord& c = items[k];
        if (k > 0) index = next_index(items.data(), k, index);
        h.add(c.lo);
        h.add(c.hi);
        h.add(index);
        h.add_doubles(c.geom.pos, 3);
        h.add_doubles(c.geom.normal, 3);
        h.add_doubles(&c.geom.depth, 1);
    }
    return h.value();
}

}  // namespace parode
