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
    std::vector<Neighbour> neighbours;        // this step's, by id
    std::vector<std::uint32_t> before;        // last step's neighbour ids
    std::vector<CatomMessage> inbox;          // to deliver this step
    std::vector<std::pair<std::uint32_t, CatomMessage>> outbox;  // sent this step: (to, message)
    std::array<double, kProgramValues> values{};
    bool magnets = true, started = false;
    double timer_at = -1;  // negative: no timer
    std::uint64_t events = 0;
    std::string error;     // this step's first failure
    Vec3 x{0, 0, 0}, v{0, 0, 0};
    std::array<double, 4> q{1, 0, 0, 0};
};

namespace {

const char* kEventNames[] = {"start", "neighbour lost", "neighbour gained", "message", "timer"};

class Context final : public CatomContext {
public:
    Context(ProgramPass::Catom& c, std::uint32_t id, long step, double time, const ProgramScene& s)
        : c_(c), id_(id), step_(step), time_(time), scene_(s) {}
    std::uint32_t id() const override { return id_; }
    long step() const override { return step_; }
    double time() const override { return time_; }
    Vec3 position() const override { return c_.x; }
    Vec3 velocity() const override { return c_.v; }
    std::array<double, 4> orientation() const override { return c_.q; }
    const std::vector<Neighbour>& neighbours() const override { return c_.neighbours; }
    bool is_neighbour(std::uint32_t id) const override {
        return std::binary_search(c_.neighbours.begin(), c_.neighbours.end(), Neighbour{id, {}, 0},
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
    long step_;
    double time_;
    const ProgramScene& scene_;
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

// What one catom adds to the state hash.
std::uint64_t catom_digest(std::uint32_t id, const ProgramPass::Catom& c) {
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
    std::vector<unsigned char> bytes;
    c.program->save(bytes);
    if (!bytes.empty()) h.add_bytes(bytes.data(), bytes.size());
    return h.value();
}

// Sorted ids of `a` not in `b`.
std::vector<std::uint32_t> missing(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
    std::vector<std::uint32_t> out;
    std::set_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
    return out;
}

}  // namespace

ProgramPass::ProgramPass(const Scene& scene, Execution& exec)
    : scene_(scene), exec_(exec), spec_(&load_program(scene.program.name)) {
    for (std::size_t g = 0; g < scene.body_count(); ++g) {
        if (scene.body_is_catom(g)) ids_.push_back(static_cast<std::uint32_t>(g));
    }
    const double r = ids_.empty() ? 0.0 : catom_radius(scene, ids_.front());
    reach_ = scene.program.reach >= 0 ? scene.program.reach : scene.magnets.enabled ? scene.magnets.cutoff : 0.1 * r;
    catoms_.resize(ids_.size());
    for (std::size_t k = 0; k < ids_.size(); ++k) {
        catoms_[k].program = spec_->make();
        if (!catoms_[k].program) throw ProgramError("program " + spec_->name + " made no program object");
        catoms_[k].magnets = scene.body_magnets(ids_[k]);
    }
}

ProgramPass::~ProgramPass() = default;

double ProgramPass::value(std::size_t catom, int k) const { return catoms_[catom].values.at(static_cast<std::size_t>(k)); }

// Centres in a sorted cell list (edge: the largest reach of a pair); each
// catom looks at the 27 cells around its own.
void ProgramPass::find_neighbours(const World& world) {
    const std::size_t n = ids_.size();
    double rmax = 0;
    for (std::uint32_t g : ids_) rmax = std::max(rmax, catom_radius(scene_, g));
    const double edge = 2 * rmax + reach_;
    auto key = [&](const Vec3& x, int dx, int dy, int dz) {
        const auto c = [&](double v, int d) { return static_cast<std::int64_t>(std::floor(v / edge)) + d + (1 << 20); };
        return (c(x[0], dx) << 42) | (c(x[1], dy) << 21) | c(x[2], dz);
    };
    std::vector<std::pair<std::int64_t, std::uint32_t>> cells(n);  // (cell, catom index)
    for (std::size_t k = 0; k < n; ++k) {
        Catom& c = catoms_[k];
        dBodyID b = world.body(world.local_of(ids_[k]));
        const dReal* p = dBodyGetPosition(b);
        const dReal* v = dBodyGetLinearVel(b);
        const dReal* q = dBodyGetQuaternion(b);
        c.x = {p[0], p[1], p[2]};
        c.v = {v[0], v[1], v[2]};
        c.q = {q[0], q[1], q[2], q[3]};
        cells[k] = {key(c.x, 0, 0, 0), static_cast<std::uint32_t>(k)};
    }
    std::sort(cells.begin(), cells.end());
    for_ranges(exec_.loops(), n, 256, [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k) {
            Catom& c = catoms_[k];
            c.neighbours.clear();
            const double rk = catom_radius(scene_, ids_[k]);
            for (int d = 0; d < 27; ++d) {
                const std::int64_t want = key(c.x, d % 3 - 1, d / 3 % 3 - 1, d / 9 - 1);
                auto it = std::lower_bound(cells.begin(), cells.end(), std::make_pair(want, std::uint32_t{0}));
                for (; it != cells.end() && it->first == want; ++it) {
                    const Catom& o = catoms_[it->second];
                    if (it->second == k) continue;
                    const Vec3 d3{o.x[0] - c.x[0], o.x[1] - c.x[1], o.x[2] - c.x[2]};
                    const double dist = std::sqrt(d3[0] * d3[0] + d3[1] * d3[1] + d3[2] * d3[2]);
                    if (dist > rk + catom_radius(scene_, ids_[it->second]) + reach_ || dist == 0) continue;
                    c.neighbours.push_back({ids_[it->second], {d3[0] / dist, d3[1] / dist, d3[2] / dist}, dist});
                }
            }
            std::sort(c.neighbours.begin(), c.neighbours.end(),
                      [](const Neighbour& a, const Neighbour& b) { return a.id < b.id; });
        }
    });
}

void ProgramPass::run_handlers(const World& /*world*/, double time) {
    for_ranges(exec_.loops(), catoms_.size(), 64, [&](std::size_t k0, std::size_t k1) {
        for (std::size_t k = k0; k < k1; ++k) {
            Catom& c = catoms_[k];
            std::vector<std::uint32_t> now;
            now.reserve(c.neighbours.size());
            for (const Neighbour& nb : c.neighbours) now.push_back(nb.id);
            const std::vector<std::uint32_t> lost = missing(c.before, now), gained = missing(now, c.before);
            c.outbox.clear();
            c.error.clear();
            Context ctx(c, ids_[k], step_, time, scene_.program);
            run_catom(c, ctx, lost, gained, time);
            c.before = std::move(now);
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
        const std::size_t local = world.local_of(ids_[k]);
        for (std::size_t v = 0; v < spec_->values.size(); ++v) world.set_program_value(local, static_cast<int>(v), c.values[v]);
        for (const auto& [to, m] : c.outbox) {
            const auto at = std::lower_bound(ids_.begin(), ids_.end(), to);
            catoms_[static_cast<std::size_t>(at - ids_.begin())].inbox.push_back(m);
        }
        messages += c.outbox.size();
        events += c.events;
        c.events = 0;
    }
    for (std::size_t k = 0; k < catoms_.size(); ++k) digest += catom_digest(ids_[k], catoms_[k]);
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

}  // namespace parode
