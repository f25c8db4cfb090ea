// A catom program built outside parode (parode_add_program): each catom keeps
// its number of neighbours as value `neighbours`, and tells each neighbour it
// gains its own id; value `heard` counts what it was told.
#include <parode/programs/program.hpp>

namespace {

class NeighbourCount final : public parode::CatomProgram {
public:
    void on_neighbour_gained(parode::CatomContext& c, std::uint32_t id) override {
        c.set_value(0, static_cast<double>(c.neighbours().size()));
        c.send(id, {static_cast<std::int64_t>(c.id()), 0, 0, 0});
    }
    void on_neighbour_lost(parode::CatomContext& c, std::uint32_t) override {
        c.set_value(0, static_cast<double>(c.neighbours().size()));
    }
    void on_message(parode::CatomContext& c, const parode::CatomMessage&) override { c.set_value(1, c.value(1) + 1); }
};

}  // namespace

PARODE_PROGRAM_ENTRY {
    static const parode::ProgramSpec spec{"neighbour-count", {"neighbours", "heard"},
                                          [] { return std::make_unique<NeighbourCount>(); }};
    return &spec;
}
