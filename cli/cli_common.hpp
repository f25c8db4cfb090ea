// Shared pieces of the command line: exit codes, validators, thread and output
// path checks, the error guard that turns exceptions into messages and exit
// codes, and subcommands defined in their own files.
// Trade-off: exceptions carry the message and their type carries the exit
// code; only the guard maps one to the other, so no command prints its own
// failures or picks its own code.
#pragma once
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <functional>
#include <string>

#include "exec/execution.hpp"
#include "io/trajectory.hpp"
#include "run/memory_estimate.hpp"
#include "scene/scene_file.hpp"

namespace parode::cli {

// Exit codes (README "Exit codes"; the same list opens main.cpp).
constexpr int kExitSimulation = 1;    // SimulationError: the guard stopped the run
constexpr int kExitUsage = 2;         // CLI11 parse errors, std::invalid_argument
constexpr int kExitScene = 3;         // SceneError
constexpr int kExitOutput = 4;        // OutputError
constexpr int kExitChecks = 5;        // a [checks] criterion failed
constexpr int kExitMemory = 6;        // MemoryError (refused by the estimate), std::bad_alloc
constexpr int kExitInterrupted = 7;   // SIGTERM / SIGINT: checkpoint written, report marked interrupted
constexpr int kExitCheckpoint = 8;    // CheckpointError: the --restart checkpoint is damaged
constexpr int kExitProgram = 9;       // ProgramError: a catom program failed
constexpr int kExitInternal = 70;     // any other exception: a bug

constexpr int kMaxThreads = 1024;
constexpr long kMaxSteps = 1000000000;

// CLI11 validators that say what they expect: "--steps: expected an integer in
// [0, 1000000000], got '-5'".
CLI::Validator int_in(long lo, long hi);
CLI::Validator number_in(double lo, double hi);

// --threads if given (1..kMaxThreads), else OMP_NUM_THREADS (same range, else
// std::invalid_argument), else 1. 0 means "not given".
// Threads of a run and where the number came from: `requested` (> 0), else
// the scene's [run] threads (> 0), else OMP_NUM_THREADS, else Slurm's CPUs per
// task, else the cores of the process's affinity mask (shared among the MPI
// ranks of the node when every rank sees the whole node).
struct Threads {
    int count = 1;
    std::string source;
};
Threads resolve_threads(int requested, int scene_threads = 0);
// The collide backend and solver of a run: the command line's, else the
// scene's [run] table's (checked: a SceneError names the file, line and key),
// else the fastest defaults (kDefaultCollide, kDefaultSolver).
inline const char* kDefaultCollide = "grid";
inline const char* kDefaultSolver = "parallel";
std::string resolve_backend(const std::string& flag, const std::string& from_scene, const std::string& where,
                            const std::vector<std::string>& known, const char* fallback);
std::string backend_list();
std::string solver_list();
// The execution context of a run on `threads` (and PARODE_MIN_PARALLEL, a
// testing aid read here only: every loop threaded from that many items).
ExecutionConfig execution_config(const Threads& threads);

// Fails (OutputError naming the option and the path) unless `path` can be
// written: not a directory, its directory exists, a file can be opened there.
// Creates nothing: a probe file it had to create is removed. Empty: no check.
void check_output_path(const std::string& option, const std::string& path);

// A load_scene hook that refuses (MemoryError) a scene whose run, as
// `shape_of` describes it from the scene read so far, would not fit in memory.
BeforeCatoms memory_guard(std::function<RunShape(const Scene&)> shape_of);

int guarded(const std::function<int()>& action);
// kExitChecks when the report's [checks] verdict is a failure (printed when
// `print`), else 0.
int checks_exit_code(const nlohmann::json& report, bool print = true);
// The `error` block of `run` against `reference_path`: a trajectory file, or a
// run report (final observables only). Throws std::invalid_argument naming the file.
nlohmann::json compare_with_reference(const parode::Trajectory& run, const std::string& reference_path,
                                      const nlohmann::json& run_report);

// ODE's error and debug handlers: print ODE's message and exit with
// kExitSimulation instead of aborting (ode_handlers.cpp).
void install_ode_handlers();

// `parode --version`: version, commit, ODE, OpenMP and MPI.
std::string version_text();

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
// The bench's scene, after checking --csv and the variants' thread counts,
// refused when `pipelines` worlds of it would not fit in memory.
Scene load_bench_scene(const BenchArgs& a, int pipelines);
// "name:threads" -> {name, threads}; threads 1 when absent. Throws
// std::invalid_argument naming the spec unless threads is in 1..kMaxThreads.
std::pair<std::string, int> split_threads(const std::string& spec);

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

struct MemoryArgs {
    int mb = 256;
    int threads = 0;  // 0: OpenMP's maximum
    std::string json;
};
void add_memory(CLI::App& app, MemoryArgs& a, std::function<int()>& action);
struct InfoArgs {
    std::string scene;
    std::vector<std::string> sets;
    std::string collide;  // empty: the scene's [run], else the default (as `parode run`)
    std::string solver;
    int threads = 0;  // 0: not given
    int ranks = 1;
    long steps = -1;  // -1: the scene's
    std::string json;
    bool quiet = false;
};
void add_info(CLI::App& app, InfoArgs& a, std::function<int()>& action);

struct KeysArgs {
    std::string json;
};
void add_keys(CLI::App& app, KeysArgs& a, std::function<int()>& action);

// Writes a JSON document; throws std::runtime_error naming the file.
void write_json(const std::string& path, const nlohmann::json& j);

}  // namespace parode::cli
