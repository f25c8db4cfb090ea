// The project's contact solver: projected Gauss-Seidel with ODE QuickStep's
// contact model (solve/contact_rows.hpp: the rows of ODE's contact joint,
// SOR factor w), ordered by space: each contact belongs to the cell (edge
// 4 r_max) of its lower-id body and is relaxed in canonical order within that
// cell; cells take one of 8 colours by the parity of their coordinates, and
// two cells of one colour never touch the same body, so they can be relaxed in
// any order, or in parallel, with the same result. Every iteration sweeps the
// colours in order. Each contact starts from the impulses its pair had last
// step (warm start, matched by canonical key), which QuickStep does not do.
// The bodies are then advanced with the explicit update of ODE's steppers
// (v += h (invM fe + fc), x += h v, q += h/2 (0, w) q), computed per body and
// written back through ODE's setters.
// Layout for the sweeps (solve/sweep_layout.hpp): bodies in cell order, one
// cache line each (velocity corrections, inverse mass and inertia); contacts
// in sweep order, sphere-sphere and sphere-plane ones as 128-byte rows, others
// as general blocks. Every loop goes through util/parallel.hpp; omp/ runs the
// sweeps themselves (one parallel region, a barrier per colour).
// Trade-off: a fixed spatial order instead of QuickStep's canonical order with
// random reshuffles: results independent of the thread count, and with warm
// starting at least QuickStep's accuracy per iteration on the classic scenes.
// With solver.substeps = S > 1 the step is cut into S substeps of dt / S on
// one collision: each runs `iterations` sweeps, then every body (ghosts too,
// with the same arithmetic as on its owner) moves by its substep's velocity,
// and each normal row's target is recomputed for the depth its bodies'
// displacement along the normal leaves; the bodies' rows hold velocities
// (the velocity form), so no other term of a row changes; the impulses
// carry over from substep to substep (substeps.cpp). ERP and CFM, given for
// dt, become the same spring and damper at dt / S (substep_softness).
// No damping, no auto-disable: such scenes stay on ODE's stepper (solver.cpp).
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "collide/contacts.hpp"
#include "domain/cells.hpp"
#include "solve/contact_rows.hpp"
#include "solve/solver.hpp"
#include "solve/sweep_layout.hpp"
#include "exec/execution.hpp"
#include "util/substages.hpp"
#include "world/world.hpp"

namespace parode {

// A contact's impulses at the end of a step, kept for the next step's warm
// start, by canonical key. Sorted by (lo, hi, index).
struct WarmImpulse {
    std::uint32_t lo, hi, index;
    double lambda[3];
};
// The canonical order of impulses: (lo, hi, index).
inline bool warm_less(const WarmImpulse& a, const WarmImpulse& b) {
    return a.lo != b.lo ? a.lo < b.lo : a.hi != b.hi ? a.hi < b.hi : a.index < b.index;
}

// The solver's velocity corrections (inv(M) J^T lambda, linear then angular)
// of local body `local`: six doubles, stored in the solver's body order.
class CorrectionView {
public:
    CorrectionView(BodyRow* rows, const std::uint32_t* slot) : rows_(rows), slot_(slot) {}
    double* of(std::uint32_t local) const { return rows_[slot_[local]].fc; }

private:
    BodyRow* rows_;
    const std::uint32_t* slot_;
};

// Keeps copies of shared bodies consistent during the solve of a distributed
// run: after each colour of each sweep, the velocity corrections of the bodies
// that this process's cells of that colour touched go to the processes holding
// copies of them, and theirs come in. Cells of one colour touch disjoint
// bodies, so every body's corrections are summed in the same order as on one
// process.
// The exchange comes in two halves so that work runs while the messages
// travel: post() once the colour's boundary cells are relaxed (the only ones
// that touch bodies other processes hold), complete() after its interior
// cells, which touch no such body.
class CorrectionExchange {
public:
    virtual ~CorrectionExchange() = default;
    // Whether another process holds a copy of local body `local` (valid after
    // the step's exchange of states).
    virtual bool shared(std::uint32_t local) const = 0;
    // Once a step, before the warm start: the local bodies that this
    // process's cells of each colour touch (each listed once per colour).
    virtual void plan(const std::vector<std::vector<std::uint32_t>>& touched) = 0;
    // After colour `c`'s boundary cells: send this process's corrections.
    virtual void post(int colour, const CorrectionView& fc) = 0;
    // After its interior cells: take the other processes' corrections.
    virtual void complete(int colour, const CorrectionView& fc) = 0;
    // Whether any process says yes (the adaptive solver: whether any cell
    // anywhere is swept again); every process calls it alike.
    virtual bool any(bool mine) { return mine; }
    void exchange(int colour, const CorrectionView& fc) {
        post(colour, fc);
        complete(colour, fc);
    }
};


class ContactSolver : public SolverBackend {
public:
    // Its loops, per-step tables and (omp/) threads come from `exec`, which
    // must outlive it.
    // adaptive: the adaptive solver (active sweeps after solver.adaptive_sweeps
    // sweeps of every cell, active_sweeps.cpp), else `iterations` sweeps.
    ContactSolver(const Scene& scene, Execution& exec, bool adaptive = false);
    ContactSolver(Scene&&, Execution&, bool = false) = delete;  // keeps a reference to the scene
    std::string name() const override { return adaptive_ ? "adaptive" : "pgs"; }
    bool uses_contact_joints() const override { return false; }
    void step(World& world, const ContactBuffer& contacts) override;
    std::vector<WarmImpulse>* warm_impulses() override { return &previous_; }
    void set_exchange(CorrectionExchange* exchange) override { exchange_ = exchange; }
    const Substages* substages() const override { return &times_; }
    const ColourTimes* colour_times() const override { return &colour_times_; }
    const ActiveWork* active_work() const override { return adaptive_ ? &active_work_ : nullptr; }
    bool wrote_finite_state() const override { return finite_; }
    double max_speed_written() const override { return max_speed_; }

    static constexpr int kColours = SweepLayout::kColours;
    // Contacts of the last step as compact sphere rows and as general blocks.
    std::size_t sphere_rows() const { return contacts_ ? contacts_->size() - blocks_.size() : 0; }
    std::size_t general_blocks() const { return blocks_.size(); }
    // Every contact through the general block (for tests comparing the two).
    void set_general_only(bool on) { general_only_ = on; }

protected:
    // Relaxes (or, with `warm`, applies the warm-start impulses of) cells
    // [t0, t1) of one colour.
    void relax_cells(std::size_t t0, std::size_t t1);
    void relax_pack(SphereRow* const* pack, int held, double* change);
    static constexpr int kMostStreams = 8;
    void relax_rounds(const std::size_t* at, int streams, std::size_t rounds);
    void relax_round(std::size_t* at, const std::size_t* end, int streams);
    SphereRowConstants row_constants() const;
    void warm_cells(std::size_t t0, std::size_t t1);
    // `passes` sweeps over the colours; after each colour, exchange_after.
    // omp/ overrides this with its threaded sweep.
    virtual void sweep(int passes, bool warm);
    // One sweep of the cells listed in active_ (active_sweeps.cpp), colour by
    // colour, each class of a colour (boundary cells, then interior ones)
    // through relax_listed; omp/ overrides it with its threads.
    virtual void list_sweep();
    // Entries [a0, a1) of the listed cells, as relax_cells relaxes a range,
    // each cell's largest change kept in cell_change_.
    void relax_listed(std::size_t a0, std::size_t a1);
    bool adaptive() const { return adaptive_; }
    // The listed cells of class k (colour c: 2c its boundary cells, 2c + 1
    // its interior ones): entries [listed_begin(k), listed_begin(k + 1)); the
    // contacts of entries [0, a): listed_contacts(a).
    std::size_t listed_begin(int k) const { return listed_start_[static_cast<std::size_t>(k)]; }
    std::size_t listed_contacts(std::size_t a) const { return listed_pos_[a]; }
    // The first entry of [a0, a1) whose contacts before it are at least
    // `contacts`, or a1.
    std::size_t listed_entry_at(std::size_t a0, std::size_t a1, std::size_t contacts) const {
        const auto b = listed_pos_.begin();
        return static_cast<std::size_t>(std::lower_bound(b + static_cast<std::ptrdiff_t>(a0),
                                                         b + static_cast<std::ptrdiff_t>(a1), contacts) - b);
    }
    const SweepLayout& layout() const { return layout_; }
    int iterations() const { return scene_.solver.iterations; }
    int substeps() const { return substeps_; }
    std::size_t contact_count() const { return contacts_ ? contacts_->size() : 0; }
    // The halves of colour c's exchange (serially: one thread talks).
    void post_after_boundary(int c) {
        SubstageTimer t(times_, "exchange");  // within warm_start and sweeps: the time spent talking
        exchange_->post(c, CorrectionView(hot_.data(), layout_.slot().data()));
    }
    void complete_after_interior(int c) {
        SubstageTimer t(times_, "exchange");
        exchange_->complete(c, CorrectionView(hot_.data(), layout_.slot().data()));
    }
    // Colour c of a sweep on this thread alone: boundary cells, post,
    // interior cells, complete (without an exchange: the cells in one go);
    // its compute and wait seconds added to colour_times_.
    void colour_alone(int c, bool warm);
    ColourTimes& colour_times_mut() { return colour_times_; }
    bool exchanging() const { return exchange_ != nullptr; }
    Substages& times() { return times_; }
    Execution& execution() const { return exec_; }
    const LoopRunner& loops() const { return exec_.loops(); }

private:
    // Per local body, what build and integrate need (the sweeps use BodyRow).
    struct BodyData {
        double x[3];     // position; after integrate, the new one
        double v[6];     // velocity; after integrate, the new one
        double acc[6];   // invM fe; after integrate, acc[0..3] holds the new quaternion
        double invm, invi;  // invi = 0: anisotropic, see invI_
    };
    void prepare_body(std::size_t i);
    void classify(std::size_t k);
    void fill_body_rows();
    void classify_and_match();
    void prefetch_row(std::size_t p) const;
    void build_row(std::size_t k);
    void plan_exchange();
    // The sweeps of a step or substep: `iterations`, or the adaptive solver's.
    void iterate();
    void active_sweeps();
    // Lists every cell (all) or those whose change passed the tolerance;
    // whether any process listed one.
    bool list_cells(bool all);
    bool integrate_body(World& world, std::size_t i, double& max_speed);
    void integrate_phase(World& world);
    // Substeps (substeps.cpp): every local body's displacement and its row for
    // the next substep (the velocity form), then every normal row's target.
    void advance_bodies();
    void start_motion(std::size_t slot, const BodyData& B, BodyRow& H);
    void refresh_rows();
    void refresh_row(std::size_t p, const RowInputs& at);
    void prefetch_motion(std::size_t p) const;
    void remember(std::size_t k);
    void commit(World& world) const;
    void build_phase();
    ContactFrame frame(const ContactRecord& r, std::uint32_t k) const;
    bool sphere_pair(const ContactRecord& r, std::size_t k) const;
    bool only_sphere_rows() const;
    const double* inv_inertia(std::uint32_t local, double* diag) const;

    // Per body slot (the sweeps' order) during substeps: the velocity terms
    // of its external forces (inv(M) f_ext), the turn so far and its velocity
    // terms tmp = v / h + inv(M) f_ext at the substep's start (its row holds
    // tmp plus the sweeps' corrections: the velocity form, substeps.cpp), read
    // and written in slot order by the pass over the bodies; and what the
    // pass over the rows reads of a body (in cell order, so nearly in slot
    // order): its displacement since the step began, 32 bytes. That pass is
    // bound by memory traffic: reading the 128-byte Motion there took 1.6 x
    // as long as a 72-byte record.
    struct alignas(64) Motion {
        double acc[6], tmp[6], turn[3];  // turn: the sum of h w over the substeps so far
    };
    struct alignas(32) Reach {
        double dx[3];
    };

    const Scene& scene_;
    Execution& exec_;
    CellSpace cells_;
    const int substeps_;                             // solver.substeps
    const double h_;                                 // dt / substeps_
    std::vector<Kept> kept_;                         // per position, with substeps
    ScratchArray<Motion> motion_{&exec_.scratch(), kSlotMotion};  // per body slot, with substeps
    ScratchArray<Reach> reach_{&exec_.scratch(), kSlotReach};     // per body slot, with substeps
    const World* world_ = nullptr;
    const ContactBuffer* contacts_ = nullptr;
    bool general_only_ = false;
    ScratchArray<BodyData> bodies_{&exec_.scratch(), kSlotBodies};  // per local body
    std::vector<std::array<double, 9>> invI_;        // per local body, unless all are spheres
    std::uint64_t shapes_of_ = ~0ULL;                // world generation all_spheres_ is for
    bool all_spheres_ = true;
    bool all_rows_ = false;                          // this step: every contact a sphere row
    std::vector<std::uint64_t> cell_;                // per local body
    std::vector<std::uint32_t> owner_, other_;       // per contact: local bodies of lo and hi (or none)
    std::vector<std::uint32_t> block_of_;            // per contact: index into blocks_, or kNone
    SweepLayout layout_;
    ScratchArray<BodyRow> hot_{&exec_.scratch(), kSlotBodyRows};  // per body slot
    ScratchArray<SphereRow> rows_{&exec_.scratch(), kSlotRows};   // per position; general: b1 = -1 - block index
    std::vector<Block> blocks_;
    std::vector<WarmImpulse> previous_;              // last step's impulses, canonical order
    std::vector<std::uint32_t> warm_;                // contact -> index into previous_, or kNone
    CorrectionExchange* exchange_ = nullptr;
    std::vector<std::vector<std::uint32_t>> touched_;  // per colour, for the exchange
    std::vector<std::uint8_t> stamp_;                  // per body: last colour + 1 that listed it (at most 8)
    std::vector<std::uint8_t> shared_;                 // per body: another process holds a copy
    Substages times_;
    ColourTimes colour_times_;
    bool finite_ = false;  // every owned body's new state was finite
    double max_speed_ = -1.0;  // the largest linear speed integrate wrote
    const bool adaptive_;
    std::vector<double> cell_change_;           // per cell of the layout: its last sweep's largest change
    std::vector<std::uint32_t> listed_;         // cells to sweep, class by class, in layout order
    std::array<std::size_t, 2 * kColours + 1> listed_start_{};
    std::vector<std::size_t> listed_pos_;       // contacts of listed_[0, a), per a (size + 1)
    ActiveWork active_work_;
};

}  // namespace parode
