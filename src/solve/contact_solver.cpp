// Project contact solver, serial reference (see contact_solver.hpp).
#include "solve/contact_solver.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace parode {
namespace {

void cross(const double* a, const double* b, double* out) {
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
double dot6(const double* a, const double* b) { return dot3(a, b) + dot3(a + 3, b + 3); }

void mul33(const double* M, const double* v, double* out) {
    for (int r = 0; r < 3; ++r) out[r] = M[3 * r] * v[0] + M[3 * r + 1] * v[1] + M[3 * r + 2] * v[2];
}

// out = R A R^T, with R in ODE's 3x4 layout and A, out row-major 3x3.
void rotate_tensor(const dReal* R, const double* A, double* out) {
    double RA[9];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) RA[3 * r + c] = R[4 * r] * A[c] + R[4 * r + 1] * A[3 + c] + R[4 * r + 2] * A[6 + c];
    for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) out[3 * r + c] = RA[3 * r] * R[4 * c] + RA[3 * r + 1] * R[4 * c + 1] + RA[3 * r + 2] * R[4 * c + 2];
}

void invert33(const double* m, double* out) {
    const double a = m[4] * m[8] - m[5] * m[7], b = m[5] * m[6] - m[3] * m[8], c = m[3] * m[7] - m[4] * m[6];
    const double inv_det = 1.0 / (m[0] * a + m[1] * b + m[2] * c);
    out[0] = a * inv_det;
    out[1] = (m[2] * m[7] - m[1] * m[8]) * inv_det;
    out[2] = (m[1] * m[5] - m[2] * m[4]) * inv_det;
    out[3] = b * inv_det;
    out[4] = (m[0] * m[8] - m[2] * m[6]) * inv_det;
    out[5] = (m[2] * m[3] - m[0] * m[5]) * inv_det;
    out[6] = c * inv_det;
    out[7] = (m[1] * m[6] - m[0] * m[7]) * inv_det;
    out[8] = (m[0] * m[4] - m[1] * m[3]) * inv_det;
}

// Jacobian of one contact row along `dir` at lever arms c1, c2 (ODE's layout).
void jacobian_row(const double* dir, const double* c1, const double* c2, double* J) {
    for (int i = 0; i < 3; ++i) {
        J[i] = dir[i];
        J[6 + i] = -dir[i];
    }
    cross(c1, dir, J + 3);
    cross(dir, c2, J + 9);
}

}  // namespace

// A body's contacts are owned by cells within 2 r_max of it: with cells of
// 4 r_max they span at most two cells per axis, of different parity.
ContactSolver::ContactSolver(const Scene& scene) : scene_(scene), cells_(scene) {}

void ContactSolver::cell_key(std::size_t k) {
    const ContactRecord& r = contacts_->items()[k];
    dGeomID owner = world_->is_body_id(r.lo) ? r.geom.g1 : r.geom.g2;  // a dynamic body
    const std::uint64_t cell = cells_.key(dBodyGetPosition(dGeomGetBody(owner)));
    keys_[k] = {static_cast<std::uint64_t>(CellSpace::colour(cell)) << 61 | cell, static_cast<std::uint32_t>(k)};
}

void ContactSolver::cell_keys() {
    for (std::size_t k = 0; k < keys_.size(); ++k) cell_key(k);
}

void ContactSolver::sort_keys() { std::sort(keys_.begin(), keys_.end()); }

void ContactSolver::colour(const ContactBuffer& contacts) {
    const std::size_t n = contacts.size();
    keys_.resize(n);
    cell_keys();
    sort_keys();
    const std::vector<CellKey>& keys = keys_;
    slot_contact_.resize(n);
    cell_start_.clear();
    colour_start_.assign(9, 0);
    for (std::size_t s = 0; s < n; ++s) {
        slot_contact_[s] = keys[s].k;
        if (s == 0 || keys[s].cell != keys[s - 1].cell) {
            cell_start_.push_back(s);
            for (std::size_t c = (keys[s].cell >> 61) + 1; c < 9; ++c) colour_start_[c] = cell_start_.size();
        }
    }
    cell_start_.push_back(n);
}

void ContactSolver::prepare_body(std::size_t i) {
    dBodyID b = world_->body(i);
    Body& B = bodies_[i];
    dMass m;
    dBodyGetMass(b, &m);
    const dReal* R = dBodyGetRotation(b);
    const double I[9] = {m.I[0], m.I[1], m.I[2], m.I[4], m.I[5], m.I[6], m.I[8], m.I[9], m.I[10]};
    double invIb[9];
    invert33(I, invIb);
    double Iw[9];
    rotate_tensor(R, I, Iw);
    rotate_tensor(R, invIb, B.invI.data());
    B.invm = 1.0 / m.mass;
    const dReal* f = dBodyGetForce(b);
    const dReal* t = dBodyGetTorque(b);
    const dReal* v = dBodyGetLinearVel(b);
    const dReal* w = dBodyGetAngularVel(b);
    const double fps = 1.0 / scene_.dt;
    const bool gravity = dBodyGetGravityMode(b) != 0;
    double te[3] = {t[0], t[1], t[2]};
    if (dBodyGetGyroscopicMode(b)) {
        double L[3], gyro[3];
        mul33(Iw, w, L);
        cross(w, L, gyro);
        for (int k = 0; k < 3; ++k) te[k] -= gyro[k];
    }
    double a[3];
    mul33(B.invI.data(), te, a);
    for (int k = 0; k < 3; ++k) {
        B.acc[k] = B.invm * (f[k] + (gravity ? m.mass * scene_.gravity[k] : 0.0));
        B.acc[3 + k] = a[k];
        B.tmp[k] = v[k] * fps + B.acc[k];
        B.tmp[3 + k] = w[k] * fps + a[k];
    }
    fc_[i].fill(0.0);
}

void ContactSolver::build_block(std::size_t slot) {
    const ContactRecord& r = contacts_->items()[slot_contact_[slot]];
    Block& K = blocks_[slot];
    K.b1 = world_->is_body_id(r.lo) ? static_cast<std::int32_t>(World::local_of_geom(r.geom.g1)) : -1;
    K.b2 = world_->is_body_id(r.hi) ? static_cast<std::int32_t>(World::local_of_geom(r.geom.g2)) : -1;
    double n[3] = {r.geom.normal[0], r.geom.normal[1], r.geom.normal[2]};
    if (K.b1 < 0) {  // as ODE's reversed contact joint: body first, normal flipped
        std::swap(K.b1, K.b2);
        for (double& x : n) x = -x;
    }
    const dSurfaceParameters& s = world_->surface(world_->material_of(r.lo), world_->material_of(r.hi));
    const SolverSpec& sv = scene_.solver;
    const double fps = 1.0 / scene_.dt;
    const dReal* x1 = dBodyGetPosition(world_->body(static_cast<std::size_t>(K.b1)));
    double c1[3], c2[3] = {0, 0, 0};
    for (int i = 0; i < 3; ++i) c1[i] = r.geom.pos[i] - x1[i];
    if (K.b2 >= 0) {
        const dReal* x2 = dBodyGetPosition(world_->body(static_cast<std::size_t>(K.b2)));
        for (int i = 0; i < 3; ++i) c2[i] = r.geom.pos[i] - x2[i];
    }
    K.mu = s.mu;
    K.rows = s.mu > 0 ? 3 : 1;
    double c[3] = {0, 0, 0}, cfm[3] = {sv.cfm, sv.cfm, sv.cfm};
    jacobian_row(n, c1, c2, K.J[0]);
    const double erp = (s.mode & dContactSoftERP) ? s.soft_erp : sv.erp;
    const double depth = std::max(r.geom.depth - sv.contact_surface_layer, 0.0);
    c[0] = std::min(fps * erp * depth, sv.contact_max_correcting_vel);
    if ((s.mode & dContactBounce) && s.bounce_vel >= 0) {
        dBodyID b1 = world_->body(static_cast<std::size_t>(K.b1));
        double out = dot3(K.J[0] + 3, dBodyGetAngularVel(b1)) + dot3(n, dBodyGetLinearVel(b1));
        if (K.b2 >= 0) {
            dBodyID b2 = world_->body(static_cast<std::size_t>(K.b2));
            out += dot3(K.J[0] + 9, dBodyGetAngularVel(b2)) - dot3(n, dBodyGetLinearVel(b2));
        }
        if (-out > s.bounce_vel) c[0] = std::max(c[0], s.bounce * -out);
    }
    if (s.mode & dContactSoftCFM) cfm[0] = s.soft_cfm;
    if (K.rows == 3) {
        dVector3 nn = {n[0], n[1], n[2], 0}, t1, t2;
        dPlaneSpace(nn, t1, t2);
        jacobian_row(t1, c1, c2, K.J[1]);
        jacobian_row(t2, c1, c2, K.J[2]);
        if (s.mode & dContactSlip1) cfm[1] = s.slip1;
        if (s.mode & dContactSlip2) cfm[2] = s.slip2;
    }
    const Body& B1 = bodies_[static_cast<std::size_t>(K.b1)];
    const Body* B2 = K.b2 >= 0 ? &bodies_[static_cast<std::size_t>(K.b2)] : nullptr;
    for (int row = 0; row < K.rows; ++row) {
        double* J = K.J[row];
        double* iMJ = K.iMJ[row];
        for (int i = 0; i < 3; ++i) iMJ[i] = B1.invm * J[i];
        mul33(B1.invI.data(), J + 3, iMJ + 3);
        double rhs = c[row] * fps - dot6(J, B1.tmp.data());
        double sum = dot6(iMJ, J);
        if (B2) {
            for (int i = 0; i < 3; ++i) iMJ[6 + i] = B2->invm * J[6 + i];
            mul33(B2->invI.data(), J + 9, iMJ + 9);
            rhs -= dot6(J + 6, B2->tmp.data());
            sum += dot6(iMJ + 6, J + 6);
        }
        const double cf = cfm[row] * fps;
        const double Ad = sv.sor_w / (sum + cf);
        for (int i = 0; i < 12; ++i) J[i] *= Ad;
        K.rhs[row] = rhs * Ad;
        K.cfm[row] = cf * Ad;
        K.lambda[row] = 0;
    }
    const std::int64_t w = warm_[slot_contact_[slot]];
    if (w >= 0 && scene_.solver.warm_start) {
        for (int row = 0; row < K.rows; ++row) K.lambda[row] = previous_[static_cast<std::size_t>(w)].lambda[row];
    }
}

void ContactSolver::warm_block(std::size_t k) {
    const Block& K = blocks_[k];
    double* f1 = fc_[static_cast<std::size_t>(K.b1)].data();
    double* f2 = K.b2 >= 0 ? fc_[static_cast<std::size_t>(K.b2)].data() : nullptr;
    for (int row = 0; row < K.rows; ++row) {
        const double l = K.lambda[row];
        if (l == 0) continue;
        for (int i = 0; i < 6; ++i) f1[i] += l * K.iMJ[row][i];
        if (f2) {
            for (int i = 0; i < 6; ++i) f2[i] += l * K.iMJ[row][6 + i];
        }
    }
}

void ContactSolver::match_previous(const ContactBuffer& contacts) {
    const auto& items = contacts.items();
    warm_.assign(items.size(), -1);
    std::size_t p = 0;
    for (std::size_t k = 0; k < items.size() && p < previous_.size(); ++k) {
        const ContactRecord& r = items[k];
        auto before = [&r](const WarmImpulse& m) {
            return m.lo != r.lo ? m.lo < r.lo : m.hi != r.hi ? m.hi < r.hi : m.index < r.index;
        };
        while (p < previous_.size() && before(previous_[p])) ++p;
        if (p < previous_.size() && previous_[p].lo == r.lo && previous_[p].hi == r.hi && previous_[p].index == r.index) {
            warm_[k] = static_cast<std::int64_t>(p);
        }
    }
}

void ContactSolver::remember_block(std::size_t s) {
    const ContactRecord& r = contacts_->items()[slot_contact_[s]];
    WarmImpulse& m = previous_[slot_contact_[s]];
    m.lo = r.lo;
    m.hi = r.hi;
    m.index = r.index;
    for (int row = 0; row < 3; ++row) m.lambda[row] = row < blocks_[s].rows ? blocks_[s].lambda[row] : 0.0;
}

void ContactSolver::remember() {
    for (std::size_t s = 0; s < blocks_.size(); ++s) remember_block(s);
}

void ContactSolver::relax(std::size_t k) {
    Block& K = blocks_[k];
    double* f1 = fc_[static_cast<std::size_t>(K.b1)].data();
    double* f2 = K.b2 >= 0 ? fc_[static_cast<std::size_t>(K.b2)].data() : nullptr;
    for (int row = 0; row < K.rows; ++row) {
        const double* J = K.J[row];
        double delta = K.rhs[row] - K.lambda[row] * K.cfm[row] - dot6(J, f1);
        if (f2) delta -= dot6(J + 6, f2);
        double hi = HUGE_VAL, lo = 0;
        if (row > 0) {
            hi = std::fabs(K.mu * K.lambda[0]);
            lo = -hi;
        }
        const double old = K.lambda[row];
        const double nl = std::min(std::max(old + delta, lo), hi);
        delta = nl - old;
        K.lambda[row] = nl;
        const double* iMJ = K.iMJ[row];
        for (int i = 0; i < 6; ++i) f1[i] += delta * iMJ[i];
        if (f2) {
            for (int i = 0; i < 6; ++i) f2[i] += delta * iMJ[6 + i];
        }
    }
}

// The explicit update of ODE's steppers (dxStepBody, no damping, no finite
// rotation): v += h (invM fe + fc); x += h v; q += h/2 (0, w) q, normalised.
void ContactSolver::integrate_body(std::size_t i) {
    if (world_->ghost(i)) return;  // its owner integrates it
    Body& B = bodies_[i];
    dBodyID b = world_->body(i);
    const double h = scene_.dt;
    const dReal* x = dBodyGetPosition(b);
    const dReal* q = dBodyGetQuaternion(b);
    const dReal* v0 = dBodyGetLinearVel(b);
    const dReal* w0 = dBodyGetAngularVel(b);
    double v[6];
    for (int k = 0; k < 3; ++k) {
        v[k] = v0[k] + h * (B.acc[k] + fc_[i][k]);
        v[3 + k] = w0[k] + h * (B.acc[3 + k] + fc_[i][3 + k]);
    }
    const double* w = v + 3;
    double dq[4] = {0.5 * (-w[0] * q[1] - w[1] * q[2] - w[2] * q[3]), 0.5 * (w[0] * q[0] + w[1] * q[3] - w[2] * q[2]),
                    0.5 * (-w[0] * q[3] + w[1] * q[0] + w[2] * q[1]), 0.5 * (w[0] * q[2] - w[1] * q[1] + w[2] * q[0])};
    double nq[4], len = 0;
    for (int k = 0; k < 4; ++k) {
        nq[k] = q[k] + h * dq[k];
        len += nq[k] * nq[k];
    }
    len = 1.0 / std::sqrt(len);
    for (int k = 0; k < 3; ++k) B.next[k] = x[k] + h * v[k];
    for (int k = 0; k < 4; ++k) B.next[3 + k] = nq[k] * len;
    for (int k = 0; k < 6; ++k) B.tmp[k] = v[k];  // tmp is free now: keep the new velocity
}

void ContactSolver::prepare_bodies() {
    for (std::size_t i = 0; i < bodies_.size(); ++i) prepare_body(i);
}

void ContactSolver::build_blocks() {
    for (std::size_t s = 0; s < blocks_.size(); ++s) build_block(s);
}

void ContactSolver::relax_cell(std::size_t t) {
    for (std::size_t k = cell_start_[t]; k < cell_start_[t + 1]; ++k) relax(k);
}

void ContactSolver::warm_cell(std::size_t t) {
    for (std::size_t k = cell_start_[t]; k < cell_start_[t + 1]; ++k) warm_block(k);
}

void ContactSolver::iterate() {
    for (int it = 0; it < iterations(); ++it) {
        for (int c = 0; c < colours(); ++c) {
            for (std::size_t t = colour_begin(c); t < colour_end(c); ++t) relax_cell(t);
            exchange_after(c);
        }
    }
}

void ContactSolver::warm_start() {
    for (int c = 0; c < colours(); ++c) {
        for (std::size_t t = colour_begin(c); t < colour_end(c); ++t) warm_cell(t);
        exchange_after(c);
    }
}

// The bodies each colour's cells touch, each once per colour (a body is
// touched by at most one cell of a colour).
void ContactSolver::plan_exchange() {
    touched_.resize(static_cast<std::size_t>(colours()));
    stamp_.assign(bodies_.size(), 0);
    for (int c = 0; c < colours(); ++c) {
        auto& list = touched_[static_cast<std::size_t>(c)];
        list.clear();
        const auto mark = static_cast<std::uint32_t>(c + 1);
        auto add = [&](std::int32_t b) {
            if (b < 0 || stamp_[static_cast<std::size_t>(b)] == mark) return;
            stamp_[static_cast<std::size_t>(b)] = mark;
            list.push_back(static_cast<std::uint32_t>(b));
        };
        for (std::size_t k = cell_start_[colour_begin(c)]; k < cell_start_[colour_end(c)]; ++k) {
            add(blocks_[k].b1);
            add(blocks_[k].b2);
        }
    }
    exchange_->plan(touched_);
}

void ContactSolver::integrate() {
    for (std::size_t i = 0; i < bodies_.size(); ++i) integrate_body(i);
}

void ContactSolver::commit(World& world) const {
    for (std::size_t i = 0; i < bodies_.size(); ++i) {  // serial: the setters move geoms in the space
        if (world.ghost(i)) continue;
        const Body& B = bodies_[i];
        dBodyID b = world.body(i);
        dBodySetLinearVel(b, B.tmp[0], B.tmp[1], B.tmp[2]);
        dBodySetAngularVel(b, B.tmp[3], B.tmp[4], B.tmp[5]);
        world.set_pose(i, B.next.data(), B.next.data() + 3);
        dBodySetForce(b, 0, 0, 0);
        dBodySetTorque(b, 0, 0, 0);
    }
}

void ContactSolver::step(World& world, const ContactBuffer& contacts) {
    world_ = &world;
    contacts_ = &contacts;
    const std::size_t nb = world.body_count();
    bodies_.resize(nb);
    fc_.resize(nb);
    colour(contacts);
    match_previous(contacts);
    blocks_.resize(contacts.size());
    prepare_bodies();
    build_blocks();
    if (exchange_) plan_exchange();
    if (scene_.solver.warm_start) warm_start();
    iterate();
    previous_.resize(contacts.size());
    remember();
    integrate();
    commit(world);
}

}  // namespace parode
