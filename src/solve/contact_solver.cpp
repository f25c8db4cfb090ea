// Project contact solver, serial reference (see contact_solver.hpp).
#include "solve/contact_solver.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "exec/execution.hpp"
#include "util/scratch.hpp"

namespace parode {
namespace {

constexpr std::uint32_t kNone = 0xFFFFFFFFu;
constexpr std::size_t kGrain = 2048;
// Items ahead (contacts, rows or bodies) at which a pass that walks one array
// in order prefetches what it reaches out of order in another.
constexpr std::size_t kPrefetchAhead = 8;

using detail::cross3;
using detail::mul33;

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

bool isotropic(const dMass& m) {
    return m.I[1] == 0 && m.I[2] == 0 && m.I[4] == 0 && m.I[6] == 0 && m.I[8] == 0 && m.I[9] == 0 &&
           m.I[0] == m.I[5] && m.I[0] == m.I[10];
}

// One CFM for all three rows: what a sphere row can hold.
bool uniform_cfm(const dSurfaceParameters& s, double cfm) {
    return (!(s.mode & dContactSoftCFM) || s.soft_cfm == cfm) && (!(s.mode & dContactSlip1) || s.slip1 == cfm) &&
           (!(s.mode & dContactSlip2) || s.slip2 == cfm);
}

bool sphere_or_plane(World::GeomShape s) { return s == World::GeomShape::Sphere || s == World::GeomShape::Plane; }

}  // namespace

// A body's contacts are owned by cells within 2 r_max of it: with cells of
// 4 r_max they span at most two cells per axis, of different parity.
ContactSolver::ContactSolver(const Scene& scene, Execution& exec, bool adaptive)
    : scene_(scene),
      exec_(exec),
      cells_(scene),
      substeps_(scene.solver.substeps),
      h_(scene.dt / scene.solver.substeps),
      adaptive_(adaptive) {}

void ContactSolver::prepare_body(std::size_t i) {
    dBodyID b = world_->body(i);
    BodyData& B = bodies_[i];
    const dMass& m = world_->mass_of(world_->gid(i));  // not ODE's copy: a cache miss a body
    const dReal* f = dBodyGetForce(b);
    const dReal* t = dBodyGetTorque(b);
    const dReal* v = dBodyGetLinearVel(b);
    const dReal* w = dBodyGetAngularVel(b);
    const dReal* x = dBodyGetPosition(b);
    const bool gravity = dBodyGetGravityMode(b) != 0;
    B.invm = 1.0 / m.mass;
    double te[3] = {t[0], t[1], t[2]}, a[3];
    if (isotropic(m)) {  // every sphere (World gives it a sphere's mass); w x (I w) vanishes
        B.invi = 1.0 / m.I[0];
        for (int k = 0; k < 3; ++k) a[k] = B.invi * te[k];
    } else {
        if (invI_.size() <= i) throw std::logic_error("contact solver: anisotropic inertia on a sphere body");
        B.invi = 0;
        const dReal* R = dBodyGetRotation(b);
        const double I[9] = {m.I[0], m.I[1], m.I[2], m.I[4], m.I[5], m.I[6], m.I[8], m.I[9], m.I[10]};
        double invIb[9], Iw[9];
        invert33(I, invIb);
        rotate_tensor(R, I, Iw);
        rotate_tensor(R, invIb, invI_[i].data());
        if (dBodyGetGyroscopicMode(b)) {
            double L[3], gyro[3];
            mul33(Iw, w, L);
            cross3(w, L, gyro);
            for (int k = 0; k < 3; ++k) te[k] -= gyro[k];
        }
        mul33(invI_[i].data(), te, a);
    }
    for (int k = 0; k < 3; ++k) {
        B.x[k] = x[k];
        B.v[k] = v[k];
        B.v[3 + k] = w[k];
        B.acc[k] = B.invm * (f[k] + (gravity ? m.mass * scene_.gravity[k] : 0.0));
        B.acc[3 + k] = a[k];
    }
    cell_[i] = cells_.key(B.x);
}

// Both geoms spheres, or a sphere and a plane, between bodies of isotropic
// inertia and with one CFM for all rows: a SphereRow holds the contact exactly.
bool ContactSolver::sphere_pair(const ContactRecord& r, std::size_t k) const {
    if (general_only_) return false;
    const World::GeomShape a = world_->geom_shape(r.lo), b = world_->geom_shape(r.hi);
    if (!sphere_or_plane(a) || !sphere_or_plane(b) || (a == World::GeomShape::Plane && b == World::GeomShape::Plane)) {
        return false;
    }
    if (bodies_[owner_[k]].invi == 0 || (other_[k] != kNone && bodies_[other_[k]].invi == 0)) return false;
    return uniform_cfm(world_->surface(world_->material_of(r.lo), world_->material_of(r.hi)), scene_.solver.cfm);
}

void ContactSolver::classify(std::size_t k) {
    const ContactRecord& r = contacts_->items()[k];
    owner_[k] = world_->local_of(r.lo);  // lo is a body: static geoms' ids follow all bodies'
    other_[k] = world_->is_body_id(r.hi) ? world_->local_of(r.hi) : kNone;
    block_of_[k] = all_rows_ || sphere_pair(r, k) ? kNone : 0;
}

// Every contact a sphere row: all bodies spheres (isotropic: World gives them
// a sphere's mass), all static geoms planes, one CFM per material pair.
bool ContactSolver::only_sphere_rows() const {
    if (general_only_ || !all_spheres_ || !world_->scene().statics.empty()) return false;
    const std::size_t m = world_->scene().materials.size();
    for (std::size_t a = 0; a < m; ++a) {
        for (std::size_t b = 0; b < m; ++b) {
            if (!uniform_cfm(world_->surface(static_cast<int>(a), static_cast<int>(b)), scene_.solver.cfm)) return false;
        }
    }
    return true;
}

void ContactSolver::fill_body_rows() {
    const auto& order = layout_.order();
    hot_.resize(order.size());
    for_ranges(loops(), order.size(), kGrain, [&](std::size_t s0, std::size_t s1) {
        for (std::size_t s = s0; s < s1; ++s) {
            BodyRow& H = hot_[s];
            const BodyData& B = bodies_[order[s]];
            if (substeps_ > 1) start_motion(s, B, H);
            else std::fill(H.fc, H.fc + 6, 0.0);
            H.invm = B.invm;
            H.invi = B.invi;
        }
    });
}

// Each contact's owner, partner and row kind (classify), and its index into
// last step's impulses (both in canonical order), chunk by chunk in one pass
// over the contacts (their keys are read once a step, not twice): the
// impulses from a binary search for the chunk's first contact on.
void ContactSolver::classify_and_match() {
    const auto& items = contacts_->items();
    const std::size_t nc = items.size();
    scratch_resize(owner_, nc);
    scratch_resize(other_, nc);
    scratch_resize(block_of_, nc);
    scratch_assign(warm_, nc, kNone);
    const bool match = scene_.solver.warm_start && !previous_.empty();
    for_ranges(loops(), nc, kGrain, [&](std::size_t k0, std::size_t k1) {
        if (k0 == k1) return;
        WarmImpulse key;  // contact k's canonical key
        key.lo = items[k0].lo;
        key.hi = items[k0].hi;
        key.index = contact_index(items.data(), k0);
        std::size_t p = match ? static_cast<std::size_t>(std::lower_bound(previous_.begin(), previous_.end(), key, warm_less) -
                                                         previous_.begin())
                              : previous_.size();
        for (std::size_t k = k0; k < k1; ++k) {
            classify(k);
            const ContactRecord& r = items[k];
            if (k > k0) key.index = next_index(items.data(), k, key.index);
            key.lo = r.lo;
            key.hi = r.hi;
            while (p < previous_.size() && warm_less(previous_[p], key)) ++p;
            if (p < previous_.size() && previous_[p].lo == r.lo && previous_[p].hi == r.hi && previous_[p].index == key.index) {
                warm_[k] = static_cast<std::uint32_t>(p);
            }
        }
    });
}

ContactFrame ContactSolver::frame(const ContactRecord& r, std::uint32_t k) const {
    ContactFrame f;
    const BodyData& B1 = bodies_[owner_[k]];
    f.b1 = static_cast<std::int32_t>(layout_.slot()[owner_[k]]);
    f.b2 = other_[k] == kNone ? -1 : static_cast<std::int32_t>(layout_.slot()[other_[k]]);
    f.depth = r.geom.depth;
    for (int i = 0; i < 3; ++i) {
        f.n[i] = r.geom.normal[i];
        f.c1[i] = r.geom.pos[i] - B1.x[i];
        f.c2[i] = other_[k] == kNone ? 0.0 : r.geom.pos[i] - bodies_[other_[k]].x[i];
    }
    return f;
}

const double* ContactSolver::inv_inertia(std::uint32_t local, double* diag) const {
    const BodyData& B = bodies_[local];
    if (B.invi == 0) return invI_[local].data();
    std::fill(diag, diag + 9, 0.0);
    diag[0] = diag[4] = diag[8] = B.invi;
    return diag;
}

// The rows are built in canonical order but stored in the sweeps' cell
// order, so each store would first wait for its row's two lines: they are
// fetched kPrefetchAhead contacts early, for writing (measured at 10^6 catoms on
// one thread: the row loop 15 % faster; fetching the bodies as well was slower).
void ContactSolver::prefetch_row(std::size_t p) const {
    const auto* at = reinterpret_cast<const char*>(&rows_[p]);
    __builtin_prefetch(at, 1);
    __builtin_prefetch(at + 64, 1);
}

// The same bits as build_row's: CFM times 1 / dt.
SphereRowConstants ContactSolver::row_constants() const {
    double erp = 0, cfm = 0;
    substep_softness(scene_.solver.erp, scene_.solver.cfm, substeps_, erp, cfm);
    return SphereRowConstants{scene_.solver.sor_w, cfm * (1.0 / h_)};
}

void ContactSolver::build_row(std::size_t k) {
    const std::size_t p = layout_.position(k);
    const ContactRecord& r = contacts_->items()[k];
    const ContactFrame f = frame(r, k);
    const SolverSpec& sv = scene_.solver;
    const double fps = 1.0 / h_;
    const std::uint32_t locals[2] = {owner_[k], other_[k]};
    double tmp[2][6], diag[2][9];
    RowInputs in;  // not value-initialised: that cleared 136 bytes a contact
    in.tmp[1] = in.vel[1] = in.invI[1] = nullptr;
    in.invm[1] = in.invi[1] = 0;
    for (int j = 0; j < 2 && locals[j] != kNone; ++j) {
        const BodyData& B = bodies_[locals[j]];
        // With substeps the bodies' rows hold the velocity terms (substeps.cpp):
        // the rows' right-hand sides keep only their targets.
        for (int i = 0; i < 6; ++i) tmp[j][i] = substeps_ > 1 ? 0.0 : B.v[i] * fps + B.acc[i];
        in.tmp[j] = tmp[j];
        in.vel[j] = B.v;
        in.invm[j] = B.invm;  // from the body record build_row reads anyway, not the sweeps' row
        in.invi[j] = B.invi;
        in.invI[j] = block_of_[k] == kNone ? nullptr : inv_inertia(locals[j], diag[j]);
    }
    in.surface = &world_->surface(world_->material_of(r.lo), world_->material_of(r.hi));
    in.fps = fps;
    in.erp = sv.erp;
    in.cfm = sv.cfm;
    in.surface_layer = sv.contact_surface_layer;
    in.max_correcting_vel = sv.contact_max_correcting_vel;
    in.sor_w = sv.sor_w;
    in.substeps = substeps_;
    in.kept = substeps_ > 1 ? &kept_[p] : nullptr;
    double* lambda = nullptr;
    SphereRow& K = rows_[p];
    if (block_of_[k] == kNone) {
        build_sphere_row(f, in, K);
        lambda = K.lambda;
    } else {
        Block& G = blocks_[block_of_[k]];
        build_block(f, in, G);
        K.b1 = -1 - static_cast<std::int32_t>(block_of_[k]);
        K.mu = G.mu;
        lambda = G.lambda;
    }
    if (warm_[k] != kNone) {
        const int rows = in.surface->mu > 0 ? 3 : 1;
        for (int row = 0; row < rows; ++row) lambda[row] = previous_[warm_[k]].lambda[row];
    }
}

void ContactSolver::build_phase() {
    const std::size_t nb = world_->body_count(), nc = contacts_->size();
    bodies_.resize(nb);
    cell_.resize(nb);
    if (shapes_of_ != world_->generation()) {
        shapes_of_ = world_->generation();
        all_spheres_ = std::all_of(world_->gids().begin(), world_->gids().end(),
                                   [this](std::uint32_t g) { return world_->geom_shape(g) == World::GeomShape::Sphere; });
    }
    invI_.resize(all_spheres_ ? 0 : nb);
    all_rows_ = only_sphere_rows();
    for_ranges(loops(), nb, kGrain, [&](std::size_t i0, std::size_t i1) {
        for (std::size_t i = i0; i < i1; ++i) {
            if (i + kRecordAhead < i1) world_->prefetch_body(i + kRecordAhead);
            prepare_body(i);
        }
    });
    classify_and_match();
    std::uint32_t general = 0;  // general blocks in canonical order (rare: a serial count)
    if (!all_rows_) {           // else classify marked none: skip a serial pass over the contacts
        for (std::uint32_t& b : block_of_) {
            if (b != kNone) b = general++;
        }
    }
    blocks_.resize(general);
    LayoutInput li;
    li.bodies = nb;
    li.cell = cell_.data();
    li.gid = world_->gids().data();
    li.contacts = nc;
    li.owner = owner_.data();
    if (exchange_) {  // boundary cells first in each colour (sweep_layout.hpp)
        shared_.resize(nb);
        for_ranges(loops(), nb, kGrain, [&](std::size_t i0, std::size_t i1) {
            for (std::size_t i = i0; i < i1; ++i) shared_[i] = exchange_->shared(static_cast<std::uint32_t>(i)) ? 1 : 0;
        });
        li.other = other_.data();
        li.shared = shared_.data();
    }
    layout_.build(li, loops());
    if (substeps_ > 1) {
        motion_.resize(layout_.order().size());
        reach_.resize(layout_.order().size());
        kept_.resize(nc);
    }
    fill_body_rows();
    rows_.resize(nc);
    for_ranges(loops(), nc, kGrain, [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k) {
            if (k + kPrefetchAhead < k1) prefetch_row(layout_.position(k + kPrefetchAhead));
            build_row(k);
        }
    });
    if (exchange_) plan_exchange();
}

// Cells [t0, t1) of one colour as `streams` runs of whole cells with about
// equal numbers of contacts: eight where relax_eight has AVX-512, else four.
// Each round takes the next contact of every stream and relaxes them
// together, one per SIMD lane (contacts of different cells of a colour share
// no body, so this is exactly relaxing the cells one after the other, and
// each body still sees its contacts in canonical order); the packs are
// independent, so the processor also overlaps one with the next. While every
// stream has contacts left and all are sphere rows, rounds run without
// per-stream checks (relax_rounds); the last rounds as streams run dry, or
// with general blocks, one by one (relax_round).
void ContactSolver::relax_cells(std::size_t t0, std::size_t t1) {
    const int streams = eight_lanes() ? 8 : 4;
    std::size_t at[kMostStreams], end[kMostStreams];
    const std::size_t p0 = layout_.cell_begin(t0), p1 = layout_.cell_begin(t1);
    std::size_t t = t0;
    for (int s = 0; s < streams; ++s) {
        at[s] = layout_.cell_begin(t);
        const std::size_t target = p0 + (p1 - p0) * static_cast<std::size_t>(s + 1) / static_cast<std::size_t>(streams);
        while (t < t1 && layout_.cell_begin(t + 1) <= target) ++t;
        if (s == streams - 1) t = t1;
        end[s] = layout_.cell_begin(t);
    }
    for (;;) {
        std::size_t rounds = ~std::size_t{0};
        int live = 0;
        for (int s = 0; s < streams; ++s) {
            if (at[s] == end[s]) continue;
            ++live;
            rounds = std::min(rounds, end[s] - at[s]);
        }
        if (live == 0) return;
        if (live < streams || !all_rows_) {
            relax_round(at, end, streams);
            continue;
        }
        relax_rounds(at, streams, rounds);
        for (int s = 0; s < streams; ++s) at[s] += rounds;
    }
}

// `rounds` rounds of full packs of sphere rows, streams [at[s], at[s] + rounds).
void ContactSolver::relax_rounds(const std::size_t* at, int streams, std::size_t rounds) {
    BodyRow* hot = hot_.data();
    SphereRow* rows = rows_.data();
    const std::size_t n = rows_.size();
    const SphereRowConstants rc = row_constants();
    SphereRow* pack[kMostStreams];
    for (std::size_t r = 0; r < rounds; ++r) {
        for (int s = 0; s < streams; ++s) {
            prefetch_ahead(rows, n, hot, at[s] + r);
            pack[s] = &rows[at[s] + r];
        }
        if (streams == 8) relax_eight(pack, hot, rc);
        else relax_four(pack, hot, rc);
    }
}

// One round: the next contact of every stream that has one.
void ContactSolver::relax_round(std::size_t* at, const std::size_t* end, int streams) {
    BodyRow* hot = hot_.data();
    SphereRow* pack[kMostStreams];
    int held = 0;
    for (int s = 0; s < streams; ++s) {
        if (at[s] == end[s]) continue;
        const std::size_t p = at[s]++;
        prefetch_ahead(rows_.data(), rows_.size(), hot, p);
        SphereRow& K = rows_[p];
        if (K.b1 < 0) {
            relax(blocks_[static_cast<std::size_t>(-1 - K.b1)], hot);
            continue;
        }
        pack[held++] = &K;
    }
    relax_pack(pack, held, nullptr);
}

// `held` sphere rows of different cells of one colour: eight lanes, four,
// two, one at a time (the same bits whichever); each one's change into
// change[0, held) unless null.
void ContactSolver::relax_pack(SphereRow* const* pack, int held, double* change) {
    BodyRow* hot = hot_.data();
    const SphereRowConstants rc = row_constants();
    int done = 0;
    const auto at = [&]() { return change ? change + done : nullptr; };
    if (held - done == 8) relax_eight(pack + done, hot, rc, at()), done += 8;
    if (held - done >= 4) relax_four(pack + done, hot, rc, at()), done += 4;
    if (held - done >= 2) relax_lanes<detail::Pair, 2>(pack + done, hot, rc, at()), done += 2;
    if (held - done == 1) relax_lanes<double, 1>(pack + done, hot, rc, at());
}

namespace {
// The body rows a contact row acts on (a general block's: none fetched).
void prefetch_bodies(const SphereRow& K, const BodyRow* hot) {
    if (K.b1 < 0) return;
    __builtin_prefetch(&hot[K.b1], 1);
    if (K.b2 >= 0) __builtin_prefetch(&hot[K.b2], 1);
}
}  // namespace

void ContactSolver::warm_cells(std::size_t t0, std::size_t t1) {
    BodyRow* hot = hot_.data();
    const std::size_t end = layout_.cell_begin(t1);
    for (std::size_t p = layout_.cell_begin(t0); p < end; ++p) {
        if (p + kPrefetchAhead < end) prefetch_bodies(rows_[p + kPrefetchAhead], hot);
        const SphereRow& K = rows_[p];
        if (K.b1 >= 0) apply_impulses(K, hot);
        else apply_impulses(blocks_[static_cast<std::size_t>(-1 - K.b1)], hot);
    }
}

void ContactSolver::colour_alone(int c, bool warm) {
    const auto cells = [&](std::size_t t0, std::size_t t1) {
        if (warm) warm_cells(t0, t1);
        else relax_cells(t0, t1);
    };
    const double t0 = now_seconds();
    if (!exchange_) {
        cells(layout_.colour_begin(c), layout_.colour_end(c));
        colour_times_.compute[static_cast<std::size_t>(c)] += now_seconds() - t0;
        return;
    }
    cells(layout_.colour_begin(c), layout_.boundary_end(c));
    post_after_boundary(c);
    cells(layout_.boundary_end(c), layout_.colour_end(c));
    const double t1 = now_seconds();
    complete_after_interior(c);
    colour_times_.compute[static_cast<std::size_t>(c)] += t1 - t0;
    colour_times_.wait[static_cast<std::size_t>(c)] += now_seconds() - t1;
}

void ContactSolver::sweep(int passes, bool warm) {
    for (int it = 0; it < passes; ++it) {
        for (int c = 0; c < kColours; ++c) colour_alone(c, warm);
    }
}

// The bodies each colour's boundary cells touch, each once per colour (a
// body is touched by at most one cell of a colour); interior cells touch no
// body another process holds, so they are not listed.
void ContactSolver::plan_exchange() {
    static_assert(kColours < 256, "a colour's mark is a byte");
    touched_.resize(kColours);
    stamp_.assign(hot_.size(), 0);
    const auto& order = layout_.order();
    for (int c = 0; c < kColours; ++c) {
        auto& list = touched_[static_cast<std::size_t>(c)];
        list.clear();
        const auto mark = static_cast<std::uint8_t>(c + 1);  // kColours + 1 fits a byte
        auto add = [&](std::int32_t s) {
            if (s < 0 || stamp_[static_cast<std::size_t>(s)] == mark) return;
            stamp_[static_cast<std::size_t>(s)] = mark;
            list.push_back(order[static_cast<std::size_t>(s)]);
        };
        for (std::size_t p = layout_.cell_begin(layout_.colour_begin(c)); p < layout_.cell_begin(layout_.boundary_end(c)); ++p) {
            const SphereRow& K = rows_[p];
            if (K.b1 >= 0) {
                add(K.b1);
                add(K.b2);
            } else {
                const Block& G = blocks_[static_cast<std::size_t>(-1 - K.b1)];
                add(G.b1);
                add(G.b2);
            }
        }
    }
    exchange_->plan(touched_);
}

void ContactSolver::remember(std::size_t k) {
    const ContactRecord& r = contacts_->items()[k];
    const SphereRow& K = rows_[layout_.position(k)];
    const double* lambda = K.b1 >= 0 ? K.lambda : blocks_[static_cast<std::size_t>(-1 - K.b1)].lambda;
    const int rows = K.mu > 0 ? 3 : 1;
    WarmImpulse& m = previous_[k];
    m.lo = r.lo;
    m.hi = r.hi;
    m.index = contact_index(contacts_->items().data(), k);
    for (int row = 0; row < 3; ++row) m.lambda[row] = row < rows ? lambda[row] : 0.0;
}

// The explicit update of ODE's steppers (dxStepBody, no damping, no finite
// rotation): v += h (invM fe + fc); x += h v; q += h/2 (0, w) q, normalised.
// Velocities, forces, torques and the pose go straight to ODE (each touches
// its own body only); commit then tells the space, in body order.
// Returns whether the new state is finite.
bool ContactSolver::integrate_body(World& world, std::size_t i, double& max_speed) {
    if (world_->ghost(i)) return true;  // its owner integrates it
    BodyData& B = bodies_[i];
    dBodyID b = world_->body(i);
    const double h = h_;
    const double* fc = hot_[layout_.slot()[i]].fc;
    const Motion* m = substeps_ > 1 ? &motion_[layout_.slot()[i]] : nullptr;
    const dReal* q = dBodyGetQuaternion(b);
    double v[6];  // with substeps the row holds v / h (the velocity form, substeps.cpp)
    for (int k = 0; k < 6; ++k) v[k] = m ? h * fc[k] : B.v[k] + h * (B.acc[k] + fc[k]);
    // The turn: h w, or with substeps the sum of every substep's h w (the
    // mean angular velocity over the step), applied once.
    double turn[3];
    const double* w = v + 3;
    double scale = h;
    if (m) {
        for (int k = 0; k < 3; ++k) turn[k] = m->turn[k] + h * w[k];
        w = turn;
        scale = 1.0;
    }
    double dq[4] = {0.5 * (-w[0] * q[1] - w[1] * q[2] - w[2] * q[3]), 0.5 * (w[0] * q[0] + w[1] * q[3] - w[2] * q[2]),
                    0.5 * (-w[0] * q[3] + w[1] * q[0] + w[2] * q[1]), 0.5 * (w[0] * q[2] - w[1] * q[1] + w[2] * q[0])};
    double nq[4], len = 0;
    for (int k = 0; k < 4; ++k) {
        nq[k] = q[k] + scale * dq[k];
        len += nq[k] * nq[k];
    }
    len = 1.0 / std::sqrt(len);
    if (substeps_ > 1) {
        const double* dx = reach_[layout_.slot()[i]].dx;
        for (int k = 0; k < 3; ++k) B.x[k] += dx[k] + h * v[k];
    } else {
        for (int k = 0; k < 3; ++k) B.x[k] += h * v[k];
    }
    for (int k = 0; k < 4; ++k) B.acc[k] = nq[k] * len;
    for (int k = 0; k < 6; ++k) B.v[k] = v[k];
    // The guard's speed (run/guard.cpp), on the same doubles ODE will hold.
    max_speed = std::max(max_speed, std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]));
    dBodySetLinearVel(b, v[0], v[1], v[2]);
    dBodySetAngularVel(b, v[3], v[4], v[5]);
    dBodySetForce(b, 0, 0, 0);
    dBodySetTorque(b, 0, 0, 0);
    world.write_pose(i, B.x, B.acc);
    double sum = 0;  // finite iff the sum of every component times zero is zero
    for (int k = 0; k < 3; ++k) sum += B.x[k] * 0.0;
    for (int k = 0; k < 4; ++k) sum += B.acc[k] * 0.0;
    for (int k = 0; k < 6; ++k) sum += v[k] * 0.0;
    return sum == 0;
}

void ContactSolver::commit(World& world) const {
    world.poses_written();  // serial unless deferred: moves geoms in the space's list
}

void ContactSolver::step(World& world, const ContactBuffer& contacts) {
    world_ = &world;
    contacts_ = &contacts;
    {
        SubstageTimer t(times_, "build");
        build_phase();
    }
    {
        SubstageTimer t(times_, "warm_start");
        if (scene_.solver.warm_start) sweep(1, true);
    }
    iterate();
    for (int s = 1; s < substeps_; ++s) {
        {
            SubstageTimer t(times_, "integrate");
            advance_bodies();
            refresh_rows();
        }
        iterate();
    }
    integrate_phase(world);
}

void ContactSolver::integrate_phase(World& world) {
    SubstageTimer t(times_, "integrate");
    const std::size_t nc = contacts_->size();
    scratch_resize(previous_, nc);  // last step's impulses were read by build_row
    for_ranges(loops(), nc, kGrain, [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k) {
            if (k + kPrefetchAhead < k1) __builtin_prefetch(&rows_[layout_.position(k + kPrefetchAhead)].lambda);
            remember(k);
        }
    });
    const std::size_t nb = bodies_.size(), chunks = chunk_count(loops(), nb, kGrain);
    std::vector<unsigned char> finite(chunks, 1);
    std::vector<double> fastest(chunks, 0.0);
    loops().run(chunks, nb, [&](std::size_t c) {
        bool ok = true;
        double top = 0;  // stored once: neighbouring chunks' entries share a cache line
        const std::size_t end = chunk_begin(nb, chunks, c + 1);
        for (std::size_t i = chunk_begin(nb, chunks, c); i < end; ++i) {
            if (i + kPrefetchAhead < end) __builtin_prefetch(&hot_[layout_.slot()[i + kPrefetchAhead]]);
            if (i + kRecordAhead < end) world.prefetch_body(i + kRecordAhead);
            ok &= integrate_body(world, i, top);
        }
        finite[c] = ok;
        fastest[c] = top;
    });
    finite_ = std::all_of(finite.begin(), finite.end(), [](unsigned char f) { return f != 0; });
    max_speed_ = finite_ ? *std::max_element(fastest.begin(), fastest.end()) : -1.0;
    commit(world);
}

}  // namespace parode
