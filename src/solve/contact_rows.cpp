// Building and warm-starting contact rows (see contact_rows.hpp): ODE's
// contact joint rows (normal with ERP/CFM, surface layer, max correcting
// velocity and bounce; two friction rows bounded by mu * normal impulse; slip
// as CFM), their effective masses scaled by the SOR factor.
// The four-lane instantiation's helpers take and return 32-byte vectors; they
// are always inlined into the AVX entry point, so no such vector crosses a
// call and GCC's note on the ABI of passing them does not apply (src/
// CMakeLists.txt turns it off for this file).
#include "solve/contact_rows.hpp"

#include <algorithm>

namespace parode {
namespace {

using detail::cross3;
using detail::dot3;
using detail::mul33;

// Target velocity of the normal row (ERP on the depth past the surface layer,
// capped; bounce when closing faster than bounce_vel) given the closing
// velocity J0 v, and the rows' CFMs (soft CFM, slip).
// With substeps the contact's ERP and CFM are converted (substep_softness;
// the slip CFMs are dampers and stay), and what the substeps recompute the
// target from is kept.
void targets(const ContactFrame& f, const RowInputs& in, double closing, double c[3], double cfm[3]) {
    const dSurfaceParameters& s = *in.surface;
    double erp = (s.mode & dContactSoftERP) ? s.soft_erp : in.erp;
    cfm[0] = (s.mode & dContactSoftCFM) ? s.soft_cfm : in.cfm;
    double world_cfm = in.cfm;
    if (in.substeps > 1) {
        double unused = 0;
        substep_softness(erp, cfm[0], in.substeps, erp, cfm[0]);
        substep_softness(in.erp, in.cfm, in.substeps, unused, world_cfm);
    }
    const double depth = std::max(f.depth - in.surface_layer, 0.0);
    c[0] = std::min(in.fps * erp * depth, in.max_correcting_vel);
    c[1] = c[2] = 0;
    double bounce = 0;
    if ((s.mode & dContactBounce) && s.bounce_vel >= 0 && -closing > s.bounce_vel) {
        bounce = s.bounce * -closing;
        c[0] = std::max(c[0], bounce);
    }
    cfm[1] = (s.mode & dContactSlip1) ? s.slip1 : world_cfm;
    cfm[2] = (s.mode & dContactSlip2) ? s.slip2 : world_cfm;
    if (in.kept) *in.kept = Kept{f.depth, erp, bounce};
}

// Jacobian of one contact row along `dir` at lever arms c1, c2 (ODE's layout).
void jacobian_row(const double* dir, const double* c1, const double* c2, double* J) {
    for (int i = 0; i < 3; ++i) {
        J[i] = dir[i];
        J[6 + i] = -dir[i];
    }
    cross3(c1, dir, J + 3);
    cross3(dir, c2, J + 9);
}

}  // namespace

void build_sphere_row(const ContactFrame& f, const RowInputs& in, SphereRow& K) {
    const bool two = f.b2 >= 0;
    K.b1 = f.b1;
    K.b2 = f.b2;
    K.mu = in.surface->mu;
    for (int i = 0; i < 3; ++i) K.n[i] = f.n[i];
    K.r1 = -dot3(f.c1, f.n);
    K.r2 = two ? dot3(f.c2, f.n) : 0.0;
    K.kt = tangent_scale(K.n);
    // With the step's constants (ContactSolver::row_constants): the same bits.
    double erp_s = 0, cfm_s = 0;
    substep_softness(in.erp, in.cfm, in.substeps, erp_s, cfm_s);
    sphere_row_masses(K, in.invm[0], in.invi[0], in.invm[1], in.invi[1], SphereRowConstants{in.sor_w, cfm_s * in.fps},
                      K.ad_n, K.ad_t);
    double closing = dot3(f.n, in.vel[0]);
    if (two) closing -= dot3(f.n, in.vel[1]);
    double c[3], cfm[3];
    targets(f, in, closing, c, cfm);  // cfm: every row's is the solver's (SphereRowConstants)
    sphere_rhs(K, in.tmp[0], two ? in.tmp[1] : nullptr, c[0], in.fps);
    for (int r = 0; r < 3; ++r) K.lambda[r] = 0;
}

void sphere_rhs(SphereRow& K, const double* tmp1, const double* tmp2, double c0, double fps) {
    double t1[3], t2[3];
    tangent_frame(K.n, K.kt, t1, t2);
    const double* lin[3] = {K.n, t1, t2};
    const double ang[3][3] = {{0, 0, 0}, {-t2[0], -t2[1], -t2[2]}, {t1[0], t1[1], t1[2]}};
    const double c[3] = {c0, 0, 0};
    for (int r = 0; r < 3; ++r) {
        double jt = dot3(lin[r], tmp1) + K.r1 * dot3(ang[r], tmp1 + 3);
        if (tmp2) jt += K.r2 * dot3(ang[r], tmp2 + 3) - dot3(lin[r], tmp2);
        K.rhs[r] = c[r] * fps - jt;
    }
}

void build_block(const ContactFrame& f, const RowInputs& in, Block& K) {
    K.b1 = f.b1;
    K.b2 = f.b2;
    K.mu = in.surface->mu;
    K.rows = K.mu > 0 ? 3 : 1;
    jacobian_row(f.n, f.c1, f.c2, K.J[0]);
    double closing = dot3(K.J[0] + 3, in.vel[0] + 3) + dot3(f.n, in.vel[0]);
    if (f.b2 >= 0) closing += dot3(K.J[0] + 9, in.vel[1] + 3) - dot3(f.n, in.vel[1]);
    double c[3], cfm[3];
    targets(f, in, closing, c, cfm);
    if (K.rows == 3) {
        dVector3 nn = {f.n[0], f.n[1], f.n[2], 0}, t1, t2;
        dPlaneSpace(nn, t1, t2);
        jacobian_row(t1, f.c1, f.c2, K.J[1]);
        jacobian_row(t2, f.c1, f.c2, K.J[2]);
    }
    for (int i = 0; i < 3; ++i) K.n[i] = f.n[i];
    for (int row = 0; row < K.rows; ++row) {
        double* J = K.J[row];
        double* iMJ = K.iMJ[row];
        for (int i = 0; i < 3; ++i) iMJ[i] = in.invm[0] * J[i];
        mul33(in.invI[0], J + 3, iMJ + 3);
        double rhs = c[row] * in.fps - dot3(J, in.tmp[0]) - dot3(J + 3, in.tmp[0] + 3);
        double sum = dot3(iMJ, J) + dot3(iMJ + 3, J + 3);
        if (f.b2 >= 0) {
            for (int i = 0; i < 3; ++i) iMJ[6 + i] = in.invm[1] * J[6 + i];
            mul33(in.invI[1], J + 9, iMJ + 9);
            rhs -= dot3(J + 6, in.tmp[1]) + dot3(J + 9, in.tmp[1] + 3);
            sum += dot3(iMJ + 6, J + 6) + dot3(iMJ + 9, J + 9);
        }
        const double cf = cfm[row] * in.fps;
        const double Ad = in.sor_w / (sum + cf);
        for (int i = 0; i < 12; ++i) J[i] *= Ad;
        K.ad[row] = Ad;
        K.rhs[row] = rhs * Ad;
        K.cfm[row] = cf * Ad;
        K.lambda[row] = 0;
    }
}

namespace {
bool avx_available() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    return __builtin_cpu_supports("avx");
#else
    return false;
#endif
}
bool use_four = avx_available();
bool avx512_available() {
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    return __builtin_cpu_supports("avx512f");
#else
    return false;
#endif
}
bool use_eight = avx512_available();

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target("avx"))) void relax_avx(SphereRow* const* K, BodyRow* bodies, const SphereRowConstants& c,
                                              double* change) {
    relax_lanes<detail::Quad, 4>(K, bodies, c, change);
}
__attribute__((target("avx512f"))) void relax_avx512(SphereRow* const* K, BodyRow* bodies, const SphereRowConstants& c,
                                                     double* change) {
    relax_lanes<detail::Oct, 8>(K, bodies, c, change);
}
#else
void relax_avx512(SphereRow* const* K, BodyRow* bodies, const SphereRowConstants& c, double* change) {
    relax_four(K, bodies, c, change);
    relax_four(K + 4, bodies, c, change ? change + 4 : nullptr);
}
void relax_avx(SphereRow* const* K, BodyRow* bodies, const SphereRowConstants& c, double* change) {
    relax_lanes<detail::Pair, 2>(K, bodies, c, change);
    relax_lanes<detail::Pair, 2>(K + 2, bodies, c, change ? change + 2 : nullptr);
}
#endif
}  // namespace

void relax_four(SphereRow* const* K, BodyRow* bodies, const SphereRowConstants& c, double* change) {
    if (use_four) {
        relax_avx(K, bodies, c, change);
        return;
    }
    relax_lanes<detail::Pair, 2>(K, bodies, c, change);
    relax_lanes<detail::Pair, 2>(K + 2, bodies, c, change ? change + 2 : nullptr);
}

void sphere_row_masses(const SphereRow& K, double invm1, double invi1, double invm2, double invi2,
                       const SphereRowConstants& c, double& ad_n, double& ad_t) {
    effective_masses(invm1 + invm2, K.r1 * (invi1 * K.r1) + K.r2 * (invi2 * K.r2), c, ad_n, ad_t);
}

void sphere_row_masses(const SphereRow& K, const BodyRow& B1, const BodyRow& B2, const SphereRowConstants& c,
                       double& ad_n, double& ad_t) {
    sphere_row_masses(K, B1.invm, B1.invi, B2.invm, B2.invi, c, ad_n, ad_t);
}

bool four_lanes() { return use_four; }
void set_four_lanes(bool on) { use_four = on && avx_available(); }

void relax_eight(SphereRow* const* K, BodyRow* bodies, const SphereRowConstants& c, double* change) {
    if (use_eight) {
        relax_avx512(K, bodies, c, change);
        return;
    }
    relax_four(K, bodies, c, change);
    relax_four(K + 4, bodies, c, change ? change + 4 : nullptr);
}
bool eight_lanes() { return use_eight; }
void set_eight_lanes(bool on) { use_eight = on && avx512_available(); }

void apply_impulses(const SphereRow& K, BodyRow* bodies) {
    BodyRow& B1 = bodies[K.b1];
    BodyRow* B2 = K.b2 >= 0 ? &bodies[K.b2] : nullptr;
    const double l0 = K.lambda[0], l1 = K.lambda[1], l2 = K.lambda[2];
    double t1[3], t2[3], dl[3], da[3];
    tangent_frame(K.n, K.kt, t1, t2);
    for (int i = 0; i < 3; ++i) {
        dl[i] = l0 * K.n[i] + (l1 * t1[i] + l2 * t2[i]);
        da[i] = l2 * t1[i] - l1 * t2[i];
    }
    const double k1 = B1.invi * K.r1;
    for (int i = 0; i < 3; ++i) {
        B1.fc[i] += B1.invm * dl[i];
        B1.fc[3 + i] += k1 * da[i];
    }
    if (!B2) return;
    const double k2 = B2->invi * K.r2;
    for (int i = 0; i < 3; ++i) {
        B2->fc[i] -= B2->invm * dl[i];
        B2->fc[3 + i] += k2 * da[i];
    }
}

void apply_impulses(const Block& K, BodyRow* bodies) {
    double* f1 = bodies[K.b1].fc;
    double* f2 = K.b2 >= 0 ? bodies[K.b2].fc : nullptr;
    for (int row = 0; row < K.rows; ++row) {
        const double l = K.lambda[row];
        if (l == 0) continue;
        for (int i = 0; i < 6; ++i) f1[i] += l * K.iMJ[row][i];
        if (f2) {
            for (int i = 0; i < 6; ++i) f2[i] += l * K.iMJ[row][6 + i];
        }
    }
}

}  // namespace parode
