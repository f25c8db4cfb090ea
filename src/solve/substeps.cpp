// Substeps of the project's contact solver (solver.substeps; contact_solver.hpp),
// in the velocity form: with substeps a body's row holds its velocity terms
// tmp = v / h + inv(M) f_ext plus the sweeps' corrections inv(M) J^T lambda
// (s = v_next / h), and a row's right-hand side only its target (the
// ODE form, one substep, keeps tmp in the rows' right-hand sides: J tmp
// subtracted at the build). A sweep computes the same J s - rhs either way,
// to rounding. Between the sweeps of two substeps every local body advances
// by the substep's velocity h s, its row taking the next substep's tmp and
// keeping its corrections (the next substep's warm start), and every normal
// row's target is recomputed for the depth its bodies' displacement along
// the normal leaves (a sphere's contact point stays on the line of the
// centres; for other shapes this is the first-order change, the lever arms
// kept); the friction rows' targets stay 0. Every body and row is updated on
// its own, by the same arithmetic on any process that holds it, so the
// result is the same for any thread and rank count.
// Trade-off: one collision a step and a pass over the bodies and one over
// the rows (a depth each) per extra substep, against the accuracy of a
// shorter step; the velocity form reads a body's 32-byte displacement in the
// pass over the rows, where the ODE form read 72 bytes and recomputed the
// three rows' J tmp (1.5 sweeps' time a substep at 64,000 catoms).
#include "solve/contact_solver.hpp"

namespace parode {
namespace {
constexpr std::size_t kGrain = 2048;
constexpr std::size_t kAhead = 8;
}  // namespace

// At the build, slot by slot (the body data are read there anyway): the
// body's row starts as its velocity terms, the warm start adds to them.
void ContactSolver::start_motion(std::size_t slot, const BodyData& B, BodyRow& H) {
    Motion& M = motion_[slot];
    const double fps = 1.0 / h_;
    for (int k = 0; k < 6; ++k) M.acc[k] = B.acc[k];
    for (int k = 0; k < 6; ++k) M.tmp[k] = B.v[k] * fps + B.acc[k];
    for (int k = 0; k < 6; ++k) H.fc[k] = M.tmp[k];
    for (int k = 0; k < 3; ++k) M.turn[k] = 0;
    for (int k = 0; k < 3; ++k) reach_[slot].dx[k] = 0;
}

// Slot by slot: the substep's velocity v = h s, the displacement and turn it
// adds, and the row for the next substep, tmp' = v / h + inv(M) f_ext = s +
// acc plus the corrections s - tmp kept. The orientation is not needed
// between substeps (a sphere's contacts do not depend on it; other shapes
// keep their lever arms for the step): the turn h w is summed and applied
// once, by the step's integration.
void ContactSolver::advance_bodies() {
    const std::size_t ns = layout_.order().size();
    const double h = h_;
    for_ranges(loops(), ns, kGrain, [&](std::size_t s0, std::size_t s1) {
        for (std::size_t j = s0; j < s1; ++j) {
            Motion& M = motion_[j];
            double* s = hot_[j].fc;
            double* dx = reach_[j].dx;
            for (int k = 0; k < 3; ++k) dx[k] += h * (h * s[k]);
            for (int k = 0; k < 3; ++k) M.turn[k] += h * (h * s[3 + k]);
            for (int k = 0; k < 6; ++k) {
                const double next = s[k] + M.acc[k];
                s[k] = next + (s[k] - M.tmp[k]);
                M.tmp[k] = next;
            }
        }
    });
}

void ContactSolver::refresh_row(std::size_t p, const RowInputs& at) {
    SphereRow& K = rows_[p];
    Block* G = K.b1 < 0 ? &blocks_[static_cast<std::size_t>(-1 - K.b1)] : nullptr;
    const std::int32_t slots[2] = {G ? G->b1 : K.b1, G ? G->b2 : K.b2};
    const double* n = G ? G->n : K.n;
    const double* x1 = reach_[static_cast<std::size_t>(slots[0])].dx;
    double moved = n[0] * x1[0] + n[1] * x1[1] + n[2] * x1[2];
    if (slots[1] >= 0) {
        const double* x2 = reach_[static_cast<std::size_t>(slots[1])].dx;
        moved -= n[0] * x2[0] + n[1] * x2[1] + n[2] * x2[2];
    }
    const double c0 = normal_target(kept_[p].depth - moved, kept_[p], at) * at.fps;
    if (G) G->rhs[0] = G->ad[0] * c0;
    else K.rhs[0] = c0;
}

// The displacements a contact row reads, fetched kAhead rows early: a row's
// second body lies in another cell, away in slot order (measured at 64,000
// catoms: the pass over the rows waited on these loads most of its time).
void ContactSolver::prefetch_motion(std::size_t p) const {
    const SphereRow& K = rows_[p];
    const Block* G = K.b1 < 0 ? &blocks_[static_cast<std::size_t>(-1 - K.b1)] : nullptr;
    for (std::int32_t s : {G ? G->b1 : K.b1, G ? G->b2 : K.b2}) {
        if (s >= 0) __builtin_prefetch(&reach_[static_cast<std::size_t>(s)]);
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
