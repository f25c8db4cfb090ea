// Shared pieces of the command line: exit codes, thread resolution, the error
// guard that turns exceptions into messages and exit codes, and subcommands
// defined in their own files.
// Trade-off: exceptions carry the message; only this guard decides exit codes.
#pragma once
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <functional>
#include <string>

#include "io/trajectory.hpp"

namespace parode::cli {

constexpr int kExitSimulation = 1;
constexpr int kExitUsage = 2;
constexpr int kExitScene = 3;
constexpr int kExitOutput = 4;
constexpr int kExitChecks = 5;

int resolve_threads(int requested);  // 0 -> OMP_NUM_THREADS or 1
std::string backend_list();
std::string solver_list();
int guarded(const std::function<int()>& action);
// kExitChecks when the report's [checks] verdict is a failure (printed when
// `print`), else 0.
int checks_exit_code(const nlohmann::json& report, bool print = true);
// The `error` block of `run` against `reference_path`: a trajectory file, or a
// run report (final observables only). Throws std::runtime_error naming the file.
nlohmann::json compare_with_reference(const parode::Trajectory& run, const std::string& reference_path,
                                      const nlohmann::json& run_report);

struct BenchArgs {
    std::string what;
    std::string scene;
    std::vector<std::string> sets;
    std::vector<std::string> backends;
    int steps = 0;
    int every = 50;
    int repeats = 5;
    int reference_iterations = 0;  // bench step: reference pipeline, 0 = none
    int error_at = 50;             // bench step: steps before the RMS error
    std::string csv;
};
void add_bench(CLI::App& app, BenchArgs& a, std::function<int()>& action);
int bench_step(const BenchArgs& a);

struct CompareArgs {
    std::string run;
    std::string reference;
    std::string report;
    std::vector<long> horizons{10, 50, 200};
    bool quiet = false;
};
void add_compare(CLI::App& app, CompareArgs& a, std::function<int()>& action);

struct LatencyArgs {
    int rounds = 20000;
    std::string json;
};
void add_latency(CLI::App& app, LatencyArgs& a, std::function<int()>& action);
// Writes a JSON document; throws std::runtime_error naming the file.
void write_json(const std::string& path, const nlohmann::json& j);

}  // namespace parode::cli
