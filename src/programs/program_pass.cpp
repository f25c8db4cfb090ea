// The catom programs' pass: handlers and the step's end (see
// program_pass.hpp; neighbours are in program_neighbours.cpp, the exchanges
// between processes and checkpoints in program_state.cpp).
#include "programs/program_pass.hpp"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <stdexcept>
#include <exception>
#include <functional>
#include <numeric>

#include "programs/catom_state.hpp"
#include "util/errors.hpp"
#include "util/hash.hpp"
#include "util/id_map.hpp"
#include "util/substages.hpp"

namespace parode {

namespace {

const char* kEventNames[] = {"start", "neighbour lost", "neighbour gained", "message", "timer"};

// The neighbours of one catom as the pass keeps them: gids (or, when
// `begin` is null, a function listing them on demand into a scratch
// vector), and the world to read positions from.
struct NeighbourRange {
    const std::uint32_t *begin, *end;
    const World& world;
    std::function<void(std::vector<std::uint32_t>&)> list = nullptr;
    std::vector<std::uint32_t>* listed = nullptr;
};

// One catom's view during its handlers: pose and velocity read from ODE;
// its neighbours with their directions worked out at the first handler that
// asks (into the caller's scratch), since most handlers never do.
class Context final : public CatomContext {
public:
    Context(ProgramPass::Catom& c, std::uint32_t id, dBodyID body, long step, double time, const Scene& s,
            const NeighbourRange& range, std::vector<Neighbour>& scratch)
        : c_(c), id_(id), body_(body), step_(step), time_(time), scene_(s.program), poles_(s.magnets.directions),
          range_(range), nbrs_(scratch) {}
    std::uint32_t id() const override { return id_; }
    long step() const override { return step_; }
    double time() const override { return time_; }
    Vec3 position() const override {
        const dReal* p = dBodyGetPosition(body_);
        return {p[0], p[1], p[2]};
    }
    Vec3 velocity() const override {
        const dReal* v = dBodyGetLinearVel(body_);
        return {v[0], v[1], v[2]};
    }
    std::array<double, 4> orientation() const override {
        const dReal* q = dBodyGetQuaternion(body_);
        return {q[0], q[1], q[2], q[3]};
    }
    const std::vector<Neighbour>& neighbours() const override {
        if (!built_) build();
        return nbrs_;
    }
    bool is_neighbour(std::uint32_t id) const override { return find(id) != nullptr; }
    void send(std::uint32_t to, const std::array<std::int64_t, 4>& data) override {
        if (!is_neighbour(to)) throw ProgramError("a message to catom " + std::to_string(to) + ", not a neighbour");
        if (static_cast<int>(c_.outbox.size()) >= scene_.max_messages) {
            throw ProgramError("more than program.max_messages = " + std::to_string(scene_.max_messages) +
                               " messages in one step");
        }
        CatomMessage m;
        m.from = id_;
        m.data = data;
        c_.outbox.emplace_back(to, m);
    }
    void set_magnets(bool on) override { c_.magnets = on; }
    bool magnets() const override { return c_.magnets; }
    void set_value(int k, double v) override { c_.values.at(static_cast<std::size_t>(k)) = v; }
    double value(int k) const override { return c_.values.at(static_cast<std::size_t>(k)); }
    void set_timer(double seconds) override { c_.timer_at = time_ + seconds; }
    void set_magnets_toward(std::uint32_t id, bool on) override {
        const std::uint8_t bit = static_cast<std::uint8_t>(1u << facing(id));
        c_.poles_off = on ? static_cast<std::uint8_t>(c_.poles_off & ~bit) : static_cast<std::uint8_t>(c_.poles_off | bit);
    }
    bool magnets_toward(std::uint32_t id) const override { return c_.magnets && !(c_.poles_off >> facing(id) & 1u); }
    double param(const std::string& name, double fallback) const override {
        for (const auto& p : scene_.params) {
            if (p.first == name) return p.second;
        }
        return fallback;
    }

private:
    void build() const {
        const dReal* p = dBodyGetPosition(body_);
        nbrs_.clear();
        const std::uint32_t *j0 = range_.begin, *j1 = range_.end;
        if (!j0) {
            range_.listed->clear();
            range_.list(*range_.listed);
            j0 = range_.listed->data(), j1 = j0 + range_.listed->size();
        }
        for (const std::uint32_t* j = j0; j != j1; ++j) {
            const dReal* q = dBodyGetPosition(range_.world.body(range_.world.local_of(*j)));
            const Vec3 d{q[0] - p[0], q[1] - p[1], q[2] - p[2]};
            const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            nbrs_.push_back({*j, {d[0] / len, d[1] / len, d[2] / len}, len});
        }
        built_ = true;
    }
    const Neighbour* find(std::uint32_t id) const {
        neighbours();
        const auto it = std::lower_bound(nbrs_.begin(), nbrs_.end(), id, [](const Neighbour& a, std::uint32_t b) { return a.id < b; });
        return it != nbrs_.end() && it->id == id ? &*it : nullptr;
    }
    // The pole whose body-frame direction is closest to the neighbour's
    // direction turned into the body frame (the lowest such pole on a tie).
    int facing(std::uint32_t id) const {
        const Neighbour* n = find(id);
        if (!n) throw ProgramError("magnets toward catom " + std::to_string(id) + ", not a neighbour");
        const dReal* R = dBodyGetRotation(body_);  // body to world, 3x4 row-major: the body frame is R^T d
        const Vec3& d = n->direction;
        const Vec3 b{R[0] * d[0] + R[4] * d[1] + R[8] * d[2], R[1] * d[0] + R[5] * d[1] + R[9] * d[2],
                     R[2] * d[0] + R[6] * d[1] + R[10] * d[2]};
        int best = -1;
        double most = -2;
        for (std::size_t p = 0; p < poles_.size(); ++p) {
            const double dot = poles_[p][0] * b[0] + poles_[p][1] * b[1] + poles_[p][2] * b[2];
            if (dot > most) most = dot, best = static_cast<int>(p);
        }
        if (best < 0) throw ProgramError("magnets toward catom " + std::to_string(id) + ": the scene has no magnet poles");
        if (best >= 8) throw ProgramError("magnets toward catom " + std::to_string(id) + ": pole " + std::to_string(best) +
                                          " faces it, and only the first 8 poles switch one by one");
        return best;
    }

    ProgramPass::Catom& c_;
    std::uint32_t id_;
    dBodyID body_;
    long step_;
    double time_;
    const ProgramScene& scene_;
    const std::vector<Vec3>& poles_;
    const NeighbourRange& range_;
    std::vector<Neighbour>& nbrs_;
    mutable bool built_ = false;
};

// The handlers of one catom's step, in the fixed order; the first exception
// is recorded with its event (and message) and ends the catom's step.
void run_catom(ProgramPass::Catom& c, Context& ctx, const std::vector<std::uint32_t>& lost,
               const std::vector<std::uint32_t>& gained, double time) {
    int event = 0;
    const CatomMessage* current = nullptr;
    try {
        if (!c.started) {
            c.started = true;
            ++c.events;
            c.program->on_start(ctx);
        }
        event = 1;
        for (std::uint32_t id : lost) ++c.events, c.program->on_neighbour_lost(ctx, id);
        event = 2;
        for (std::uint32_t id : gained) ++c.events, c.program->on_neighbour_gained(ctx, id);
        event = 3;
        for (const CatomMessage& m : c.inbox) {
            current = &m;
            ++c.events;
            c.program->on_message(ctx, m);
        }
        current = nullptr;
        event = 4;
        if (c.timer_at >= 0 && time >= c.timer_at - 1e-12) {
            c.timer_at = -1;
            ++c.events;
            c.program->on_timer(ctx);
        }
    } catch (const std::exception& e) {
        c.error = std::string("catom ") + std::to_string(ctx.id()) + ", event " + kEventNames[event] +
                  (current ? " (from catom " + std::to_string(current->from) + ", data [" +
                                 std::to_string(current->data[0]) + ", " + std::to_string(current->data[1]) + ", " +
                                 std::to_string(current->data[2]) + ", " + std::to_string(current->data[3]) + "])"
                           : std::string()) +
                  ": " + e.what();
    }
}

// What one catom adds to the state hash; `bytes` is the caller's scratch.
std::uint64_t catom_digest(std::uint32_t id, const ProgramPass::Catom& c, std::vector<unsigned char>& bytes) {
    Fnv1a h;
    h.add_bytes(&id, sizeof id);
    h.add_bytes(c.values.data(), sizeof(double) * c.values.size());
    const unsigned char flags[2] = {static_cast<unsigned char>(c.magnets), static_cast<unsigned char>(c.started)};
    h.add_bytes(flags, sizeof flags);
    h.add_bytes(&c.timer_at, sizeof c.timer_at);
    if (c.poles_off) h.add_bytes(&c.poles_off, sizeof c.poles_off);  // only when used: older hashes stand
    for (const CatomMessage& m : c.inbox) {
        h.add_bytes(&m.from, sizeof m.from);
        h.add_bytes(m.data.data(), sizeof(std::int64_t) * m.data.size());
    }
    bytes.clear();
    c.program->save(bytes);
    if (!bytes.empty()) h.add_bytes(bytes.data(), bytes.size());
    return h.value();
}

// Ids of the sorted range [a0, a1) not in [b0, b1), into `out`.
void missing(const std::uint32_t* a0, const std::uint32_t* a1, const std::uint32_t* b0, const std::uint32_t* b1,
             std::vector<std::uint32_t>& out) {
    out.clear();
    for (; a0 != a1; ++a0) {
        while (b0 != b1 && *b0 < *a0) ++b0;
        if (b0 == b1 || *b0 != *a0) out.push_back(*a0);
    }
}

// The candidates' skin as a fraction of the neighbour range: 0.2, or
// PARODE_PROGRAM_SKIN (a testing aid: 0 lists them every step a catom moves).
double skin_fraction() {
    const char* env = std::getenv("PARODE_PROGRAM_SKIN");
    if (!env || !*env) return 0.2;
    char* end = nullptr;
    const double f = std::strtod(env, &end);
    if (*end || !(f >= 0 && f <= 1)) {
        throw std::invalid_argument(std::string("PARODE_PROGRAM_SKIN=") + env + ": expected a number from 0 to 1");
    }
    return f;
}

}  // namespace

ProgramPass::Numbering::Numbering(const Scene& scene)
    : first_generated_(scene.bodies.size()), generated_(scene.catoms.count) {
    for (std::size_t g = 0; g < scene.bodies.size(); ++g) {
        if (scene.bodies[g].catom) listed_.push_back(static_cast<std::uint32_t>(g));
    }
}

std::uint32_t ProgramPass::Numbering::gid(std::size_t k) const {
    return static_cast<std::uint32_t>(k < listed_.size() ? listed_[k] : first_generated_ + (k - listed_.size()));
}

std::size_t ProgramPass::Numbering::index(std::uint32_t g) const {
    if (g >= first_generated_) return listed_.size() + (g - first_generated_);
    return static_cast<std::size_t>(std::lower_bound(listed_.begin(), listed_.end(), g) - listed_.begin());
}

// Each of `keys` (ascending) by its place in `in` (ascending), or IdMap::kNone:
// one walk over both.
std::vector<std::uint32_t> ProgramPass::sorted_places(const std::vector<std::uint32_t>& keys,
                                                      const std::vector<std::uint32_t>& in) {
    std::vector<std::uint32_t> out(keys.size(), IdMap::kNone);
    for (std::size_t o = 0, b = 0; o < keys.size(); ++o) {
        while (b < in.size() && in[b] < keys[o]) ++b;
        if (b < in.size() && in[b] == keys[o]) out[o] = static_cast<std::uint32_t>(b);
    }
    return out;
}

std::uint32_t ProgramPass::Csr::place(std::uint32_t g) const {
    const auto it = std::lower_bound(keys.begin(), keys.end(), g);
    return it != keys.end() && *it == g ? static_cast<std::uint32_t>(it - keys.begin()) : IdMap::kNone;
}

ProgramPass::ProgramPass(const Scene& scene, Execution& exec)
    : scene_(scene), exec_(exec), spec_(&load_program(scene.program.name)), numbering_(scene) {
    reach_ = scene.program_reach();
    edge_ = scene.program_range();  // the scene's radii: the cell edge is fixed for the run
    skin_ = skin_fraction() * edge_;
    fresh_record(numbering_.count() ? numbering_.gid(0) : 0);  // a program that makes no object fails here, before the run
}

// A record as catom g starts: a new program object, the scene's magnets.
std::unique_ptr<ProgramPass::Catom> ProgramPass::fresh_record(std::uint32_t g) const {
    auto c = std::make_unique<Catom>();
    c->program = spec_->make();
    if (!c->program) throw ProgramError("program " + spec_->name + " made no program object");
    c->magnets = numbering_.count() == 0 || scene_.body_magnets(g);
    return c;
}

std::vector<std::uint32_t> ProgramPass::catom_ids() const {
    std::vector<std::uint32_t> out(numbering_.count());
    for (std::size_t k = 0; k < out.size(); ++k) out[k] = numbering_.gid(k);
    return out;
}

// Whether this process owns catom g (the world as last located).
bool ProgramPass::owned_here(const World& world, std::uint32_t g) const {
    const std::uint32_t l = world.local_of(g);
    return l != IdMap::kNone && !world.ghost(l);
}

ProgramPass::Catom* ProgramPass::record(std::uint32_t g) const { return records_.find(g); }

// The records' table, sized for about `expected` catoms at its first use.
void ProgramPass::ensure_records(std::size_t expected) {
    if (!records_.ready()) records_.reset(scene_.body_count(), expected);
}

// The owned catoms' records beside them, for the loops over them, and
// their digests: kept for the catoms that stayed owned (matched by a merge),
// to be worked out for the others.
void ProgramPass::bind_owned() {
    const std::size_t n = owned_.size();
    owned_rec_.resize(n);
    for (std::size_t o = 0; o < n; ++o) owned_rec_[o] = record(owned_[o]);
    if (digest_of_ == owned_) return;
    std::vector<std::uint64_t> digest(n, 0);
    std::vector<std::uint8_t> dirty(n, 1);
    const std::vector<std::uint32_t> was = sorted_places(owned_, digest_of_);
    for (std::size_t o = 0; o < n; ++o) {
        if (was[o] != IdMap::kNone) digest[o] = digest_[was[o]], dirty[o] = dirty_[was[o]];
    }
    digest_.swap(digest);
    dirty_.swap(dirty);
    digest_of_ = owned_;
}

// Owned catom g's record changed (its mail).
void ProgramPass::mark_dirty(std::uint32_t g) {
    dirty_[static_cast<std::size_t>(std::lower_bound(owned_.begin(), owned_.end(), g) - owned_.begin())] = 1;
}

ProgramCounts ProgramPass::totals() const {
    ProgramCounts t = counts_;
    std::int64_t v[2] = {static_cast<std::int64_t>(t.messages), static_cast<std::int64_t>(t.events)};
    if (distributed()) coll_->sum(v, 2);
    t.messages = static_cast<std::uint64_t>(v[0]), t.events = static_cast<std::uint64_t>(v[1]);
    return t;
}

void ProgramPass::prepare(const World& world) {
    locate(world);
    hold_records();
    sweep_ = distributed();  // those that move before the first step leave their records here: dropped then
}

// Every owned catom has a record: one that never ran anywhere starts afresh
// here; any other must have come with its state. The records are made on the
// threads (a program's constructor, like its handlers, touches only its own
// object); the first failure is rethrown.
void ProgramPass::hold_records() {
    ensure_records(owned_.size());
    std::vector<std::uint32_t> make;
    for (std::uint32_t g : owned_) {
        if (record(g)) continue;
        if (!unstarted_) {
            throw std::logic_error("catom " + std::to_string(g) + " came to this process without its program state");
        }
        make.push_back(g);
    }
    const std::size_t n = make.size(), chunks = chunk_count(exec_.loops(), n, 1024);
    std::vector<std::exception_ptr> failed(chunks);
    std::vector<std::unique_ptr<Catom>> made(n);
    exec_.loops().run(chunks, n, [&](std::size_t c) {
        try {
            for (std::size_t i = chunk_begin(n, chunks, c); i < chunk_begin(n, chunks, c + 1); ++i) {
                made[i] = fresh_record(make[i]);
            }
        } catch (...) {
            failed[c] = std::current_exception();
        }
    });
    for (const std::exception_ptr& e : failed) {
        if (e) std::rethrow_exception(e);
    }
    for (std::size_t i = 0; i < n; ++i) records_.at(make[i]) = std::move(made[i]);
    bind_owned();
}

ProgramPass::~ProgramPass() = default;

// Only catoms with something to handle run (not started yet, a neighbour
// lost or gained, mail, a timer due): the others' records stay as they are.
// `which`: places in owned_, ascending.
void ProgramPass::run_handlers(const World& world, const std::vector<std::uint32_t>& which, double time) {
    const bool diff = spec_->neighbour_events;
    const std::size_t n = which.size(), chunks = chunk_count(exec_.loops(), n, 256);
    std::vector<std::vector<std::uint32_t>> ran(chunks);
    exec_.loops().run(chunks, n, [&](std::size_t ch) {
        std::vector<std::uint32_t> lost, gained;
        std::vector<Neighbour> scratch;
        std::vector<std::uint32_t> listed;
        for (std::size_t o = chunk_begin(n, chunks, ch); o < chunk_begin(n, chunks, ch + 1); ++o) {
            const std::uint32_t at = which[o], g = owned_[at], local = owned_local_[at];
            Catom& c = *owned_rec_[at];
            NeighbourRange range{nullptr, nullptr, world};
            if (diff) {
                range.begin = now_.ids.data() + now_.at[at], range.end = now_.ids.data() + now_.at[at + 1];
                neighbour_changes(at, lost, gained);
            } else {  // worked out only if a handler asks
                range.list = [this, &world, g, local](std::vector<std::uint32_t>& out) { neighbours_of(world, g, local, out); };
                range.listed = &listed;
            }
            if (!c.outbox.empty()) c.outbox.clear();
            const bool due = c.timer_at >= 0 && time >= c.timer_at - 1e-12;
            if (c.started && lost.empty() && gained.empty() && c.inbox.empty() && !due) continue;
            c.error.clear();
            Context ctx(c, g, world.body(local), step_, time, scene_, range, scratch);
            run_catom(c, ctx, lost, gained, time);
            dirty_[at] = 1;  // one byte a catom: no two threads write the same
            ran[ch].push_back(at);
        }
    });
    arrived_.clear();
    ran_.clear();
    for (const auto& r : ran) ran_.insert(ran_.end(), r.begin(), r.end());  // ascending: chunks in order
}

// The neighbours the owned catom at place o lost and gained since last step:
// against its list of last step, or the one it arrived with from another
// process.
void ProgramPass::neighbour_changes(std::size_t o, std::vector<std::uint32_t>& lost,
                                   std::vector<std::uint32_t>& gained) const {
    const std::uint32_t* n0 = now_.ids.data() + now_.at[o];
    const std::uint32_t* n1 = now_.ids.data() + now_.at[o + 1];
    const std::uint32_t *b0 = nullptr, *b1 = nullptr;
    if (const auto a = arrived_.find(owned_[o]); a != arrived_.end()) {
        b0 = a->second.data(), b1 = b0 + a->second.size();
    } else if (const std::uint32_t b = before_at_[o]; b != IdMap::kNone) {
        b0 = before_.ids.data() + before_.at[b], b1 = before_.ids.data() + before_.at[b + 1];
    }
    missing(b0, b1, n0, n1, lost);
    missing(n0, n1, b0, b1, gained);
}

// The owned catoms with an event other than a neighbour's (not started yet,
// mail, a timer due): their places in owned_, ascending.
std::vector<std::uint32_t> ProgramPass::due(double time) const {
    const std::size_t n = owned_.size(), chunks = chunk_count(exec_.loops(), n, 4096);
    std::vector<std::vector<std::uint32_t>> part(chunks);
    exec_.loops().run(chunks, n, [&](std::size_t ch) {
        for (std::size_t o = chunk_begin(n, chunks, ch); o < chunk_begin(n, chunks, ch + 1); ++o) {
            const Catom& c = *owned_rec_[o];
            if (!c.started || !c.inbox.empty() || (c.timer_at >= 0 && time >= c.timer_at - 1e-12)) {
                part[ch].push_back(static_cast<std::uint32_t>(o));
            }
        }
    });
    std::vector<std::uint32_t> out;
    for (const auto& p : part) out.insert(out.end(), p.begin(), p.end());
    return out;
}

// In id order: the mail for next step (each receiver's inbox in sender
// order), the magnet switches, the first failure (on every process), then
// the world's values, the counts and the digest.
void ProgramPass::finish_step(World& world) {
    // Only catoms that ran have mail to clear (mail makes a catom run), an
    // outbox, events, a failure or switched magnets.
    for (std::uint32_t o : ran_) owned_rec_[o]->inbox.clear();
    std::vector<std::pair<std::uint32_t, std::string>> failed;  // (catom's gid, what)
    std::int64_t counted[2] = {0, 0};  // messages, events
    for (std::uint32_t o : ran_) {
        Catom& c = *owned_rec_[o];
        if (!c.error.empty()) failed.emplace_back(owned_[o], c.error);
        counted[0] += static_cast<std::int64_t>(c.outbox.size());
        counted[1] += c.events;
        c.events = 0;
    }
    {
        SubstageTimer t(counts_.parts, "mail");
        exchange_mail(world, failed);
    }
    if (!failed.empty()) {
        const auto first = std::min_element(failed.begin(), failed.end());
        throw ProgramError("program " + spec_->name + ", step " + std::to_string(step_) + ": " + first->second);
    }
    SubstageTimer t(counts_.parts, "digest");
    counts_.messages += static_cast<std::uint64_t>(counted[0]);  // this process's: summed when reported
    counts_.events += static_cast<std::uint64_t>(counted[1]);
    refresh_world(world, step_ == 0);
    last_owned_ = owned_;
}

// The values of the owned catoms whose record changed (of all of them when
// local indices moved) into the world, and the digest of the owned catoms
// (this process's part of the state hash): each catom's digest is kept and
// worked out again only when its record changed.
void ProgramPass::refresh_world(World& world, bool all) {
    all = all || world.generation() != generation_;
    generation_ = world.generation();
    world.size_program_values();  // the threads below only write values
    const std::size_t n = owned_.size(), chunks = chunk_count(exec_.loops(), n, 1024);
    std::vector<std::uint64_t> sums(chunks, 0);  // modulo 2^64: any grouping gives the same total
    exec_.loops().run(chunks, n, [&](std::size_t ch) {
        std::vector<unsigned char> bytes;
        std::uint64_t sum = 0;
        for (std::size_t o = chunk_begin(n, chunks, ch); o < chunk_begin(n, chunks, ch + 1); ++o) {
            if (all || dirty_[o]) {
                for (std::size_t v = 0; v < spec_->values.size(); ++v) {  // each catom its own local slot
                    world.set_program_value(owned_local_[o], static_cast<int>(v), owned_rec_[o]->values[v]);
                }
            }
            if (dirty_[o]) digest_[o] = catom_digest(owned_[o], *owned_rec_[o], bytes), dirty_[o] = 0;
            sum += digest_[o];
        }
        sums[ch] = sum;
    });
    std::uint64_t digest = 0;
    for (std::uint64_t v : sums) digest += v;
    world.set_program_digest(digest);
}

void ProgramPass::apply(World& world, double time) {
    const double t0 = now_seconds();
    {
        SubstageTimer t(counts_.parts, "locate");
        locate(world);
    }
    if (distributed()) {
        SubstageTimer t(counts_.parts, "transfer");
        transfer(world);
    }
    if (relocated_ && !distributed()) hold_records();  // distributed: in transfer(), every step
    relocated_ = false;
    // With neighbour events, every owned catom's neighbours; without, the
    // candidates made ready for the catoms that run (a handler that asks gets
    // its catom's neighbours then).
    std::vector<std::uint32_t> which(spec_->neighbour_events ? owned_.size() : 0);
    if (spec_->neighbour_events) std::iota(which.begin(), which.end(), 0u);
    else which = due(time);
    if (!which.empty()) {
        SubstageTimer t(counts_.parts, "neighbours");
        update_candidates(world);
        if (spec_->neighbour_events) find_neighbours(world);
    }
    {
        SubstageTimer t(counts_.parts, "handlers");
        run_handlers(world, which, time);
    }
    finish_step(world);
    ++step_;
    ++counts_.steps;
    counts_.seconds += now_seconds() - t0;
}

}  // namespace parode
