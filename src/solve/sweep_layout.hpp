// The order in which the contact solver stores bodies and relaxes contacts.
// Bodies are sorted by their cell of the global cell grid (domain/cells.hpp)
// in (z, y, x) order, then by global id, so the bodies of a cell and of its
// neighbours sit together in memory. A contact belongs to the cell of its
// lower-id body (its owner); the cells of each colour are listed in (z, y, x)
// order, and a cell's contacts are its bodies' contacts taken body by body in
// id order, each body's in canonical order: the canonical order within the
// cell. Positions number the contacts in that order: colour by colour, cell by
// cell, so a sweep reads its rows front to back; the layout maps each contact
// to its position, so that a pass in canonical order reads its inputs front
// to back too.
// On a distributed run each colour lists first the cells that touch a body
// another process also holds (boundary cells: their corrections are sent
// after the colour), then the others (interior cells, relaxed while the
// messages travel); cells of one colour touch disjoint bodies, so this order
// changes no result.
// The sort is a counting sort over the cells of the bodies' bounding box
// (z-slabs in parallel), or a comparison sort when the box holds more than
// 8 cells per body (bodies scattered far apart). Results never depend on the
// order of cells within a colour, nor on where a body is stored.
// Trade-off: a full reorder every step (a few passes over bodies and
// contacts) buys sweeps that stream their rows and keep the bodies they touch
// in cache whatever the ids' spatial order.
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "exec/loops.hpp"

namespace parode {

struct LayoutInput {
    std::size_t bodies = 0;
    const std::uint64_t* cell = nullptr;  // per local body: its CellSpace key
    const std::uint32_t* gid = nullptr;   // per local body
    std::size_t contacts = 0;
    const std::uint32_t* owner = nullptr;  // per contact: local body of its lower id; equal owners adjacent
    // A distributed run: per contact, the local body of its higher id (or
    // ~0u), and per local body, whether another process holds a copy. A
    // cell touching such a body is a boundary cell; each colour lists its
    // boundary cells first. Null: no boundary cells.
    const std::uint32_t* other = nullptr;
    const std::uint8_t* shared = nullptr;
};

class SweepLayout {
public:
    static constexpr int kColours = 8;
    // Its loops run on `loops` (the solver's execution context).
    void build(const LayoutInput& in, const LoopRunner& loops);

    const std::vector<std::uint32_t>& order() const { return order_; }  // slot -> local body
    const std::vector<std::uint32_t>& slot() const { return slot_; }    // local body -> slot
    // Cells (with contacts) of colour c: [colour_begin(c), colour_end(c)),
    // its boundary cells [colour_begin(c), boundary_end(c)) first.
    std::size_t colour_begin(int c) const { return class_start_[2 * static_cast<std::size_t>(c)]; }
    std::size_t boundary_end(int c) const { return class_start_[2 * static_cast<std::size_t>(c) + 1]; }
    std::size_t colour_end(int c) const { return class_start_[2 * static_cast<std::size_t>(c) + 2]; }
    std::size_t cells() const { return class_start_[2 * kColours]; }
    // Positions of cell t: [cell_begin(t), cell_begin(t + 1)).
    std::size_t cell_begin(std::size_t t) const { return pos_start_[t]; }
    // The position of contact k (canonical index).
    std::uint32_t position(std::size_t k) const { return position_[k]; }

private:
    struct Box {
        std::uint64_t lo[3], dim[3];
    };
    Box bounding_box(const LayoutInput& in) const;
    void sort_dense(const LayoutInput& in, const Box& box);
    void sort_sparse(const LayoutInput& in);
    void list_cells(const LayoutInput& in);
    void order_within_cells(const LayoutInput& in);
    void find_runs(const LayoutInput& in);
    bool touches_shared(const LayoutInput& in, std::size_t t) const;
    void place_contacts(const LayoutInput& in);

    const LoopRunner* runner_ = nullptr;  // build's
    std::vector<std::uint32_t> order_, slot_;
    std::vector<std::uint32_t> lin_;         // dense: per local body, its cell in the box
    std::vector<std::uint32_t> count_;       // dense: per box cell, bodies (then first slot)
    std::vector<std::size_t> slab_pos_, slab_start_;
    std::vector<std::uint32_t> slab_items_;
    std::vector<std::uint32_t> run_first_, run_count_;  // per local body: its owned contacts
    std::vector<std::uint32_t> cell_slot_;   // per cell of bodies: first slot, + one past the last
    std::vector<std::uint8_t> colour_;       // per cell of bodies
    std::vector<std::uint32_t> task_cell_;   // per listed cell (with contacts): its cell of bodies
    std::vector<std::size_t> pos_start_;     // per listed cell: first position, + total
    // Per colour c: class 2c its boundary cells, 2c + 1 its interior ones.
    static constexpr int kClasses = 2 * kColours;
    std::array<std::size_t, kClasses + 1> class_start_{};
    std::vector<std::uint8_t> boundary_;     // per cell of bodies: touches a shared body
    std::vector<std::uint32_t> position_;    // per contact
};

}  // namespace parode
