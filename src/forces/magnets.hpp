// Catom magnets: monopoles at body-fixed points on each magnetised catom's
// surface. Two poles at distance d < cutoff exert on each other
//     F = k q_i q_j (p_i - p_j) / (|d|^2 + eps^2)^(3/2) * (1 - |d|^2/cutoff^2)^2
// (like charges repel), applied at the pole so it also makes torque.
// Forces are *gathered per body*: each body sums the forces on its own poles from
// its neighbours in a fixed order (cell key, then global id), so the sum depends
// neither on which thread computes which body nor on how bodies are stored or
// spread over processes. Neighbours come from a sorted cell list of centres,
// each cell's run found through a hash index of the cell keys; a pole too far
// from a neighbour's centre for any of its poles skips that neighbour's poles.
// Ghost bodies are neighbours, only owned bodies get a wrench.
// Trade-off: every pair is evaluated twice (once per body) in exchange for no
// write conflicts and thread-count-independent sums.
#pragma once
#include <cstdint>
#include <utility>
#include <vector>

#include "exec/loops.hpp"
#include "forces/force_pass.hpp"
#include "world/world.hpp"

namespace parode {

struct BodyWrench {
    Vec3 force{0, 0, 0};
    Vec3 torque{0, 0, 0};
};

class MagnetField {
public:
    explicit MagnetField(const Scene& scene);
    explicit MagnetField(Scene&&) = delete;  // keeps a reference to the scene
    // Members (after any change of the world's bodies), pole positions and
    // the cell list, from the current body states: the members' poles and
    // keys on `loops` (serial by default), the cell list sorted from last
    // step's order (the same list however it is sorted: its entries are
    // distinct).
    void prepare(const World& world, const LoopRunner& loops = LoopRunner{});
    // Force and torque on magnetised body number k (index into members()).
    BodyWrench gather(std::size_t k) const;
    // Local indices of the bodies with magnets on, owned and ghosts.
    const std::vector<std::uint32_t>& members() const { return members_; }
    // The members that get a wrench (the owned ones), as indices into members().
    const std::vector<std::uint32_t>& targets() const { return targets_; }
    // Apply precomputed wrenches (one per target), in target order.
    void apply(World& world, const std::vector<BodyWrench>& wrenches) const;
    // Centre distance within which two magnetised bodies interact.
    double reach() const { return cell_; }

private:
    struct CellEntry {
        std::int64_t key;
        std::uint32_t gid, member;
        bool operator<(const CellEntry& o) const { return key != o.key ? key < o.key : gid < o.gid; }
    };
    std::int64_t cell_key(const Vec3& c) const;
    // The run of cells_ in cell `key` (empty when none): a lookup in index_.
    std::pair<std::uint32_t, std::uint32_t> run_of(std::int64_t key) const;
    void index_cells();
    // Member k's centre, poles and cell entry (at cells_[at_[k]]).
    void place(const World& world, std::size_t k);
    void sort_cells();
    // Adds to w the pairs of k with the bodies of one run of cells_.
    void visit(std::size_t k, std::pair<std::uint32_t, std::uint32_t> run, BodyWrench& w) const;
    void add_pair(std::size_t k, std::size_t m, BodyWrench& w) const;
    void find_members(const World& world);

    const Scene& scene_;
    const MagnetModel& model_;
    std::uint64_t generation_ = ~0ULL;    // of the world when members were listed
    std::uint64_t magnet_version_ = 0;    // of the world's run-time switches then
    std::vector<std::uint32_t> members_;  // local indices of bodies with magnets on
    std::vector<std::uint32_t> targets_;  // members that are owned
    std::vector<double> radius_;          // per member
    std::vector<std::uint8_t> on_;        // per member: its first 8 poles on (bit p), when partial_
    bool partial_ = false;                // some member has poles switched off one by one
    std::vector<Vec3> centre_;            // per member
    std::vector<Vec3> poles_;             // member-major, world frame
    std::vector<CellEntry> cells_;        // sorted by (cell key, gid)
    std::vector<std::uint32_t> at_;       // per member: its place in cells_ after the last sort
    // Open addressing from a cell key to its run of cells_ (key -1: a free
    // slot), twice the occupied cells: one probe a cell where a binary
    // search of cells_ took about 16 mispredicted steps.
    struct Run {
        std::int64_t key;
        std::uint32_t begin, end;
    };
    std::vector<Run> index_;
    double cell_ = 1.0;
    double reach2_ = 1.0;  // max centre distance^2 for any pole pair to interact
};

// The "magnets" force pass: prepare the field, gather every target's wrench
// (gather_all: a serial loop here; "magnets/omp" overrides it with an OpenMP
// loop of identical results), apply the wrenches in target order.
class MagnetPass : public ForcePass {
public:
    explicit MagnetPass(const Scene& scene) : field_(scene) {}
    std::string name() const override { return "magnets"; }
    void apply(World& world, double time) override;
    // The field prepared for `world` and every target's wrench, without
    // applying them (apply does this, then applies).
    const std::vector<BodyWrench>& wrenches(const World& world);
    const MagnetField& field() const { return field_; }

protected:
    // Fills out[j] = field.gather(targets[j]) for every target j.
    virtual void gather_all(const MagnetField& field, std::vector<BodyWrench>& out) const;
    // Where the field's per-member loops run (here: serially).
    virtual const LoopRunner& loops() const { return serial_; }

private:
    MagnetField field_;
    std::vector<BodyWrench> wrenches_;
    LoopRunner serial_;
};

}  // namespace parode
