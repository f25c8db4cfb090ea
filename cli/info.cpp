// `parode info SCENE`: what a run of the scene would be, before running it:
// bodies and geoms, the stages that will run and why (run/stage_plan), the
// memory estimate per rank (run/memory_estimate), the cell edge and the ghost
// halo with the occupied cells (domain/cell_census), whether the scene can be
// distributed and why not (domain/distribution), and for --ranks R an
// estimate of the bodies and ghosts per rank. Printed, and as JSON with --json.
// Trade-off: nothing of ODE is built (the catoms are never generated, the
// backends are made but never given a space), so it answers in a fraction of
// a second at 10^8 catoms; the price is estimates (memory, ghosts) where a
// run would measure.
#include <iomanip>
#include <iostream>
#include <sstream>

#include "cli_common.hpp"
#include "collide/collide.hpp"
#include "domain/cell_census.hpp"
#include "domain/distribution.hpp"
#include "processes.hpp"
#include "run/memory_estimate.hpp"
#include "run/stage_plan.hpp"
#include "run/stages.hpp"
#include "solve/solver.hpp"

namespace parode::cli {
namespace {

nlohmann::json sizes(const Scene& sc) {
    const std::size_t bodies = sc.body_count(), geoms = bodies + sc.statics.size() + sc.planes.size();
    nlohmann::json j = {{"bodies", bodies}, {"catoms", sc.catom_count()}, {"listed_bodies", sc.bodies.size()},
                        {"magnet_bodies", sc.any_magnets() ? sc.magnet_count() : 0}, {"joints", sc.joints.size()},
                        {"geoms", geoms}, {"statics", sc.statics.size()}, {"planes", sc.planes.size()}};
    if (sc.catoms.count > 0) j["prism"] = {sc.catoms.dims[0], sc.catoms.dims[1], sc.catoms.dims[2]};
    return j;
}

nlohmann::json stages_json(const Scene& sc, const InfoArgs& a, int threads, const DistributionVerdict& v, double edge) {
    ExecutionConfig config;
    config.threads = threads;
    const auto exec = Stages::instance().execution(config);
    const auto backend = Stages::instance().collide.make(a.collide, *exec);
    const auto solver = Stages::instance().solver.make(a.solver, sc, *exec);
    const bool distributed = a.ranks > 1 && v.ok;
    StagePlanInput in{distributed, distributed ? distributed_why(a.ranks, edge) : Decomposition().why(),
                      backend->name(), solver->uses_contact_joints(), solver->name(), solver->why(), "", 0};
    const auto plan = stage_plan(sc, in);
    nlohmann::json j;
    for (int k = 0; k < kStageCount; ++k) {
        j[stage_name(static_cast<Stage>(k))] = {{"runs", plan[static_cast<std::size_t>(k)].enabled},
                                                {"why", plan[static_cast<std::size_t>(k)].reason}};
    }
    return j;
}

nlohmann::json memory_json(const Scene& sc, const InfoArgs& a, long steps) {
    RunShape shape;
    shape.collide = a.collide;
    shape.steps = steps;
    shape.observe_every = sc.observe_every;
    const MemoryEstimate e = estimate_memory(sc, shape, a.ranks);
    const MemoryAvailable have = available_memory();
    return {{"bytes_per_rank", e.bytes_per_rank}, {"bytes", e.bytes}, {"detail", e.detail},
            {"available_here_bytes", have.bytes}, {"available_here_source", have.source},
            {"fits_here", e.bytes_per_rank <= have.bytes}};
}

nlohmann::json cells_json(const CellStats& s) {
    return {{"edge", s.edge}, {"r_max", s.r_max}, {"halo", s.halo}, {"occupied", s.occupied},
            {"bodies_per_cell", {{"mean", s.mean_bodies}, {"max", s.max_bodies}}}};
}

nlohmann::json distributed_json(const CellCensus& census, const InfoArgs& a, const DistributionVerdict& v) {
    nlohmann::json j = {{"possible", v.ok}, {"reason", v.reason}, {"ranks", a.ranks}};
    if (a.ranks < 2 || !v.ok) return j;
    const GhostEstimate g = census.ghosts(a.ranks);
    j["estimate"] = {{"bodies_per_rank_max", g.bodies_max},
                     {"ghosts_per_rank", {{"mean", g.ghosts_mean}, {"max", g.ghosts_max}}},
                     {"ghost_fraction", g.fraction},
                     {"method", "ideal planar cuts of the occupied cells' box into blocks of equal bodies (a lower bound: the "
                                "partitions of the tennis prism, 64,000 and 10^6 catoms on 2 and 4 ranks, made 1.05 to 1.10 times these ghosts)"}};
    return j;
}

nlohmann::json info_json(const InfoArgs& given) {
    const Scene sc = load_scene(given.scene, given.sets);
    InfoArgs a = given;  // with the backends `parode run` would choose
    a.collide = resolve_backend(a.collide, sc.run.collide, sc.run.collide_where, Stages::instance().collide.accepted(),
                                kDefaultCollide);
    a.solver = resolve_backend(a.solver, sc.run.solver, sc.run.solver_where, Stages::instance().solver.accepted(),
                               kDefaultSolver);
    const int threads = resolve_threads(a.threads, sc.run.threads).count;
    const long steps = a.steps >= 0 ? a.steps : sc.steps;
    const CellCensus census(sc);
    const CellStats cells = census.stats();
    const DistributionVerdict v = distribution_verdict(sc, a.solver, std::max(2, a.ranks), cells.edge);
    nlohmann::json j = {{"scene", sc.name}, {"scene_file", a.scene}, {"seed", sc.seed}, {"steps", steps}, {"dt", sc.dt}};
    j.update(sizes(sc));
    j["run"] = {{"collide", a.collide}, {"solver", a.solver}, {"threads", threads}, {"ranks", a.ranks}};
    j["stages"] = stages_json(sc, a, threads, v, cells.edge);
    j["memory"] = memory_json(sc, a, steps);
    j["cells"] = cells_json(cells);
    j["distributed"] = distributed_json(census, a, v);
    return j;
}

std::string num(double x, int precision = 3) {
    std::ostringstream os;
    os << std::setprecision(precision) << x;
    return os.str();
}

void print_bodies(std::ostream& os, const nlohmann::json& j) {
    os << "bodies       " << j["bodies"] << " (" << j["catoms"] << " catoms";
    if (j.contains("prism")) os << ", prism " << j["prism"][0] << " x " << j["prism"][1] << " x " << j["prism"][2];
    os << "; " << j["listed_bodies"] << " [[bodies]]; " << j["magnet_bodies"] << " with magnets on; " << j["joints"]
       << " joints)\n";
    os << "geoms        " << j["geoms"] << " (" << j["bodies"] << " bodies, " << j["statics"] << " statics, "
       << j["planes"] << " planes)\n";
}

void print_stages(std::ostream& os, const nlohmann::json& j) {
    const auto& r = j["run"];
    os << "run          collide " << r["collide"].get<std::string>() << ", solver " << r["solver"].get<std::string>()
       << ", " << r["threads"] << " thread(s), " << r["ranks"] << " rank(s), " << j["steps"] << " steps\n";
    os << "stages\n";
    for (int k = 0; k < kStageCount; ++k) {
        const std::string name = stage_name(static_cast<Stage>(k));
        const auto& s = j["stages"][name];
        os << "  " << std::left << std::setw(9) << name << std::setw(4) << (s["runs"].get<bool>() ? "yes" : "no")
           << std::right << s["why"].get<std::string>() << "\n";
    }
}

void print_memory_and_cells(std::ostream& os, const nlohmann::json& j) {
    const auto& m = j["memory"];
    os << "memory       about " << format_bytes(m["bytes_per_rank"].get<double>()) << " per rank, "
       << format_bytes(m["bytes"].get<double>()) << " in all (" << m["detail"].get<std::string>() << "); this machine has "
       << format_bytes(m["available_here_bytes"].get<double>()) << "\n";
    const auto& c = j["cells"];
    os << "cells        edge " << num(c["edge"].get<double>()) << " m = 4 r_max (r_max " << num(c["r_max"].get<double>())
       << " m); " << c["occupied"] << " occupied at the start, " << num(c["bodies_per_cell"]["mean"].get<double>())
       << " bodies per cell (at most " << c["bodies_per_cell"]["max"] << ")\n";
    os << "halo         " << num(c["halo"].get<double>()) << " m (how far a body's contact, magnet and message partners "
       << "lie): a rank holds ghost copies of the bodies within it of its cells, along every axis\n";
}

void print_distributed(std::ostream& os, const nlohmann::json& j) {
    const auto& d = j["distributed"];
    if (!d["possible"].get<bool>()) {
        os << "distributed  no: " << d["reason"].get<std::string>() << "\n";
        return;
    }
    os << "distributed  yes";
    if (d.contains("estimate")) {
        const auto& e = d["estimate"];
        os << ": on " << d["ranks"] << " ranks about " << num(e["bodies_per_rank_max"].get<double>())
           << " bodies on the fullest rank and " << num(e["ghosts_per_rank"]["mean"].get<double>()) << " ghosts per rank"
           << " (at most " << num(e["ghosts_per_rank"]["max"].get<double>()) << "), ghost fraction "
           << num(e["ghost_fraction"].get<double>()) << "\n             (estimate from " << e["method"].get<std::string>()
           << ")";
    }
    os << "\n";
}

int info_command(const InfoArgs& a) {
    const Processes* procs = Processes::current();
    const bool root = !procs || procs->root();
    if (root) check_output_path("--json", a.json);
    const nlohmann::json j = info_json(a);
    if (!root) return 0;
    if (!a.quiet) {
        std::cout << j["scene"].get<std::string>() << " (" << a.scene << "): " << j["steps"] << " steps of "
                  << j["dt"] << " s, seed " << j["seed"] << "\n";
        print_bodies(std::cout, j);
        print_stages(std::cout, j);
        print_memory_and_cells(std::cout, j);
        print_distributed(std::cout, j);
    }
    if (!a.json.empty()) write_json(a.json, j);
    return 0;
}

}  // namespace

void add_info(CLI::App& app, InfoArgs& a, std::function<int()>& action) {
    CLI::App* info = app.add_subcommand("info", "What a run of a scene would be: sizes, stages, memory, cells, distribution");
    info->add_option("scene", a.scene, "Scene file (TOML)")->required();
    info->add_option("--set", a.sets, "Override a scene value, key=value; repeatable")->allow_extra_args(false);
    info->add_option("--collide", a.collide, "Collision backend: " + backend_list())
        ->check(CLI::IsMember(Stages::instance().collide.accepted()))->capture_default_str();
    info->add_option("--solver", a.solver, "Solver: " + solver_list())
        ->check(CLI::IsMember(Stages::instance().solver.accepted()))->capture_default_str();
    info->add_option("--threads", a.threads, "Threads (default: OMP_NUM_THREADS, else 1)")->check(int_in(1, kMaxThreads));
    info->add_option("--ranks", a.ranks, "MPI processes of the run to describe")->check(int_in(1, 1000000))
        ->capture_default_str();
    info->add_option("--steps", a.steps, "Steps (default: the scene's scene.steps)")->check(int_in(0, kMaxSteps));
    info->add_option("--json", a.json, "Also write the figures as JSON to this file");
    info->add_flag("--quiet,-q", a.quiet, "Print nothing (with --json)");
    info->callback([&] { action = [&] { return info_command(a); }; });
}

}  // namespace parode::cli
