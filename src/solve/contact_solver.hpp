// The project's contact solver: projected Gauss-Seidel with ODE QuickStep's
// contact model (the rows of ODE's contact joint: normal with ERP/CFM, surface
// layer, max correcting velocity and bounce; two friction rows bounded by
// mu * normal force as with dContactApprox1; slip as CFM; SOR factor w), ordered
// by space: each contact belongs to the cell (edge 4 r_max) of its lower-id
// body and is relaxed in canonical order within that cell; cells take one of 8
// colours by the parity of their coordinates, and two cells of one colour never
// touch the same body, so they can be relaxed in any order, or in parallel,
// with the same result. Every iteration sweeps the colours in order. Each
// contact starts from the impulses its pair had last step (warm start, matched
// by canonical key), which QuickStep does not do. The bodies are then advanced
// with the explicit update of ODE's steppers (v += h (invM fe + fc), x += h v,
// q += h/2 (0, w) q), computed per body and written back through ODE's setters.
// Each phase is a loop over independent items (bodies, contacts or cells) in a
// virtual function; omp/ overrides only those loops.
// Trade-off: a fixed spatial order instead of QuickStep's canonical order with
// random reshuffles: results independent of the thread count, and with warm
// starting at least QuickStep's accuracy per iteration on the classic scenes.
// No damping, no auto-disable: such scenes stay on ODE's stepper (solver.cpp).
#pragma once
#include <array>
#include <cstdint>
#include <vector>

#include "collide/contacts.hpp"
#include "domain/cells.hpp"
#include "solve/solver.hpp"
#include "world/world.hpp"

namespace parode {

// A contact's impulses at the end of a step, kept for the next step's warm
// start, by canonical key. Sorted by (lo, hi, index).
struct WarmImpulse {
    std::uint32_t lo, hi, index;
    double lambda[3];
};

// Keeps copies of shared bodies consistent during the solve of a distributed
// run: after each colour of each sweep, the velocity corrections (inv(M) J^T
// lambda, 6 doubles a body) of the bodies that this process's cells of that
// colour touched go to the processes holding copies of them, and theirs come
// in. Cells of one colour touch disjoint bodies, so every body's corrections
// are summed in the same order as on one process.
class CorrectionExchange {
public:
    virtual ~CorrectionExchange() = default;
    // Once a step, before the warm start: the local bodies that this
    // process's cells of each colour touch (each listed once per colour).
    virtual void plan(const std::vector<std::vector<std::uint32_t>>& touched) = 0;
    // After colour `c`: send this process's corrections, take the others'.
    virtual void exchange(int colour, std::array<double, 6>* fc) = 0;
};

class ContactSolver : public SolverBackend {
public:
    explicit ContactSolver(const Scene& scene);
    std::string name() const override { return "pgs"; }
    bool uses_contact_joints() const override { return false; }
    void step(World& world, const ContactBuffer& contacts) override;

    int colours() const { return static_cast<int>(colour_start_.size()) - 1; }
    std::size_t blocks() const { return blocks_.size(); }
    std::vector<WarmImpulse>* warm_impulses() override { return &previous_; }
    void set_exchange(CorrectionExchange* exchange) override { exchange_ = exchange; }
    const CellSpace& cells() const { return cells_; }

protected:
    struct Body {
        double invm = 0;
        std::array<double, 9> invI{};   // world frame
        std::array<double, 6> tmp{};    // v/h + invM fe (linear, angular)
        std::array<double, 6> acc{};    // invM fe: external acceleration
        std::array<double, 7> next{};   // integrated position and quaternion
    };
    struct Block {
        std::int32_t b1 = -1, b2 = -1;  // b2 = -1: static geom
        int rows = 1;
        double mu = 0;
        double J[3][12];    // scaled by Ad
        double iMJ[3][12];  // inv(M) J^T, unscaled
        double rhs[3], cfm[3], lambda[3];
    };

    // One item of each phase (independent of every other item of the phase).
    void prepare_body(std::size_t i);
    void build_block(std::size_t slot);
    void relax(std::size_t k);
    void warm_block(std::size_t k);
    void integrate_body(std::size_t i);
    void remember_block(std::size_t s);

    // The loops; the parallel solver overrides these.
    virtual void prepare_bodies();
    virtual void build_blocks();
    virtual void iterate();
    virtual void warm_start();
    virtual void integrate();
    virtual void remember();

    // Contact k's cell (colour in the top 3 bits, then the CellSpace key);
    // (cell, contact) pairs are unique, so their sorted order is too.
    struct CellKey {
        std::uint64_t cell;
        std::uint32_t k;
        bool operator<(const CellKey& o) const { return cell != o.cell ? cell < o.cell : k < o.k; }
    };
    void cell_key(std::size_t k);
    virtual void cell_keys();
    virtual void sort_keys();
    std::vector<CellKey>& keys() { return keys_; }

    std::size_t world_body_count() const { return bodies_.size(); }
    // Cells (tasks) of colour c are [colour_start_[c], colour_start_[c+1]); cell t
    // holds block slots [cell_start_[t], cell_start_[t+1]).
    std::size_t colour_begin(int c) const { return colour_start_[static_cast<std::size_t>(c)]; }
    std::size_t colour_end(int c) const { return colour_start_[static_cast<std::size_t>(c) + 1]; }
    void relax_cell(std::size_t t);
    void warm_cell(std::size_t t);
    int iterations() const { return scene_.solver.iterations; }
    // After colour c of a sweep (serially, between the colours).
    void exchange_after(int c) {
        if (exchange_) exchange_->exchange(c, fc_.data());
    }
    bool exchanging() const { return exchange_ != nullptr; }
    bool ghost(std::size_t i) const { return world_->ghost(i); }

private:
    void colour(const ContactBuffer& contacts);
    void plan_exchange();
    void match_previous(const ContactBuffer& contacts);
    void commit(World& world) const;

    const Scene& scene_;
    const World* world_ = nullptr;
    const ContactBuffer* contacts_ = nullptr;
    std::vector<Body> bodies_;
    std::vector<std::array<double, 6>> fc_;      // inv(M) J^T lambda per body
    std::vector<std::uint32_t> slot_contact_;    // block slot -> contact index
    std::vector<CellKey> keys_;
    std::vector<Block> blocks_;
    std::vector<std::size_t> colour_start_;     // colour -> first cell
    std::vector<std::size_t> cell_start_;       // cell -> first block slot
    CellSpace cells_;
    std::vector<WarmImpulse> previous_;          // last step's impulses, canonical order
    std::vector<std::int64_t> warm_;             // contact -> index into previous_, or -1
    CorrectionExchange* exchange_ = nullptr;
    std::vector<std::vector<std::uint32_t>> touched_;  // per colour, for the exchange
    std::vector<std::uint32_t> stamp_;                 // per body: last colour + 1 that listed it
};

}  // namespace parode
