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
#include <cmath>

#include "solve/contact_solver.hpp"

namespace parode {
namespace {
constexpr std::size_t kGrain = 2048;
}  // namespace

void ContactSolver::advance_bodies(int s) {
    const std::size_t nb = bodies_.size();
    if (s == 1) motion_.resize(nb);
    const double h = h_;
    for_ranges(loops(), nb, kGrain, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i) {
            BodyData& B = bodies_[i];
            Motion& M = motion_[i];
            if (s == 1) {
                const dReal* q = dBodyGetQuaternion(world_->body(i));
                for (int k = 0; k < 4; ++k) M.q[k] = q[k];
                for (int k = 0; k < 3; ++k) M.dx[k] = 0;
            }
            const double* fc = hot_[layout_.slot()[i]].fc;
            for (int k = 0; k < 6; ++k) B.v[k] += h * (B.acc[k] + fc[k]);
            for (int k = 0; k < 3; ++k) M.dx[k] += h * B.v[k];
            const double* w = B.v + 3;
            const double* q = M.q;
            const double dq[4] = {0.5 * (-w[0] * q[1] - w[1] * q[2] - w[2] * q[3]),
                                  0.5 * (w[0] * q[0] + w[1] * q[3] - w[2] * q[2]),
                                  0.5 * (-w[0] * q[3] + w[1] * q[0] + w[2] * q[1]),
                                  0.5 * (w[0] * q[2] - w[1] * q[1] + w[2] * q[0])};
            double nq[4], len = 0;
            for (int k = 0; k < 4; ++k) {
                nq[k] = q[k] + h * dq[k];
                len += nq[k] * nq[k];
            }
            len = 1.0 / std::sqrt(len);
            for (int k = 0; k < 4; ++k) M.q[k] = nq[k] * len;
        }
    });
}

void ContactSolver::refresh_row(std::size_t p, const RowInputs& at) {
    SphereRow& K = rows_[p];
    Block* G = K.b1 < 0 ? &blocks_[static_cast<std::size_t>(-1 - K.b1)] : nullptr;
    const std::int32_t slots[2] = {G ? G->b1 : K.b1, G ? G->b2 : K.b2};
    const double* n = G ? G->n : K.n;
    double tmp[2][6], moved = 0;
    for (int j = 0; j < 2 && slots[j] >= 0; ++j) {
        const std::uint32_t i = layout_.order()[static_cast<std::size_t>(slots[j])];
        const BodyData& B = bodies_[i];
        for (int k = 0; k < 6; ++k) tmp[j][k] = B.v[k] * at.fps + B.acc[k];
        const double along = n[0] * motion_[i].dx[0] + n[1] * motion_[i].dx[1] + n[2] * motion_[i].dx[2];
        moved += j == 0 ? along : -along;
    }
    const Kept& kept = kept_[p];
    const double c0 = normal_target(kept.depth - moved, kept, at);
    const double* second = slots[1] >= 0 ? tmp[1] : nullptr;
    if (G) block_rhs(*G, tmp[0], second, c0, at.fps);
    else sphere_rhs(K, tmp[0], second, c0, at.fps);
}

void ContactSolver::refresh_rows() {
    RowInputs at{};
    at.fps = 1.0 / h_;
    at.surface_layer = scene_.solver.contact_surface_layer;
    at.max_correcting_vel = scene_.solver.contact_max_correcting_vel;
    for_ranges(loops(), rows_.size(), kGrain, [&](std::size_t p0, std::size_t p1) {
        for (std::size_t p = p0; p < p1; ++p) refresh_row(p, at);
    });
}

}  // namespace parode
