// Run report (see report.hpp).
#include "run/report.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <iomanip>
#include <numeric>

#include "util/errors.hpp"
#include "util/hash.hpp"
#include "util/peak_memory.hpp"

#ifndef PARODE_ODE_VERSION
#define PARODE_ODE_VERSION "unknown"
#endif
#ifndef PARODE_CXX_FLAGS
#define PARODE_CXX_FLAGS ""
#endif
#ifndef PARODE_BUILD_TYPE
#define PARODE_BUILD_TYPE ""
#endif

namespace parode {

nlohmann::json build_info() {
    nlohmann::json b;
#if defined(__clang__)
    b["compiler"] = "clang " __clang_version__;
#elif defined(__GNUC__)
    b["compiler"] = "gcc " __VERSION__;
#else
    b["compiler"] = "unknown";
#endif
    b["flags"] = std::string(PARODE_CXX_FLAGS);
    b["build_type"] = std::string(PARODE_BUILD_TYPE);
    b["ode_version"] = std::string(PARODE_ODE_VERSION);
    b["precision"] = dCheckConfiguration("ODE_double_precision") ? "double" : "single";
    b["ode_configuration"] = std::string(dGetConfiguration());
    return b;
}

namespace {

nlohmann::json diagnostics_json(const Diagnostics& d, const RunTotals& t) {
    nlohmann::json j;
    j["max_penetration"] = t.max_penetration;
    j["mean_penetration"] = t.mean_penetration();
    j["final_max_penetration"] = d.max_penetration;
    j["nan_count"] = d.nan_count;
    j["energy"] = {{"kinetic", d.kinetic}, {"potential", d.potential}, {"total", d.energy()}};
    j["momentum"] = {{"linear", d.momentum}, {"angular", d.angular_momentum}};
    j["com_height"] = d.com_height;
    j["disabled_bodies"] = d.disabled;
    j["final_contacts"] = d.contacts;
    return j;
}

}  // namespace

namespace {

// Collective: {min, avg, max} of a per-process value over the processes.
nlohmann::json spread(const Collectives& domain, double v) {
    ExactSum total;
    total.add(v);
    domain.sum(&total, 1);
    return {{"min", domain.min(v)}, {"avg", total.value() / domain.ranks()}, {"max", domain.max(v)}};
}

// The process whose peak memory is `top`, the largest: the lowest rank of
// equals (collective).
int fullest_of(const Collectives& domain, double rss, double top) {
    return static_cast<int>(domain.min(rss == top ? domain.rank() : domain.ranks()));
}

// The fullest process (`rank`) with the bodies it held at the end: owned and ghosts.
nlohmann::json fullest_rank(const Collectives& domain, const World& world, int rank) {
    std::int64_t held[2] = {0, 0};
    if (domain.rank() == rank) {
        held[0] = static_cast<std::int64_t>(world.owned_count());
        held[1] = static_cast<std::int64_t>(world.body_count() - world.owned_count());
    }
    domain.sum(held, 2);
    return {{"rank", rank}, {"owned", held[0]}, {"ghosts", held[1]}};
}

// The parts of memory.peak_by_stage in their order: the set-up, the stages, other.
std::vector<std::string> peak_part_names() {
    std::vector<std::string> names{"setup"};
    for (int s = 0; s < kStageCount; ++s) names.emplace_back(stage_name(static_cast<Stage>(s)));
    names.emplace_back("other");
    return names;
}

// What the fullest process's peak memory (`top`, bytes) is made of: the
// set-up's peak, what each stage added to it over the steps, and `other`,
// what came between and after them (a checkpoint written at the end); the
// parts sum to `top`. Collective.
nlohmann::json peak_parts_json(const Collectives& domain, const Pipeline& p, int rank, double top) {
    const std::vector<std::string> names = peak_part_names();  // setup, the stages, other
    std::vector<std::int64_t> part(names.size(), 0);
    if (domain.rank() == rank) {
        part[0] = p.setup_peak();
        for (int s = 0; s < kStageCount; ++s) part[static_cast<std::size_t>(s) + 1] = p.stage(static_cast<Stage>(s)).peak_growth;
    }
    domain.sum(part.data(), static_cast<int>(part.size()));
    part.back() = static_cast<std::int64_t>(top) - std::accumulate(part.begin(), part.end() - 1, std::int64_t{0});
    nlohmann::json j = nlohmann::json::object();
    for (std::size_t k = 0; k < names.size(); ++k) j[names[k]] = part[k];
    return j;
}

// Seconds the solver spent exchanging corrections between colours (part of
// its warm start and sweeps; distributed runs only).
double solver_exchange_seconds(const Pipeline& p) {
    const Substages* s = p.substages(Stage::Solve);
    return s ? s->seconds("exchange") : 0;
}

// The adaptive solver's active sweeps: per step (substep), the sweeps of
// listed cells (the last sweep of every cell included) and the contacts they
// relaxed as a share of the step's (summed over the processes, exactly).
nlohmann::json active_json(const Collectives& domain, const ActiveWork& a) {
    std::int64_t v[2] = {a.relaxed, a.contacts};
    domain.sum(v, 2);
    const double steps = static_cast<double>(std::max<std::int64_t>(a.steps, 1));
    return {{"sweeps_per_step", static_cast<double>(a.sweeps) / steps},
            {"relaxed_per_step", v[1] ? static_cast<double>(v[0]) / static_cast<double>(v[1]) : 0.0}};
}

// Per colour of the contact solver: the seconds its cells took and the
// seconds waiting for the other processes' corrections, {min, avg, max} over
// ranks; and the colours' imbalance: what a run pays when every colour waits
// for its slowest rank (the sum over colours of the largest compute), over
// what it would pay if each rank had its mean (the sum of the means).
void colour_json(const Collectives& domain, const ColourTimes& t, nlohmann::json& parallel) {
    nlohmann::json colours = nlohmann::json::array();
    double slowest = 0, mean = 0, wait = 0;
    for (std::size_t c = 0; c < t.compute.size(); ++c) {
        const nlohmann::json compute = spread(domain, t.compute[c]);
        colours.push_back({{"compute_s", compute}, {"wait_s", spread(domain, t.wait[c])}});
        slowest += compute["max"].get<double>();
        mean += compute["avg"].get<double>();
        wait += t.wait[c];
    }
    parallel["colours"] = colours;
    parallel["colour_imbalance"] = mean > 0 ? slowest / mean : 1.0;
    parallel["wait_seconds"] = spread(domain, wait);
}

// The catom program: what ran, its messages and events per step, its time,
// and (up to kListedCatoms catoms) every catom's values by name.
nlohmann::json program_json(const Collectives& domain, const ProgramPass& pass) {
    constexpr std::size_t kListedCatoms = 100000;
    const ProgramCounts c = pass.totals();  // collective when distributed
    const double steps = c.steps ? static_cast<double>(c.steps) : 1.0;
    nlohmann::json out = {{"name", pass.spec().name},         {"catoms", pass.catom_count()},
                          {"steps", c.steps},                 {"messages", c.messages},
                          {"events", c.events},               {"messages_per_step", static_cast<double>(c.messages) / steps},
                          {"events_per_step", c.events / steps}, {"seconds", c.seconds},
                          {"neighbour_listings", c.lists},
                          {"value_names", pass.spec().values}};
    nlohmann::json parts = nlohmann::json::object();  // collective: every process has timed every part
    for (const auto& [name, seconds] : c.parts.items()) parts[name] = spread(domain, seconds);
    out["parts_s"] = parts;
    if (pass.catom_count() > kListedCatoms) return out;
    out["ids"] = pass.catom_ids();
    nlohmann::json values = nlohmann::json::object();
    for (std::size_t k = 0; k < pass.spec().values.size(); ++k) {
        values[pass.spec().values[k]] = pass.values_of(static_cast<int>(k));  // collective when distributed
    }
    out["values"] = values;
    return out;
}

// Substages reported for a stage whose backend times them, in this order.
const std::vector<std::pair<Stage, std::vector<const char*>>>& substage_names() {
    static const std::vector<std::pair<Stage, std::vector<const char*>>> names = {
        {Stage::Solve, {"build", "warm_start", "sweeps", "active", "integrate"}},
        {Stage::Collide, {"refresh", "broadphase", "narrowphase", "merge"}},
        {Stage::Forces, {"program", "magnets", "controller"}}};
    return names;
}

// Collective: stage -> substage -> seconds (the slowest process's), of the
// timers `of` gives for a stage (null: the stage has none).
template <class Of>
nlohmann::json substages_json(const Collectives& domain, Of&& of) {
    nlohmann::json out = nlohmann::json::object();
    for (const auto& [stage, names] : substage_names()) {
        const Substages* s = of(stage);
        if (!s) continue;
        nlohmann::json j = nlohmann::json::object();
        for (const char* name : names) j[name] = domain.max(s->seconds(name));
        out[stage_name(stage)] = j;
    }
    return out;
}

// Collective: the first step's wall, stages and substages (Pipeline::StepTimes),
// the slowest process's each; null before any step.
nlohmann::json first_step_json(const Collectives& domain, const Pipeline& p) {
    const Pipeline::StepTimes& t = p.first_step_times();
    if (!domain.max(t.done ? 1.0 : 0.0)) return nullptr;
    nlohmann::json stages = nlohmann::json::object();
    for (int s = 0; s < kStageCount; ++s) stages[stage_name(static_cast<Stage>(s))] = domain.max(t.stages[static_cast<std::size_t>(s)]);
    auto of = [&](Stage s) -> const Substages* {
        const std::optional<Substages>& sub = t.substages[static_cast<std::size_t>(s)];
        return sub ? &*sub : nullptr;
    };
    return {{"wall_s", domain.max(t.wall)}, {"stages", stages}, {"substages", substages_json(domain, of)}};
}

// The peak memory line: the fullest process's peak and its parts of 0.1 MiB
// or more (memory.peak_by_stage), in MiB.
void print_peak_parts(std::ostream& os, const nlohmann::json& m) {
    constexpr double kMiB = 1024.0 * 1024.0;
    os << std::setprecision(1) << "  peak memory " << m["peak_rss_bytes"]["max"].get<double>() / kMiB << " MiB";
    const char* sep = ": ";
    for (const std::string& name : peak_part_names()) {
        const double v = m["peak_by_stage"][name].get<double>();
        if (v < 0.1 * kMiB) continue;
        os << sep << name << " " << v / kMiB;
        sep = ", ";
    }
    os << (m.contains("fullest") ? " (the fullest rank)\n" : "\n");
}

// The summary lines of a stage's substages, indented under it.
void print_substages(std::ostream& os, const nlohmann::json& r, Stage stage, double wall) {
    const char* name = stage_name(stage);
    if (!r.contains("substages") || !r["substages"].contains(name)) return;
    for (const auto& [st, names] : substage_names()) {
        if (st != stage) continue;
        for (const char* sub : names) {
            const double v = r["substages"][name].value(sub, 0.0);
            if (stage == Stage::Forces && v == 0) continue;  // a pass the scene does not have
            os << "    " << std::left << std::setw(11) << sub << std::right << std::setw(8) << v << std::setw(7)
               << std::setprecision(1) << (wall > 0 ? 100.0 * v / wall : 0.0) << "%\n" << std::setprecision(3);
        }
    }
}

// The implementation of every stage that ran, by the stage registry's names.
nlohmann::json backends_json(const Pipeline& p) {
    nlohmann::json forces = nlohmann::json::array();
    for (const auto& pass : p.force_passes()) forces.push_back(pass->name());
    return {{"collide", p.backend().name()}, {"solve", p.solver().name()}, {"forces", forces},
            {"loops", p.execution().loops_name()}};
}

}  // namespace

nlohmann::json make_report(const Scene& scene, const Pipeline& p, const RunInfo& info) {
    const Collectives& domain = p.collectives();
    const double rss = static_cast<double>(peak_rss_bytes());  // the run's, before the report's own arrays (programs' values: 9 MB at 10^5)
    nlohmann::json r;
    const int steps = p.steps_done() - p.first_step();  // of this run (a restart continues from first_step)
    const double wall = domain.max(info.wall_s);
    // The first step's collision ran while the pipeline was built; a step's
    // cost includes it.
    const double step_wall = domain.max(info.wall_s + p.collide_before_steps());
    r["scene"] = scene.name;
    r["scene_file"] = info.scene_path;
    r["seed"] = scene.seed;
    r["bodies"] = p.world().global_body_count();
    r["catoms"] = scene.catom_count();
    r["steps"] = steps;
    r["final_step"] = p.steps_done();
    r["time"] = p.steps_done() * scene.dt;
    r["dt"] = scene.dt;
    r["threads"] = p.execution().threads();
    r["threads_from"] = p.execution().threads_from();
    r["ranks"] = domain.ranks();
    r["wall_s"] = wall;
    r["ms_per_step"] = steps ? 1000.0 * step_wall / steps : 0.0;
    r["steps_wall_s"] = step_wall;  // wall_s and the first step's collision, if run before the loop
    r["backends"] = backends_json(p);
    r["solver"] = solver_json(scene.solver);
    r["solver"]["backend"] = p.solver().name();  // what ran: "parallel", "ode-quickstep", ...
    if (const ActiveWork* a = p.solver().active_work()) r["solver"]["active"] = active_json(domain, *a);
    nlohmann::json stages = nlohmann::json::object(), ran = nlohmann::json::object(), ranks = nlohmann::json::object();
    for (int s = 0; s < kStageCount; ++s) {
        const StageState& st = p.stage(static_cast<Stage>(s));
        const char* name = stage_name(static_cast<Stage>(s));
        ranks[name] = spread(domain, st.seconds);
        stages[name] = ranks[name]["max"];
        ran[name] = {{"ran", st.enabled}, {"why", st.reason}};
    }
    r["stages"] = stages;
    r["stage_ranks"] = ranks;
    r["stages_run"] = ran;
    r["substages"] = substages_json(domain, [&](Stage s) { return p.substages(s); });
    nlohmann::json counts = nlohmann::json::object();
    for (const auto& [name, n] : p.backend().counts()) counts[name] = domain.sum(n);  // over ranks
    r["collide_counts"] = counts;
    r["first_step"] = first_step_json(domain, p);
    const auto contacts = domain.sum(static_cast<std::int64_t>(p.totals().contacts));
    // The totals cover the whole run, a restarted one's included.
    r["contacts_per_step"] = p.steps_done() ? static_cast<double>(contacts) / p.steps_done() : 0.0;
    r["state_hash"] = hex64(p.last().state_hash);
    r["diagnostics"] = diagnostics_json(p.last(), p.totals());
    r["guard"] = p.guard().describe();
    if (p.program()) r["program"] = program_json(domain, *p.program());
    r["parallel"] = p.decomposition().report();
    if (domain.distributed()) r["parallel"]["solver_exchange_seconds"] = spread(domain, solver_exchange_seconds(p));
    if (const ColourTimes* t = p.solver().colour_times()) colour_json(domain, *t, r["parallel"]);
    ExactSum total_rss;
    total_rss.add(rss);
    domain.sum(&total_rss, 1);
    r["memory"] = {{"peak_rss_bytes", spread(domain, rss)},
                   {"bytes_per_body", total_rss.value() / std::max<double>(1.0, static_cast<double>(p.world().global_body_count()))}};
    const double top = r["memory"]["peak_rss_bytes"]["max"].get<double>();  // spread's reduction, not another
    const int fullest = fullest_of(domain, rss, top);
    if (domain.distributed()) r["memory"]["fullest"] = fullest_rank(domain, p.world(), fullest);
    r["memory"]["peak_by_stage"] = peak_parts_json(domain, p, fullest, top);
    const nlohmann::json checks = p.checks_result();
    if (!checks.is_null()) r["checks"] = checks;
    r["build"] = build_info();
    return r;
}

void print_summary(std::ostream& os, const nlohmann::json& r) {
    const double wall = r["steps_wall_s"].get<double>();  // what the stages' shares are of
    os << "parode run: " << r["scene"].get<std::string>() << " (" << r["bodies"] << " bodies, " << r["steps"]
       << " steps of " << r["dt"] << " s, " << r["ranks"] << " rank(s) x " << r["threads"] << " thread(s), collide "
       << r["backends"]["collide"].get<std::string>() << ")\n";
    os << std::fixed << std::setprecision(3);
    os << "  stage      ran   seconds   share  why\n";
    for (int k = 0; k < kStageCount; ++k) {
        const std::string name = stage_name(static_cast<Stage>(k));
        const double s = r["stages"][name].get<double>();
        const auto& info = r["stages_run"][name];
        os << "  " << std::left << std::setw(9) << name << std::right << std::setw(4)
           << (info["ran"].get<bool>() ? "yes" : "no") << std::setw(10) << s << std::setw(7) << std::setprecision(1)
           << (wall > 0 ? 100.0 * s / wall : 0.0) << "%  " << std::setprecision(3) << info["why"].get<std::string>()
           << "\n";
        print_substages(os, r, static_cast<Stage>(k), wall);
    }
    if (r.contains("collide_counts") && r["collide_counts"].contains("neighbour_list_builds")) {
        const auto& c = r["collide_counts"];
        os << "  neighbour list: built " << c["neighbour_list_builds"].get<std::int64_t>() << " times, served "
           << c["neighbour_list_uses"].get<std::int64_t>() << " more calls";
        if (c.contains("neighbour_list_patches") && c["neighbour_list_patches"].get<std::int64_t>() > 0) {
            os << " (" << c["neighbour_list_patches"].get<std::int64_t>() << " after patching it)";
        }
        os << "\n";
    }
    const auto& d = r["diagnostics"];
    os << "  wall " << wall << " s, " << r["ms_per_step"].get<double>() << " ms/step, "
       << std::setprecision(1) << r["contacts_per_step"].get<double>() << " contacts/step\n";
    os << std::setprecision(6) << "  energy " << d["energy"]["total"].get<double>() << " J (kinetic "
       << d["energy"]["kinetic"].get<double>() << "), centre of mass height " << d["com_height"].get<double>()
       << " m\n";
    os << "  penetration max " << d["max_penetration"].get<double>() << " m, mean "
       << d["mean_penetration"].get<double>() << " m, NaN bodies " << d["nan_count"] << "\n";
    os << "  state hash " << r["state_hash"].get<std::string>() << "\n";
    print_peak_parts(os, r["memory"]);
    os.unsetf(std::ios::floatfield);
    if (!r.contains("checks")) return;
    os << "  checks " << (r["checks"]["passed"].get<bool>() ? "passed" : "FAILED") << ":";
    for (const auto& i : r["checks"]["items"]) {
        os << " " << i["name"].get<std::string>() << " = " << i["value"].get<double>() << " ("
           << (i["passed"].get<bool>() ? "ok" : "fail") << ", bound " << i["bound"].get<double>() << ");";
    }
    os << "\n";
}

void print_error_summary(std::ostream& os, const nlohmann::json& e) {
    const auto& ref = e["reference"];
    // A trajectory or report written before the backend was recorded names its stepper only.
    const std::string solver = ref["solver"].value("backend", ref["solver"].value("stepper", std::string("?")) + " stepper");
    os << "  error against " << ref.value("scene", std::string("?")) << " (dt " << ref.value("dt", 0.0) << ", solver "
       << solver << ", " << ref["solver"].value("iterations", 0) << " iterations), " << e["matched_frames"]
       << " matched frames\n";
    for (const auto& h : e["trajectory"]) {
        os << "    after " << h["step"] << " steps: position RMS " << h["rms"].get<double>() << " m, max "
           << h["max"].get<double>() << " m\n";
    }
    const auto& o = e["observables"];
    os << "    at t = " << o["time"].get<double>() << " s: com height " << o["com_height"]["diff"].get<double>()
       << " m off, spread " << o["spread"]["diff"].get<double>() << " m off, escaped "
       << o["escaped"]["run"].get<double>() << " vs " << o["escaped"]["reference"].get<double>() << ", shape error "
       << o["shape_error"].get<double>() << " m; energy drift " << e["energy"]["drift"].get<double>() << " J (reference "
       << e["energy"]["reference_drift"].get<double>() << " J)\n";
}

void write_report(const std::string& path, const nlohmann::json& report) {
    std::ofstream out(path);
    if (!out) throw OutputError(path + ": cannot open report file for writing");
    out << report.dump(2) << '\n';
    if (!out) throw OutputError(path + ": error while writing the report");
}

}  // namespace parode
