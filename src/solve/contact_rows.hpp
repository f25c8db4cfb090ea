// The rows of one contact as the contact solver relaxes them, in two forms.
// SphereRow, for sphere-sphere and sphere-plane contacts between bodies of
// isotropic inertia: the contact point lies on the line of the centres, so the
// normal row has no angular part and each friction row's angular part is the
// lever length times (tangent x normal) = -t2 for t1 and t1 for t2; the row
// keeps the frame (n, t1, t2), the two lever lengths and, per row, its
// effective mass (SOR factor over J inv(M) J^T + CFM), right-hand side and
// impulse: 160 bytes against 650 for the general Block, which keeps J and
// inv(M) J^T as 3 x 12 doubles for any other contact. The masses come from
// the bodies' BodyRow (inverse mass and inverse inertia beside the velocity
// corrections, one cache line a body).
// Trade-off: two code paths for one contact model; the sphere path drops the
// rounding-level angular terms the general Jacobian carries, so its state
// hash differs from the general path's in the last bits (test_contact_rows
// holds the two to the same impulses within 1e-9 relative).
#pragma once
#include <ode/ode.h>

#include <cmath>
#include <cstdint>

namespace parode {

// Velocity corrections inv(M) J^T lambda of one body (linear, angular), its
// inverse mass and scalar inverse inertia (0 when its inertia is not
// isotropic): all the sweeps read of a body.
struct alignas(64) BodyRow {
    double fc[6];
    double invm;
    double invi;
};

struct SphereRow {
    std::int32_t b1, b2;  // body slots; b2 < 0: static
    double n[3], t1[3], t2[3];
    double r1, r2;        // lever lengths: contact point = x1 - r1 n = x2 + r2 n
    double ad[3];         // SOR w / (J inv(M) J^T + cfm)
    double rhs[3];        // target velocity terms, unscaled
    double lambda[3];
    double cfm;           // cfm / dt, every row
    double mu;            // rows: 3 when mu > 0, else 1
};

struct Block {
    std::int32_t b1 = -1, b2 = -1;  // body slots; b2 < 0: static
    int rows = 1;
    double mu = 0;
    double J[3][12];    // scaled by Ad
    double iMJ[3][12];  // inv(M) J^T, unscaled
    double rhs[3], cfm[3], lambda[3];
};

// A contact as the builder sees it: bodies, normal into body 1 (ODE's
// convention), lever arms from the body centres to the contact point, depth.
struct ContactFrame {
    std::int32_t b1, b2;   // body slots; b2 < 0: static
    double n[3], c1[3], c2[3];
    double depth;
};

// What a row's build needs beside the frame: per body (1, 2) the velocity
// terms tmp = v / dt + inv(M) f_ext and the actual velocity (bounce), the
// surface, and the solver's settings.
struct RowInputs {
    const double* tmp[2];  // 6 each; tmp[1] null when static
    const double* vel[2];
    const double* invI[2];  // world-frame inverse inertia (Block only)
    const BodyRow* body[2];
    const dSurfaceParameters* surface;
    double fps, erp, cfm, surface_layer, max_correcting_vel, sor_w;
};

void build_sphere_row(const ContactFrame& f, const RowInputs& in, SphereRow& K);
void build_block(const ContactFrame& f, const RowInputs& in, Block& K);

// Impulses in, velocity corrections out (warm start).
void apply_impulses(const SphereRow& K, BodyRow* bodies);
void apply_impulses(const Block& K, BodyRow* bodies);

namespace detail {
inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double clamp_row(double v, double lo, double hi) { return v < lo ? lo : v > hi ? hi : v; }
}  // namespace detail

// One projected Gauss-Seidel update of every row of a contact.
inline void relax(SphereRow& K, BodyRow* bodies) {
    using detail::dot3;
    BodyRow& B1 = bodies[K.b1];
    BodyRow* B2 = K.b2 >= 0 ? &bodies[K.b2] : nullptr;
    const double m1 = B1.invm, k1 = B1.invi * K.r1;
    const double m2 = B2 ? B2->invm : 0.0, k2 = B2 ? B2->invi * K.r2 : 0.0;
    double* f1 = B1.fc;
    double* f2 = B2 ? B2->fc : nullptr;
    const int rows = K.mu > 0 ? 3 : 1;
    const double* lin[3] = {K.n, K.t1, K.t2};
    double ang[3][3] = {{0, 0, 0}, {-K.t2[0], -K.t2[1], -K.t2[2]}, {K.t1[0], K.t1[1], K.t1[2]}};
    for (int r = 0; r < rows; ++r) {
        const double* d = lin[r];
        const double* a = ang[r];
        double jf = dot3(d, f1) + K.r1 * dot3(a, f1 + 3);
        if (f2) jf += K.r2 * dot3(a, f2 + 3) - dot3(d, f2);
        const double hi = r == 0 ? HUGE_VAL : std::fabs(K.mu * K.lambda[0]);
        const double lo = r == 0 ? 0.0 : -hi;
        const double old = K.lambda[r];
        const double nl = detail::clamp_row(old + K.ad[r] * (K.rhs[r] - K.cfm * old - jf), lo, hi);
        const double delta = nl - old;
        K.lambda[r] = nl;
        for (int i = 0; i < 3; ++i) {
            f1[i] += delta * m1 * d[i];
            f1[3 + i] += delta * k1 * a[i];
        }
        if (f2) {
            for (int i = 0; i < 3; ++i) {
                f2[i] -= delta * m2 * d[i];
                f2[3 + i] += delta * k2 * a[i];
            }
        }
    }
}

inline void relax(Block& K, BodyRow* bodies) {
    double* f1 = bodies[K.b1].fc;
    double* f2 = K.b2 >= 0 ? bodies[K.b2].fc : nullptr;
    for (int row = 0; row < K.rows; ++row) {
        const double* J = K.J[row];
        double delta = K.rhs[row] - K.lambda[row] * K.cfm[row] - detail::dot3(J, f1) - detail::dot3(J + 3, f1 + 3);
        if (f2) delta -= detail::dot3(J + 6, f2) + detail::dot3(J + 9, f2 + 3);
        const double hi = row == 0 ? HUGE_VAL : std::fabs(K.mu * K.lambda[0]);
        const double lo = row == 0 ? 0.0 : -hi;
        const double old = K.lambda[row];
        const double nl = detail::clamp_row(old + delta, lo, hi);
        delta = nl - old;
        K.lambda[row] = nl;
        const double* iMJ = K.iMJ[row];
        for (int i = 0; i < 6; ++i) f1[i] += delta * iMJ[i];
        if (f2) {
            for (int i = 0; i < 6; ++i) f2[i] += delta * iMJ[6 + i];
        }
    }
}

}  // namespace parode
