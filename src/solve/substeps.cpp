// Substeps of the project's contact solver (solver.substeps; contact_solver.hpp):
// between the sweeps of two substeps every local body advances by the
// substep's velocity, and every row's right-hand side is recomputed for the
// new velocities and for the depth its bodies' displacement along the
// normal leaves (a sphere's contact point stays on the line of the centres;
// for other shapes this is the first-order change, the lever arms kept).
// Every body and row is updated on its own, by the same arithmetic on any
// process that holds it, so the result is the same for any thread and rank
// count. The sweeps' corrections are not reset: they stay inv(M) J^T lambda
// of the impulses carried over, the next substep's warm start.
// Trade-off: one collision a step and a pass over the bodies and one over
// the rows per extra substep, against the accuracy of a shorter step.
#include "solve/contact_solver.hpp"

namespace parode {
namespace {
constexpr std::size_t kGrain = 2048;
constexpr std::size_t kAhead = 8;
}  // namespace

// At the build, slot by slot (the body data are read there anyway).
void ContactSolver::start_motion(std::size_t slot, const BodyData& B) {
    Motion& M = motion_[slot];
    for (int k = 0; k < 6; ++k) M.v[k] = B.v[k];
    for (int k = 0; k < 6; ++k) M.acc[k] = B.acc[k];
    for (int k = 0; k < 3; ++k) M.turn[k] = 0;
    for (int k = 0; k < 3; ++k) reach_[slot].dx[k] = 0;
}

// Slot by slot: the sweeps' corrections and the motion in the same order.
// The orientation is not needed between substeps (a sphere's contacts do
// not depend on it; other shapes keep their lever arms for the step): the
// turn h w is summed and applied once, by the step's integration.
void ContactSolver::advance_bodies() {
    const std::size_t ns = layout_.order().size();
    const double h = h_, fps = 1.0 / h_;
    for_ranges(loops(), ns, kGrain, [&](std::size_t s0, std::size_t s1) {
        for (std::size_t j = s0; j < s1; ++j) {
            Motion& M = motion_[j];
            Reach& R = reach_[j];
            const double* fc = hot_[j].fc;
            for (int k = 0; k < 6; ++k) M.v[k] += h * (M.acc[k] + fc[k]);
            for (int k = 0; k < 3; ++k) R.dx[k] += h * M.v[k];
            for (int k = 0; k < 3; ++k) M.turn[k] += h * M.v[3 + k];
            for (int k = 0; k < 6; ++k) R.tmp[k] = M.v[k] * fps + M.acc[k];
        }
    });
}

void ContactSolver::refresh_row(std::size_t p, const RowInputs& at) {
    SphereRow& K = rows_[p];
    Block* G = K.b1 < 0 ? &blocks_[static_cast<std::size_t>(-1 - K.b1)] : nullptr;
    const std::int32_t slots[2] = {G ? G->b1 : K.b1, G ? G->b2 : K.b2};
    const double* n = G ? G->n : K.n;
    const Reach* R[2] = {&reach_[static_cast<std::size_t>(slots[0])],
                         slots[1] >= 0 ? &reach_[static_cast<std::size_t>(slots[1])] : nullptr};
    double moved = n[0] * R[0]->dx[0] + n[1] * R[0]->dx[1] + n[2] * R[0]->dx[2];
    if (R[1]) moved -= n[0] * R[1]->dx[0] + n[1] * R[1]->dx[1] + n[2] * R[1]->dx[2];
    const Kept& kept = kept_[p];
    const double c0 = normal_target(kept.depth - moved, kept, at);
    const double* second = R[1] ? R[1]->tmp : nullptr;
    if (G) block_rhs(*G, R[0]->tmp, second, c0, at.fps);
    else sphere_rhs(K, R[0]->tmp, second, c0, at.fps);
}

// The motion rows a contact row reads, fetched kAhead rows early: a row's
// second body lies in another cell, away in slot order (measured at 64,000
// catoms: the pass over the rows waited on these loads most of its time).
void ContactSolver::prefetch_motion(std::size_t p) const {
    const SphereRow& K = rows_[p];
    const Block* G = K.b1 < 0 ? &blocks_[static_cast<std::size_t>(-1 - K.b1)] : nullptr;
    for (std::int32_t s : {G ? G->b1 : K.b1, G ? G->b2 : K.b2}) {
        if (s < 0) continue;
        const char* at = reinterpret_cast<const char*>(&reach_[static_cast<std::size_t>(s)]);
        __builtin_prefetch(at);
        __builtin_prefetch(at + sizeof(Reach) - 1);
    }
}

void ContactSolver::refresh_rows() {
    RowInputs at{};
    at.fps = 1.0 / h_;
    at.surface_layer = scene_.solver.contact_surface_layer;
    at.max_correcting_vel = scene_.solver.contact_max_correcting_vel;
    for_ranges(loops(), rows_.size(), kGrain, [&](std::size_t p0, std::size_t p1) {
        for (std::size_t p = p0; p < p1; ++p) {
            if (p + kAhead < p1) prefetch_motion(p + kAhead);
            refresh_row(p, at);
        }
    });
}

}  // namespace parode
