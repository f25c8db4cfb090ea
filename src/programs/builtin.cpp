// The built-in catom programs, by name:
// - gradient: hop counts from a seed catom (param `seed`, a catom id) through
//   the neighbour graph; value `hops` (-1 until reached). A catom that learns
//   a shorter count sends it, once a step (its timer), to every neighbour but
//   the one it came from, and to each neighbour it gains.
// - sculpt: catoms whose centre lies outside a sphere (params cx, cy, cz,
//   radius) switch their magnets off at start and fall away; value `inside`.
// - wave: a wave from a seed catom (param `seed`): each catom, the first time
//   it hears the wave, records the step (value `step`) and passes it on to
//   every neighbour but the sender; at most 2 |E| messages in all.
// Trade-off: written against the public CatomContext only, as a user's
// program would be; no shortcut into the pass.
#include <cmath>
#include <cstring>

#include "programs/program.hpp"
#include "util/errors.hpp"

namespace parode {
namespace {

void save_int(std::vector<unsigned char>& out, std::int64_t v) {
    unsigned char b[sizeof v];
    std::memcpy(b, &v, sizeof v);
    out.insert(out.end(), b, b + sizeof v);
}

// Word k of what save_int wrote.
std::int64_t load_int(const std::vector<unsigned char>& in, std::size_t k) {
    if (in.size() < (k + 1) * sizeof(std::int64_t)) throw ProgramError("saved state cut short");
    std::int64_t v;
    std::memcpy(&v, in.data() + k * sizeof v, sizeof v);
    return v;
}

std::uint32_t seed_of(const CatomContext& c) {
    const double s = c.param("seed", 0);
    if (!(s >= 0) || s != std::floor(s)) throw ProgramError("program.params.seed must be a catom id");
    return static_cast<std::uint32_t>(s);
}

class Gradient final : public CatomProgram {
public:
    void on_start(CatomContext& c) override {
        c.set_value(0, -1);
        if (c.id() == seed_of(c)) improve(c, 0, c.id());
    }
    void on_message(CatomContext& c, const CatomMessage& m) override {
        if (hops_ < 0 || m.data[0] + 1 < hops_) improve(c, m.data[0] + 1, m.from);
    }
    void on_neighbour_gained(CatomContext& c, std::uint32_t id) override {
        if (hops_ >= 0 && !pending_) c.send(id, {hops_, 0, 0, 0});
    }
    void on_timer(CatomContext& c) override {
        pending_ = false;
        for (const Neighbour& n : c.neighbours()) {
            if (n.id != from_) c.send(n.id, {hops_, 0, 0, 0});
        }
    }
    void save(std::vector<unsigned char>& out) const override {
        save_int(out, hops_);
        save_int(out, from_);
        save_int(out, pending_);
    }
    void load(const std::vector<unsigned char>& in) override {
        hops_ = load_int(in, 0);
        from_ = static_cast<std::uint32_t>(load_int(in, 1));
        pending_ = load_int(in, 2) != 0;
    }

private:
    void improve(CatomContext& c, std::int64_t hops, std::uint32_t from) {
        hops_ = hops;
        from_ = from;
        c.set_value(0, static_cast<double>(hops));
        pending_ = true;
        c.set_timer(0);  // after this step's messages: one broadcast of the best count
    }
    std::int64_t hops_ = -1;
    std::uint32_t from_ = 0;
    bool pending_ = false;
};

class Sculpt final : public CatomProgram {
public:
    void on_start(CatomContext& c) override {
        const double r = c.param("radius", -1);
        if (!(r > 0)) throw ProgramError("program.params.radius must be a positive number (m)");
        const Vec3 x = c.position();
        const double d[3] = {x[0] - c.param("cx", 0), x[1] - c.param("cy", 0), x[2] - c.param("cz", 0)};
        const bool inside = d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= r * r;
        c.set_value(0, inside ? 1 : 0);
        if (!inside) c.set_magnets(false);
    }
};

class Wave final : public CatomProgram {
public:
    void on_start(CatomContext& c) override {
        c.set_value(0, -1);
        if (c.id() == seed_of(c)) pass_on(c, c.id(), true);
    }
    void on_message(CatomContext& c, const CatomMessage& m) override {
        if (!heard_) pass_on(c, m.from, false);
    }
    void save(std::vector<unsigned char>& out) const override { save_int(out, heard_); }
    void load(const std::vector<unsigned char>& in) override { heard_ = load_int(in, 0) != 0; }

private:
    void pass_on(CatomContext& c, std::uint32_t from, bool seed) {
        heard_ = true;
        c.set_value(0, static_cast<double>(c.step()));
        for (const Neighbour& n : c.neighbours()) {
            if (seed || n.id != from) c.send(n.id, {1, 0, 0, 0});
        }
    }
    bool heard_ = false;
};

template <class P>
ProgramSpec spec(const char* name, std::vector<std::string> values, bool neighbour_events) {
    return ProgramSpec{name, std::move(values), [] { return std::make_unique<P>(); }, neighbour_events};
}

const std::vector<ProgramSpec>& builtins() {
    static const std::vector<ProgramSpec> all = {spec<Gradient>("gradient", {"hops"}, true),
                                                 spec<Sculpt>("sculpt", {"inside"}, false),
                                                 spec<Wave>("wave", {"step"}, false)};
    return all;
}

}  // namespace

const ProgramSpec* builtin_program(const std::string& name) {
    for (const ProgramSpec& s : builtins()) {
        if (s.name == name) return &s;
    }
    return nullptr;
}

std::vector<std::string> builtin_program_names() {
    std::vector<std::string> out;
    for (const ProgramSpec& s : builtins()) out.push_back(s.name);
    return out;
}

}  // namespace parode
