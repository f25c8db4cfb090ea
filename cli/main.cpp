// The `parode` command line: `parode run SCENE ...` (and further subcommands).
// Exit codes: 0 success, 1 simulation failed (NaN, runaway), 2 bad command
// line, 3 bad scene file, 4 cannot write an output file, 5 a [checks]
// criterion of the scene failed. Under mpirun every process runs this; the
// root prints and writes (processes.hpp).
// Trade-off: CLI11 handles parsing and help; each subcommand is a function of
// its own options so new ones do not grow main().
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <iostream>

#include "cli_common.hpp"
#include "processes.hpp"
#include "io/error_metrics.hpp"
#include "run/pipeline.hpp"
#include "register.hpp"
#include "io/report.hpp"
#include "scene/scene_file.hpp"

namespace parode::cli {
namespace {

struct RunArgs {
    std::string scene;
    int steps = -1;
    double duration = -1;
    int threads = 0;
    std::string collide = "ode-hash";
    std::string solver = "ode";
    std::string report;
    std::vector<std::string> sets;
    std::string snapshot;
    int snapshot_every = 0;
    std::string trajectory;
    std::string reference;
    std::string dump;
    int check_every = 0;
    bool quiet = false;
};

class Progress {
public:
    Progress(int total, bool on) : total_(total), on_(on && total > 0) {}
    void update(int done) {
        if (!on_) return;
        const int pct = static_cast<int>(100LL * done / total_);
        if (pct == last_ && done != total_) return;
        last_ = pct;
        const int width = 40, fill = width * done / total_;
        std::fprintf(stderr, "\r[%.*s%*s] %3d%% step %d/%d", fill, "########################################",
                     width - fill, "", pct, done, total_);
        if (done == total_) std::fputc('\n', stderr);
        std::fflush(stderr);
    }

private:
    int total_;
    bool on_;
    int last_ = -1;
};

int step_count(const RunArgs& a, const Scene& scene) {
    if (a.duration >= 0) return static_cast<int>(std::llround(a.duration / scene.dt));
    return a.steps >= 0 ? a.steps : scene.steps;
}

// The `error` block of a run against --reference, and the optional trajectory file.
void add_error(const RunArgs& a, const Pipeline& pipeline, nlohmann::json& report) {
    if (!a.trajectory.empty()) write_trajectory(a.trajectory, *pipeline.trajectory());
    if (a.reference.empty()) return;
    report["error"] = compare_with_reference(*pipeline.trajectory(), a.reference, report);
    report["error"]["reference_file"] = a.reference;
}

int run_command(const RunArgs& a) {
    const Processes& procs = *Processes::current();
    const Scene scene = load_scene(a.scene, a.sets);
    const int steps = step_count(a, scene);
    RunOptions opt;
    opt.collide = a.collide;
    opt.solver = a.solver;
    opt.threads = resolve_threads(a.threads);
    parode::omp::set_threads(opt.threads);
    opt.snapshot_path = a.snapshot;
    opt.snapshot_every = a.snapshot.empty() ? 0 : std::max(1, a.snapshot_every);
    opt.record_trajectory = !a.trajectory.empty() || !a.reference.empty();
    opt.dump_path = a.dump;
    opt.invariants_every = a.check_every;
    const std::unique_ptr<Domain> domain = procs.make_domain(scene);
    opt.domain = domain.get();
    Pipeline pipeline(scene, opt);
    Progress progress(steps, procs.root() && !a.quiet && isatty(STDERR_FILENO));
    const auto t0 = std::chrono::steady_clock::now();
    for (int s = 0; s < steps; ++s) {
        pipeline.step();
        progress.update(s + 1);
    }
    pipeline.finish();
    RunInfo info{a.scene, opt.threads, procs.size(), std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()};
    nlohmann::json report = make_report(scene, pipeline, info);
    if (!procs.root()) return checks_exit_code(report, false);
    add_error(a, pipeline, report);
    if (!a.quiet) print_summary(std::cout, report);
    if (!a.quiet && report.contains("error")) print_error_summary(std::cout, report["error"]);
    if (!a.report.empty()) write_report(a.report, report);
    return checks_exit_code(report);
}

void add_run(CLI::App& app, RunArgs& a, std::function<int()>& action) {
    CLI::App* run = app.add_subcommand("run", "Simulate a scene and report speed and diagnostics");
    run->add_option("scene", a.scene, "Scene file (TOML), e.g. jobs/scenes/tennis.toml")->required();
    run->add_option("--steps", a.steps, "Number of steps (default: the scene's scene.steps)")->check(CLI::NonNegativeNumber);
    run->add_option("--duration", a.duration, "Simulated seconds (steps = duration / dt; overrides --steps)")
        ->check(CLI::NonNegativeNumber);
    run->add_option("--threads", a.threads, "Threads (default: OMP_NUM_THREADS, else 1)")->check(CLI::NonNegativeNumber);
    run->add_option("--collide", a.collide, "Collision backend: " + backend_list())->capture_default_str();
    run->add_option("--solver", a.solver, "Solver: " + solver_list())->capture_default_str();
    run->add_option("--report", a.report, "Write the JSON run report to this file");
    run->add_option("--set", a.sets, "Override a scene value, key=value (e.g. catoms.count=8000); repeatable")
        ->allow_extra_args(false);
    run->add_option("--snapshot", a.snapshot, "Write body poses as CSV to this file");
    run->add_option("--snapshot-every", a.snapshot_every, "Steps between snapshots (default 1 when --snapshot)");
    run->add_option("--trajectory", a.trajectory, "Write body positions at observed steps (a reference for --reference)");
    run->add_option("--reference", a.reference,
                    "Compare with a reference run: its --trajectory file (full error metrics) or its --report JSON "
                    "(final observables only); adds `error` to the report");
    run->add_option("--dump-on-failure", a.dump, "When the guard stops the run, write the last good state (CSV) here");
    run->add_option("--check-invariants", a.check_every,
                    "Steps between checks of the distributed invariants (one owner per body, constant count, ghosts "
                    "equal owners; default 100, every step in debug builds)")
        ->check(CLI::Range(1, 1000000000));
    run->add_flag("--quiet,-q", a.quiet, "No summary table and no progress bar");
    run->callback([&] { action = [&] { return run_command(a); }; });
}

}  // namespace
}  // namespace parode::cli

int main(int argc, char** argv) {
    using namespace parode::cli;
    std::unique_ptr<Processes> procs;
    try {
        procs = std::make_unique<Processes>(argc, argv);
    } catch (const std::exception& e) {
        std::cerr << "parode: " << e.what() << "\n";
        return kExitUsage;
    }
    parode::omp::register_backends();
    CLI::App app{"parode: parallel rigid-body simulation on ODE (see README.md)"};
    app.require_subcommand(1);
    RunArgs run_args;
    BenchArgs bench_args;
    CompareArgs compare_args;
    LatencyArgs latency_args;
    std::function<int()> action;
    add_run(app, run_args, action);
    add_bench(app, bench_args, action);
    add_compare(app, compare_args, action);
    add_latency(app, latency_args, action);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int rc = app.exit(e);
        return rc == 0 ? 0 : kExitUsage;
    }
    return guarded(action);
}
