// The "parallel" solver: ContactSolver (src/contact_solver) with its loops over
// independent items run on OpenMP threads. Relaxation runs in one parallel
// region: the 8 colours in sequence, the cells of a colour shared among threads
// in contiguous ranges (cells are sorted in space, so each thread keeps its
// bodies in cache; cells of one colour touch disjoint bodies), an implicit
// barrier after each colour. Results are bit for bit those of the
// serial "pgs" for any thread count.
// Trade-off: 8 barriers per iteration (160 a step at 20 iterations); worth it
// above a few hundred contacts, below that "pgs" is as fast.
#pragma once
#include "solve/contact_solver.hpp"

namespace parode::omp {

class ParallelContactSolver final : public ContactSolver {
public:
    using ContactSolver::ContactSolver;
    std::string name() const override { return "parallel"; }

private:
    template <class F>
    void sweep_cells(int passes, F&& per_cell);
    void prepare_bodies() override;
    void build_blocks() override;
    void iterate() override;
    void integrate() override;
    void remember() override;
    void warm_start() override;
    void cell_keys() override;
    void sort_keys() override;
};

}  // namespace parode::omp
