// The catom programs' pass (see program_pass.hpp).
#include "programs/program_pass.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <exception>

#include "util/errors.hpp"
#include "util/hash.hpp"
#include "util/substages.hpp"

namespace parode {

struct ProgramPass::Catom {
    std::unique_ptr<CatomProgram> program;
    std::vector<CatomMessage> inbox;                             // to deliver this step
    std::vector<std::pair<std::uint32_t, CatomMessage>> outbox;  // sent this step: (to, message)
    std::array<double, kProgramValues> values{};
    bool magnets = true, started = false;
    double timer_at = -1;  // negative: no timer
    std::uint32_t events = 0;
    std::string error;     // this step's first failure
};

namespace {

const char* kEventNames[] = {"start", "neighbour lost", "neighbour gained", "message", "timer"};

// One catom's view during its handlers: pose and velocity read from ODE,
// neighbours (with directions) filled in by the pass before the handlers.
class Context final : public CatomContext {
public:
    Context(ProgramPass::Catom& c, std::uint32_t id, dBodyID body, long step, double time, const ProgramScene& s,
            const std::vector<Neighbour>& nbrs)
        : c_(c), id_(id), body_(body), step_(step), time_(time), scene_(s), nbrs_(nbrs) {}
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
    const std::vector<Neighbour>& neighbours() const override { return nbrs_; }
    bool is_neighbour(std::uint32_t id) const override {
        return std::binary_search(nbrs_.begin(), nbrs_.end(), Neighbour{id, {}, 0},
                                  [](const Neighbour& a, const Neighbour& b) { return a.id < b.id; });
    }
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
    double param(const std::string& name, double fallback) const override {
        for (const auto& p : scene_.params) {
            if (p.first == name) return p.second;
        }
        return fallback;
    }

private:
    ProgramPass::Catom& c_;
    std::uint32_t id_;
    dBodyID body_;
    long step_;
    double time_;
    const ProgramScene& scene_;
    const std::vector<Neighbour>& nbrs_;
};

double catom_radius(const Scene& scene, std::uint32_t gid) {
    return gid < scene.bodies.size() ? scene.bodies[gid].shape.radius : scene.catoms.proto.shape.radius;
}

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
    for (const CatomMessage& m : c.inbox) {
        h.add_bytes(&m.from, sizeof m.from);
        h.add_bytes(m.data.data(), sizeof(std::int64_t) * m.data.size());
    }
    bytes.clear();
    c.program->save(bytes);
    if (!bytes.empty()) h.add_bytes(bytes.data(), bytes.size());
    return h.value();
}

// Ids of the sorted range [a0, a1) not in [b0, b1), as gids, into `out`.
void missing(const std::uint32_t* a0, const std::uint32_t* a1, const std::uint32_t* b0, const std::uint32_t* b1,
             const std::vector<std::uint32_t>& gid, std::vector<std::uint32_t>& out) {
    out.clear();
    for (; a0 != a1; ++a0) {
        while (b0 != b1 && *b0 < *a0) ++b0;
        if (b0 == b1 || *b0 != *a0) out.push_back(gid[*a0]);
    }
}

}  // namespace

ProgramPass::ProgramPass(const Scene& scene, Execution& exec)
    : scene_(scene), exec_(exec), spec_(&load_program(scene.program.name)) {
    for (std::size_t g = 0; g < scene.body_count(); ++g) {
        if (scene.body_is_catom(g)) ids_.push_back(static_cast<std::uint32_t>(g));
    }
    const double r = ids_.empty() ? 0.0 : catom_radius(scene, ids_.front());
    reach_ = scene.program.reach >= 0 ? scene.program.reach : scene.magnets.enabled ? scene.magnets.cutoff : 0.1 * r;
    double rmax = 0;  // the scene's radii: the cell edge is fixed for the run
    for (std::uint32_t g : ids_) rmax = std::max(rmax, catom_radius(scene, g));
    edge_ = 2 * rmax + reach_;
    catoms_.resize(ids_.size());
    now_.at.assign(ids_.size() + 1, 0);
    for (std::size_t k = 0; k < ids_.size(); ++k) {
        catoms_[k].program = spec_->make();
        if (!catoms_[k].program) throw ProgramError("program " + spec_->name + " made no program object");
        catoms_[k].magnets = scene.body_magnets(ids_[k]);
    }
}

ProgramPass::~ProgramPass() = default;

// The catoms' local indices, once (one process: they never move).
void ProgramPass::bind(const World& world) {
    if (!locals_.empty()) return;
    for (std::uint32_t g : ids_) locals_.push_back(world.local_of(g));
}

double ProgramPass::value(std::size_t catom, int k) const { return catoms_[catom].values.at(static_cast<std::size_t>(k)); }

// Centres in a cell list of edge 2 r_max + reach: a dense grid over the
// bounding box when it has at most 8 cells a catom (counting sort, O(N)),
// else the catoms sorted by cell key; each catom then looks at the 27 cells
// around its own. Chunks of catoms fill their own lists, joined in order.
void ProgramPass::find_neighbours(const World& world) {
    const std::size_t n = ids_.size();
    bind(world);
    std::vector<Vec3> x(n);
    Vec3 high{-1e300, -1e300, -1e300};
    low_ = {1e300, 1e300, 1e300};
    for (std::size_t k = 0; k < n; ++k) {
        const dReal* p = dBodyGetPosition(world.body(locals_[k]));
        x[k] = {p[0], p[1], p[2]};
        for (int a = 0; a < 3; ++a) low_[a] = std::min(low_[a], x[k][a]), high[a] = std::max(high[a], x[k][a]);
    }
    double cells = 1;
    for (int a = 0; a < 3; ++a) {
        dims_[a] = n ? static_cast<std::int64_t>((high[a] - low_[a]) / edge_) + 1 : 1;
        cells *= static_cast<double>(dims_[a]);
    }
    const auto cell = [&](const Vec3& p, int a) { return static_cast<std::int64_t>((p[a] - low_[a]) / edge_); };
    sorted_.clear();
    start_.clear();
    if (cells <= 8.0 * static_cast<double>(n) + 64) {
        start_.assign(static_cast<std::size_t>(cells) + 1, 0);
        order_.resize(n);
        std::vector<std::uint32_t> of(n);
        for (std::size_t k = 0; k < n; ++k) {
            of[k] = static_cast<std::uint32_t>((cell(x[k], 0) * dims_[1] + cell(x[k], 1)) * dims_[2] + cell(x[k], 2));
            ++start_[of[k] + 1];
        }
        for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
        std::vector<std::uint32_t> fill(start_.begin(), start_.end() - 1);
        for (std::size_t k = 0; k < n; ++k) order_[fill[of[k]]++] = static_cast<std::uint32_t>(k);
    } else {
        sorted_.resize(n);
        for (std::size_t k = 0; k < n; ++k) {
            sorted_[k] = {(cell(x[k], 0) << 42) | (cell(x[k], 1) << 21) | cell(x[k], 2), static_cast<std::uint32_t>(k)};
        }
        std::sort(sorted_.begin(), sorted_.end());
    }
    std::swap(before_, now_);
    const std::size_t chunks = chunk_count(exec_.loops(), n, 1024);
    std::vector<std::vector<std::uint32_t>> part(chunks);
    now_.at.assign(n + 1, 0);
    exec_.loops().run(chunks, n, [&](std::size_t c) {
        std::vector<std::uint32_t> mine;
        for (std::size_t k = chunk_begin(n, chunks, c); k < chunk_begin(n, chunks, c + 1); ++k) {
            const std::size_t from = mine.size();
            neighbours_of(k, x, mine);
            now_.at[k + 1] = static_cast<std::uint32_t>(mine.size() - from);
        }
        part[c] = std::move(mine);
    });
    for (std::size_t k = 0; k < n; ++k) now_.at[k + 1] += now_.at[k];
    now_.ids.clear();
    now_.ids.reserve(now_.at[n]);
    for (const auto& p : part) now_.ids.insert(now_.ids.end(), p.begin(), p.end());
}

// Catom k's neighbours (catom indices, ascending) appended to `out`.
void ProgramPass::neighbours_of(std::size_t k, const std::vector<Vec3>& x, std::vector<std::uint32_t>& out) const {
    const std::size_t from = out.size();
    const double rk = catom_radius(scene_, ids_[k]);
    const auto take = [&](std::uint32_t j) {
        if (j == k) return;
        const double d = std::sqrt((x[j][0] - x[k][0]) * (x[j][0] - x[k][0]) + (x[j][1] - x[k][1]) * (x[j][1] - x[k][1]) +
                                   (x[j][2] - x[k][2]) * (x[j][2] - x[k][2]));
        if (d > 0 && d <= rk + catom_radius(scene_, ids_[j]) + reach_) out.push_back(j);
    };
    std::int64_t c[3];
    for (int a = 0; a < 3; ++a) c[a] = static_cast<std::int64_t>((x[k][a] - low_[a]) / edge_);
    for (int d = 0; d < 27; ++d) {
        const std::int64_t cx = c[0] + d % 3 - 1, cy = c[1] + d / 3 % 3 - 1, cz = c[2] + d / 9 - 1;
        if (!start_.empty()) {
            if (cx < 0 || cy < 0 || cz < 0 || cx >= dims_[0] || cy >= dims_[1] || cz >= dims_[2]) continue;
            const std::size_t cell = static_cast<std::size_t>((cx * dims_[1] + cy) * dims_[2] + cz);
            for (std::uint32_t i = start_[cell]; i < start_[cell + 1]; ++i) take(order_[i]);
        } else {
            const std::int64_t want = (cx << 42) | (cy << 21) | cz;
            auto it = std::lower_bound(sorted_.begin(), sorted_.end(), std::make_pair(want, std::uint32_t{0}));
            for (; it != sorted_.end() && it->first == want; ++it) take(it->second);
        }
    }
    std::sort(out.begin() + static_cast<std::ptrdiff_t>(from), out.end());
}

void ProgramPass::run_handlers(const World& world, double time) {
    const bool first = before_.at.empty();
    for_ranges(exec_.loops(), catoms_.size(), 256, [&](std::size_t k0, std::size_t k1) {
        std::vector<std::uint32_t> lost, gained;
        std::vector<Neighbour> nbrs;
        for (std::size_t k = k0; k < k1; ++k) {
            Catom& c = catoms_[k];
            const std::uint32_t* n0 = now_.ids.data() + now_.at[k];
            const std::uint32_t* n1 = now_.ids.data() + now_.at[k + 1];
            const std::uint32_t* b0 = first ? nullptr : before_.ids.data() + before_.at[k];
            const std::uint32_t* b1 = first ? nullptr : before_.ids.data() + before_.at[k + 1];
            missing(b0, b1, n0, n1, ids_, lost);
            missing(n0, n1, b0, b1, ids_, gained);
            dBodyID body = world.body(locals_[k]);
            const dReal* p = dBodyGetPosition(body);
            nbrs.clear();
            for (const std::uint32_t* j = n0; j != n1; ++j) {
                const dReal* q = dBodyGetPosition(world.body(locals_[*j]));
                const Vec3 d{q[0] - p[0], q[1] - p[1], q[2] - p[2]};
                const double len = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                nbrs.push_back({ids_[*j], {d[0] / len, d[1] / len, d[2] / len}, len});
            }
            c.outbox.clear();
            c.error.clear();
            Context ctx(c, ids_[k], body, step_, time, scene_.program, nbrs);
            run_catom(c, ctx, lost, gained, time);
        }
    });
}

// Serially, in id order: the first failure, the magnet switches, the mail
// for next step (each receiver's inbox in sender order), the counts and the
// digest.
void ProgramPass::finish_step(World& world) {
    for (std::size_t k = 0; k < catoms_.size(); ++k) {
        if (!catoms_[k].error.empty()) {
            throw ProgramError("program " + spec_->name + ", step " + std::to_string(step_) + ": " + catoms_[k].error);
        }
    }
    for (Catom& c : catoms_) c.inbox.clear();
    std::uint64_t digest = 0, events = 0, messages = 0;
    for (std::size_t k = 0; k < catoms_.size(); ++k) {
        Catom& c = catoms_[k];
        world.switch_magnets(ids_[k], c.magnets);
        for (std::size_t v = 0; v < spec_->values.size(); ++v) {
            world.set_program_value(locals_[k], static_cast<int>(v), c.values[v]);
        }
        for (const auto& [to, m] : c.outbox) {
            const auto at = std::lower_bound(ids_.begin(), ids_.end(), to);
            catoms_[static_cast<std::size_t>(at - ids_.begin())].inbox.push_back(m);
        }
        messages += c.outbox.size();
        events += c.events;
        c.events = 0;
    }
    const std::size_t n = catoms_.size(), chunks = chunk_count(exec_.loops(), n, 1024);
    std::vector<std::uint64_t> sums(chunks, 0);  // modulo 2^64: any grouping gives the same total
    exec_.loops().run(chunks, n, [&](std::size_t c) {
        std::vector<unsigned char> bytes;
        std::uint64_t sum = 0;
        for (std::size_t k = chunk_begin(n, chunks, c); k < chunk_begin(n, chunks, c + 1); ++k) {
            sum += catom_digest(ids_[k], catoms_[k], bytes);
        }
        sums[c] = sum;
    });
    for (std::uint64_t v : sums) digest += v;
    world.set_program_digest(digest);
    counts_.messages += messages;
    counts_.events += events;
}

void ProgramPass::apply(World& world, double time) {
    const double t0 = now_seconds();
    find_neighbours(world);
    run_handlers(world, time);
    finish_step(world);
    ++step_;
    ++counts_.steps;
    counts_.seconds += now_seconds() - t0;
}

namespace {

// Plain values appended to and read from a byte buffer.
class Bytes {
public:
    explicit Bytes(std::vector<char>& out) : out_(&out) {}
    Bytes(const std::vector<char>& in, std::size_t at) : in_(&in), at_(at) {}
    template <class T>
    void put(const T& v) {
        const char* p = reinterpret_cast<const char*>(&v);
        out_->insert(out_->end(), p, p + sizeof v);
    }
    void put_bytes(const void* p, std::size_t n) {
        put(static_cast<std::uint64_t>(n));
        const char* c = static_cast<const char*>(p);
        out_->insert(out_->end(), c, c + n);
    }
    template <class T>
    T get() {
        need(sizeof(T));
        T v;
        std::memcpy(&v, in_->data() + at_, sizeof v);
        at_ += sizeof v;
        return v;
    }
    std::vector<unsigned char> get_bytes() {
        const auto n = static_cast<std::size_t>(get<std::uint64_t>());
        need(n);
        std::vector<unsigned char> v(in_->begin() + static_cast<std::ptrdiff_t>(at_),
                                     in_->begin() + static_cast<std::ptrdiff_t>(at_ + n));
        at_ += n;
        return v;
    }
    bool done() const { return at_ == in_->size(); }

private:
    void need(std::size_t n) const {
        if (at_ + n > in_->size()) throw CheckpointError("the catom programs' state in the checkpoint is cut short");
    }
    std::vector<char>* out_ = nullptr;
    const std::vector<char>* in_ = nullptr;
    std::size_t at_ = 0;
};

}  // namespace

std::vector<char> ProgramPass::save_state() const {
    std::vector<char> out;
    Bytes b(out);
    b.put(static_cast<std::uint64_t>(ids_.size()));
    b.put(static_cast<std::int64_t>(step_));
    b.put(counts_.steps);
    b.put(counts_.messages);
    b.put(counts_.events);
    std::vector<unsigned char> bytes;
    for (std::size_t k = 0; k < catoms_.size(); ++k) {
        const Catom& c = catoms_[k];
        b.put(c.values);
        b.put(static_cast<std::uint8_t>(c.magnets));
        b.put(static_cast<std::uint8_t>(c.started));
        b.put(c.timer_at);
        b.put(static_cast<std::uint64_t>(c.inbox.size()));
        for (const CatomMessage& m : c.inbox) {
            b.put(m.from);
            b.put(m.data);
        }
        bytes.clear();
        c.program->save(bytes);
        b.put_bytes(bytes.data(), bytes.size());
        const std::uint32_t n0 = now_.at[k], n1 = now_.at[k + 1];
        b.put_bytes(now_.ids.data() + n0, sizeof(std::uint32_t) * (n1 - n0));
    }
    return out;
}

void ProgramPass::load_state(World& world, const std::vector<char>& state) {
    Bytes b(state, 0);
    if (b.get<std::uint64_t>() != ids_.size()) {
        throw CheckpointError("the catom programs' state in the checkpoint is for another number of catoms");
    }
    step_ = static_cast<long>(b.get<std::int64_t>());
    counts_.steps = b.get<std::uint64_t>();
    counts_.messages = b.get<std::uint64_t>();
    counts_.events = b.get<std::uint64_t>();
    now_.at.assign(ids_.size() + 1, 0);
    now_.ids.clear();
    for (std::size_t k = 0; k < catoms_.size(); ++k) {
        Catom& c = catoms_[k];
        c.values = b.get<std::array<double, kProgramValues>>();
        c.magnets = b.get<std::uint8_t>() != 0;
        c.started = b.get<std::uint8_t>() != 0;
        c.timer_at = b.get<double>();
        c.inbox.resize(static_cast<std::size_t>(b.get<std::uint64_t>()));
        for (CatomMessage& m : c.inbox) {
            m.from = b.get<std::uint32_t>();
            m.data = b.get<std::array<std::int64_t, 4>>();
        }
        try {
            c.program->load(b.get_bytes());
        } catch (const std::exception& e) {
            throw ProgramError("program " + spec_->name + ", catom " + std::to_string(ids_[k]) + ", restoring: " + e.what());
        }
        const std::vector<unsigned char> nbrs = b.get_bytes();
        const std::size_t count = nbrs.size() / sizeof(std::uint32_t);
        now_.ids.resize(now_.ids.size() + count);
        std::memcpy(now_.ids.data() + now_.ids.size() - count, nbrs.data(), nbrs.size());
        now_.at[k + 1] = static_cast<std::uint32_t>(now_.ids.size());
    }
    if (!b.done()) throw CheckpointError("the catom programs' state in the checkpoint is longer than its catoms'");
    bind(world);
    std::uint64_t digest = 0;
    std::vector<unsigned char> bytes;
    for (std::size_t k = 0; k < catoms_.size(); ++k) {
        world.switch_magnets(ids_[k], catoms_[k].magnets);
        for (std::size_t v = 0; v < spec_->values.size(); ++v) {
            world.set_program_value(locals_[k], static_cast<int>(v), catoms_[k].values[v]);
        }
        digest += catom_digest(ids_[k], catoms_[k], bytes);
    }
    world.set_program_digest(digest);
}

}  // namespace parode
