// Command-line helpers (see cli_common.hpp).
#include "cli_common.hpp"

#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <new>
#include <sstream>

#include "collide/collide.hpp"
#include "run/stages.hpp"
#include "io/error_metrics.hpp"
#include "util/errors.hpp"
#include "processes.hpp"
#include "progress.hpp"
#include "run/memory_estimate.hpp"
#include "run/pipeline.hpp"
#include "scene/scene_file.hpp"
#include "util/launcher.hpp"
#include "util/text.hpp"

namespace parode::cli {

namespace {

// Whole-string integer parse: "12" yes; "12abc", "1.5", "" no.
bool parse_long(const std::string& s, long& out) {
    if (s.empty()) return false;
    errno = 0;
    char* end = nullptr;
    out = std::strtol(s.c_str(), &end, 10);
    return errno == 0 && end == s.c_str() + s.size();
}

}  // namespace

CLI::Validator int_in(long lo, long hi) {
    const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return CLI::Validator(
        [lo, hi, range](std::string& s) -> std::string {
            long v = 0;
            if (parse_long(s, v) && v >= lo && v <= hi) return "";
            return "expected an integer in " + range + ", got '" + s + "'";
        },
        "INT in " + range);
}

CLI::Validator number_in(double lo, double hi) {
    const std::string range = "[" + short_number(lo) + ", " + short_number(hi) + "]";
    return CLI::Validator(
        [lo, hi, range](std::string& s) -> std::string {
            char* end = nullptr;
            errno = 0;
            const double v = std::strtod(s.c_str(), &end);
            const bool whole = !s.empty() && end == s.c_str() + s.size() && errno == 0;
            if (whole && std::isfinite(v) && v >= lo && v <= hi) return "";
            return "expected a number in " + range + ", got '" + s + "'";
        },
        "NUMBER in " + range);
}

namespace {

int parse_threads(const char* name, const char* env) {
    const std::string first = std::string(env).substr(0, std::string(env).find(','));  // "4,2": nested levels
    long n = 0;
    if (!parse_long(first, n) || n < 1 || n > kMaxThreads) {
        throw std::invalid_argument(std::string(name) + "=" + env + ": expected an integer in [1, " +
                                    std::to_string(kMaxThreads) + "] (or pass --threads)");
    }
    return static_cast<int>(n);
}

Threads affinity_threads() {
    cpu_set_t set;
    CPU_ZERO(&set);
    if (sched_getaffinity(0, sizeof set, &set) != 0) return {1, "one core (the affinity mask could not be read)"};
    const int mine = std::max(1, CPU_COUNT(&set));
    const long online = sysconf(_SC_NPROCESSORS_ONLN);
    const int ranks = launcher::local_size();
    if (ranks > 1 && mine >= online) {
        return {std::max(1, mine / ranks), "the node's " + std::to_string(mine) + " cores shared by its " +
                                               std::to_string(ranks) + " ranks"};
    }
    return {std::min(mine, kMaxThreads), "the " + std::to_string(mine) + " cores of the affinity mask"};
}

}  // namespace

Threads resolve_threads(int requested, int scene_threads) {
    if (requested > 0) return {requested, "--threads"};
    if (scene_threads > 0) return {scene_threads, "the scene's [run] threads"};
    if (const char* env = std::getenv("OMP_NUM_THREADS"); env && *env) {
        return {parse_threads("OMP_NUM_THREADS", env), "OMP_NUM_THREADS"};
    }
    if (const char* env = std::getenv("SLURM_CPUS_PER_TASK"); env && *env) {
        return {parse_threads("SLURM_CPUS_PER_TASK", env), "SLURM_CPUS_PER_TASK"};
    }
    return affinity_threads();
}

std::string resolve_backend(const std::string& flag, const std::string& from_scene, const std::string& where,
                            const std::vector<std::string>& known, const char* fallback) {
    if (!flag.empty()) return flag;
    if (from_scene.empty()) return fallback;
    if (std::find(known.begin(), known.end(), from_scene) == known.end()) {
        std::string list;
        for (const auto& k : known) list += (list.empty() ? "\"" : ", \"") + k + "\"";
        throw SceneError(where + ": expected one of " + list + ", got \"" + from_scene + "\"");
    }
    return from_scene;
}

std::string backend_list() { return Stages::instance().collide.listing(); }

std::string solver_list() { return Stages::instance().solver.listing(); }

ExecutionConfig execution_config(const Threads& threads) {
    ExecutionConfig c;
    c.threads = threads.count;
    c.threads_from = threads.source;
    // PARODE_MIN_PARALLEL=N: stages run threaded from N items on, whatever
    // their crossover and however long threads wait (jobs/crossover.py
    // measures the crossovers with it).
    if (const char* env = std::getenv("PARODE_MIN_PARALLEL"); env && *env) {
        long n = 0;
        if (!parse_long(env, n) || n < 0) {
            throw std::invalid_argument(std::string("PARODE_MIN_PARALLEL=") + env +
                                        ": expected a whole number of items, 0 or more");
        }
        c.min_parallel = n;
        c.adaptive = false;
    }
    return c;
}

void check_output_path(const std::string& option, const std::string& path) {
    if (path.empty()) return;
    namespace fs = std::filesystem;
    const auto fail = [&](const std::string& why) {
        throw OutputError(option + " " + path + ": cannot write there: " + why);
    };
    std::error_code ec;
    const fs::path p(path);
    if (fs::is_directory(p, ec)) fail("it is a directory");
    const fs::path dir = p.has_parent_path() ? p.parent_path() : fs::path(".");
    if (!fs::exists(dir, ec)) fail("the directory " + dir.string() + " does not exist");
    if (!fs::is_directory(dir, ec)) fail(dir.string() + " is not a directory");
    const bool existed = fs::exists(p, ec);
    {
        std::ofstream probe(path, std::ios::app);  // appends nothing to an existing file
        if (!probe) fail(std::strerror(errno));
    }
    if (!existed) fs::remove(p, ec);
}

std::pair<std::string, int> split_threads(const std::string& spec) {
    const auto colon = spec.find(':');
    if (colon == std::string::npos) return {spec, 1};
    long n = 0;
    if (!parse_long(spec.substr(colon + 1), n) || n < 1 || n > kMaxThreads) {
        throw std::invalid_argument("--backends " + spec + ": expected NAME:THREADS with THREADS an integer in [1, " +
                                    std::to_string(kMaxThreads) + "]");
    }
    return {spec.substr(0, colon), static_cast<int>(n)};
}

BeforeCatoms memory_guard(std::function<RunShape(const Scene&)> shape_of) {
    return [shape_of](const Scene& so_far, const CatomPlan& catoms) {
        require_memory(estimate_memory(scene_size(so_far, catoms), shape_of(so_far)), available_memory());
    };
}

namespace {

// A collective failure (every process meets it at the same point: a scene
// error, the guard, a bad option) is reported by the root, and every process
// returns its code. Any other may be this process's alone: it reports with
// its rank and ends every process, so none waits forever for it.
int report_failure(int code, const std::string& message, bool collective = true) {
    const Processes* procs = Processes::current();
    const bool many = procs && procs->size() > 1;
    if (!many || !collective || procs->root()) {
        end_progress_line();
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
        return report_failure(kExitScene, std::string("scene error: ") + e.what());
    } catch (const SimulationError& e) {
        return report_failure(kExitSimulation, std::string("simulation failed: ") + e.what());
    } catch (const CheckpointError& e) {
        return report_failure(kExitCheckpoint, std::string("cannot restart: ") + e.what());
    } catch (const ProgramError& e) {
        return report_failure(kExitProgram, std::string("catom program failed: ") + e.what());
    } catch (const OutputError& e) {
        return report_failure(kExitOutput, std::string("cannot write output: ") + e.what(), false);
    } catch (const MemoryError& e) {
        return report_failure(kExitMemory, std::string("not enough memory: ") + e.what(), false);
    } catch (const std::bad_alloc&) {
        return report_failure(kExitMemory, "out of memory: an allocation failed (std::bad_alloc); the run needs "
                                           "more memory than this machine gives it: use fewer catoms or a larger "
                                           "machine",
                              false);
    } catch (const std::invalid_argument& e) {
        return report_failure(kExitUsage, e.what());
    } catch (const std::exception& e) {
        return report_failure(kExitInternal,
                              std::string("internal error (a bug in parode; please report it with the command line): ") +
                                  e.what(),
                              false);
    } catch (...) {
        return report_failure(kExitInternal, "internal error (a bug in parode): an exception of unknown type", false);
    }
}

void write_json(const std::string& path, const nlohmann::json& j) {
    std::ofstream out(path);
    out << j.dump(2) << '\n';
    if (!out) throw OutputError(path + ": cannot write");
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

double end_time(const nlohmann::json& r) {
    if (r.contains("time")) return r.at("time").get<double>();
    return r.at("steps").get<double>() * r.at("dt").get<double>();
}

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
    try {
        return compare_reports(run_report, ref, path);
    } catch (const nlohmann::json::exception& e) {
        throw std::invalid_argument(path + ": not a complete parode run report (" + e.what() + ")");
    }
}

}  // namespace parode::cli
