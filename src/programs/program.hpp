// Catom programs: every catom runs its own copy of a program, as in DPRSim and
// VisibleSim's "block codes". A program is a class with event handlers —
// start, a neighbour gained or lost, a message received, a timer — that act
// through a CatomContext: send a small message to a neighbour (delivered the
// next step), switch the catom's magnets, set its named values (written to
// the snapshots and hashed), set a timer, and read its pose, velocity and
// neighbours. Handlers of one step run in parallel, one catom per call, each
// touching only its own catom; messages are delivered in a fixed order (by
// receiver, then sender id, then the order they were sent), so a run gives
// the same state hash for any thread count.
// A program comes from a built-in name (programs/builtin.cpp) or a shared
// library exporting `extern "C" const parode::ProgramSpec* parode_program()`
// (programs/loader.cpp; CMake: parode_add_program() of the installed package).
// Trade-off: a fixed-size message (four 64-bit words) and a fixed number of
// values per catom: no allocation per message, every catom's state in a few
// cache lines, at the price of packing larger data into several messages.
#pragma once
#include <array>
#include <cstdint>
#include <cstring>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace parode {

using Vec3 = std::array<double, 3>;

// What a message carries: four 64-bit words (integers or doubles, the
// program's choice: CatomMessage::real reads a word as a double).
struct CatomMessage {
    std::uint32_t from = 0;  // the sender's id
    std::array<std::int64_t, 4> data{};
    double real(int k) const {
        double v;
        std::memcpy(&v, &data.at(static_cast<std::size_t>(k)), sizeof v);
        return v;
    }
};

// A neighbour: another catom whose centre is within the two radii plus the
// program's reach (the magnets' cutoff when magnets are on).
struct Neighbour {
    std::uint32_t id;
    Vec3 direction;   // unit vector from this catom's centre to the neighbour's
    double distance;  // between the centres (m)
};

constexpr int kProgramValues = 4;  // named values per catom

class CatomContext {
public:
    virtual ~CatomContext() = default;
    virtual std::uint32_t id() const = 0;
    virtual long step() const = 0;
    virtual double time() const = 0;
    virtual Vec3 position() const = 0;
    virtual Vec3 velocity() const = 0;
    virtual std::array<double, 4> orientation() const = 0;  // quaternion w, x, y, z
    // Sorted by id.
    virtual const std::vector<Neighbour>& neighbours() const = 0;
    virtual bool is_neighbour(std::uint32_t id) const = 0;
    // Delivered next step. Throws ProgramError if `to` is not a neighbour or
    // the catom has sent its budget for the step ([program] max_messages).
    virtual void send(std::uint32_t to, const std::array<std::int64_t, 4>& data) = 0;
    void send_real(std::uint32_t to, const std::array<double, 4>& data) {
        std::array<std::int64_t, 4> words;
        std::memcpy(words.data(), data.data(), sizeof words);
        send(to, words);
    }
    // The whole catom's magnets, from the next step's forces on.
    virtual void set_magnets(bool on) = 0;
    virtual bool magnets() const = 0;
    // Value k (0 <= k < kProgramValues), named by the ProgramSpec.
    virtual void set_value(int k, double v) = 0;
    virtual double value(int k) const = 0;
    // on_timer at the first step that starts `seconds` from now or later.
    virtual void set_timer(double seconds) = 0;
    // A number from the scene's [program.params], or `fallback`.
    virtual double param(const std::string& name, double fallback) const = 0;
    // The pole (of the scene's magnet layout, in the body frame) facing
    // neighbour `id` now, switched on or off from the next step's forces on;
    // it stays so as the catom turns. Throws ProgramError if `id` is not a
    // neighbour or the facing pole is past the first 8.
    virtual void set_magnets_toward(std::uint32_t id, bool on) = 0;
    // Whether the pole facing neighbour `id` now is on (and the catom's magnets).
    virtual bool magnets_toward(std::uint32_t id) const = 0;
};

class CatomProgram {
public:
    virtual ~CatomProgram() = default;
    virtual void on_start(CatomContext& /*c*/) {}
    virtual void on_neighbour_gained(CatomContext& /*c*/, std::uint32_t /*id*/) {}
    virtual void on_neighbour_lost(CatomContext& /*c*/, std::uint32_t /*id*/) {}
    virtual void on_message(CatomContext& /*c*/, const CatomMessage& /*m*/) {}
    virtual void on_timer(CatomContext& /*c*/) {}
    // The program's own state as bytes, hashed into the run's state hash and
    // written to checkpoints; load() takes them back on a restart (a program
    // that saves bytes must load them: the default refuses any).
    virtual void save(std::vector<unsigned char>& /*out*/) const {}
    virtual void load(const std::vector<unsigned char>& bytes) {
        if (!bytes.empty()) throw std::runtime_error("the program saves state but has no load() to restore it");
    }
};

// A program: its name, the names of its values (up to kProgramValues) and a
// factory making one object per catom.
struct ProgramSpec {
    std::string name;
    std::vector<std::string> values;
    std::function<std::unique_ptr<CatomProgram>()> make;
    // Whether the program handles on_neighbour_gained / lost. false: they are
    // never called, and a catom's neighbours are worked out only at a step
    // where it has another event (its handlers may still ask for them), so a
    // catom with nothing to do costs next to nothing.
    bool neighbour_events = true;
};

// The entry point a program library exports:
//     PARODE_PROGRAM_ENTRY { static const parode::ProgramSpec s{...}; return &s; }
using ProgramEntry = const ProgramSpec* (*)();
#define PARODE_PROGRAM_ENTRY extern "C" __attribute__((visibility("default"))) const parode::ProgramSpec* parode_program()

// The built-in programs by name ("gradient", "sculpt", "wave"), or null.
const ProgramSpec* builtin_program(const std::string& name);
std::vector<std::string> builtin_program_names();
// A built-in name, or a shared library's path (ending in .so): its spec.
// Throws ProgramError naming the file and what is missing.
const ProgramSpec& load_program(const std::string& name_or_path);

}  // namespace parode
