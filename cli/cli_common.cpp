// Command-line helpers (see cli_common.hpp).
#include "cli_common.hpp"
#include "processes.hpp"

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <iostream>

#include "collide/collide.hpp"
#include "io/error_metrics.hpp"
#include "run/pipeline.hpp"
#include "scene/scene_file.hpp"

namespace parode::cli {

int resolve_threads(int requested) {
    if (requested > 0) return requested;
    if (const char* env = std::getenv("OMP_NUM_THREADS")) {
        const int n = std::atoi(env);
        if (n > 0) return n;
    }
    return 1;
}

std::string backend_list() {
    std::string out;
    for (const auto& n : BackendRegistry::instance().names()) out += (out.empty() ? "" : ", ") + n;
    return out;
}

std::string solver_list() {
    std::string out;
    for (const auto& n : SolverRegistry::instance().names()) out += (out.empty() ? "" : ", ") + n;
    return out;
}

namespace {

// Every process meets a collective failure at the same point: the root
// reports it and all return its code. Any other failure may be this
// process's alone: it reports and ends every process.
int fail(int code, const std::string& message, bool collective) {
    const Processes* procs = Processes::current();
    const bool many = procs && procs->size() > 1;
    if (!many || !collective || procs->root()) {
        std::cerr << "parode: " << (many && !collective ? "rank " + std::to_string(procs->rank()) + ": " : "") << message
                  << "\n";
    }
    if (many && !collective) procs->abort(code);
    return code;
}

}  // namespace

int guarded(const std::function<int()>& action) {
    try {
        return action ? action() : 0;
    } catch (const SceneError& e) {
        return fail(kExitScene, std::string("scene error: ") + e.what(), true);
    } catch (const SimulationError& e) {
        return fail(kExitSimulation, std::string("simulation failed: ") + e.what(), true);
    } catch (const std::invalid_argument& e) {
        return fail(kExitUsage, e.what(), true);
    } catch (const std::exception& e) {
        return fail(kExitOutput, e.what(), false);
    }
}

void write_json(const std::string& path, const nlohmann::json& j) {
    std::ofstream out(path);
    out << j.dump(2) << '\n';
    if (!out) throw std::runtime_error(path + ": cannot write");
}

int checks_exit_code(const nlohmann::json& report, bool print) {
    if (!report.contains("checks") || report["checks"]["passed"].get<bool>()) return 0;
    if (!print) return kExitChecks;
    std::cerr << "parode: checks failed:";
    for (const auto& i : report["checks"]["items"]) {
        if (i["passed"].get<bool>()) continue;
        std::cerr << " " << i["name"].get<std::string>() << " = " << i["value"].get<double>() << " (bound "
                  << i["bound"].get<double>() << ");";
    }
    std::cerr << "\n";
    return kExitChecks;
}

namespace {

nlohmann::json read_json_report(const std::string& path) {
    std::ifstream in(path);
    if (!in) throw std::invalid_argument(path + ": cannot open the reference");
    try {
        return nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception&) {
        throw std::invalid_argument(path + ": the reference is neither a parode trajectory (--trajectory) "
                                    "nor a JSON run report (--report)");
    }
}

double end_time(const nlohmann::json& r) { return r.at("steps").get<double>() * r.at("dt").get<double>(); }

// Final observables of two run reports that end at the same simulated time.
nlohmann::json compare_reports(const nlohmann::json& run, const nlohmann::json& ref, const std::string& path) {
    const double t = end_time(run), tr = end_time(ref);
    if (std::fabs(t - tr) > 1e-6 * std::min(run["dt"].get<double>(), ref["dt"].get<double>())) {
        throw std::invalid_argument(path + ": the reference ends at t = " + std::to_string(tr) + " s, the run at " +
                                    std::to_string(t) + " s");
    }
    const auto& a = run["diagnostics"];
    const auto& b = ref["diagnostics"];
    auto obs = [](double x, double y) { return nlohmann::json{{"run", x}, {"reference", y}, {"diff", x - y}}; };
    const double ea = a["energy"]["total"].get<double>(), eb = b["energy"]["total"].get<double>();
    return {{"reference", {{"scene", ref["scene"]}, {"dt", ref["dt"]}, {"steps", ref["steps"]}, {"solver", ref["solver"]}}},
            {"final_only", true},
            {"time", t},
            {"state_hash_equal", run["state_hash"] == ref["state_hash"]},
            {"penetration", {{"max", a["max_penetration"]}, {"mean", a["mean_penetration"]},
                             {"reference_max", b["max_penetration"]}, {"reference_mean", b["mean_penetration"]}}},
            {"energy", {{"final", ea}, {"reference_final", eb}, {"final_diff", ea - eb}}},
            {"observables", {{"com_height", obs(a["com_height"].get<double>(), b["com_height"].get<double>())}}}};
}

}  // namespace

nlohmann::json compare_with_reference(const parode::Trajectory& run, const std::string& path,
                                      const nlohmann::json& run_report) {
    if (is_trajectory_file(path)) {
        try {
            return compare_trajectories(run, read_trajectory(path));
        } catch (const std::runtime_error& e) {
            throw std::invalid_argument(path + ": " + e.what());
        }
    }
    const nlohmann::json ref = read_json_report(path);
    if (!ref.contains("diagnostics") || !ref.contains("steps")) {
        throw std::invalid_argument(path + ": a JSON file but not a parode run report (no 'diagnostics')");
    }
    return compare_reports(run_report, ref, path);
}

}  // namespace parode::cli
