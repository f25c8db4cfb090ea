// The `parode` command line: `parode run SCENE ...` (and further subcommands).
// Exit codes: 0 success, 1 simulation failed (NaN, runaway), 2 bad command
// line, 3 bad scene file, 4 cannot write an output file.
// Trade-off: CLI11 handles parsing and help; each subcommand is a function of
// its own options so new ones do not grow main().
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <iostream>

#include "cli_common.hpp"
#include "pipeline.hpp"
#include "register.hpp"
#include "report.hpp"
#include "scene_file.hpp"

namespace parode::cli {
namespace {

struct RunArgs {
    std::string scene;
    int steps = -1;
    int threads = 0;
    std::string collide = "ode-hash";
    std::string report;
    std::vector<std::string> sets;
    std::string snapshot;
    int snapshot_every = 0;
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

int run_command(const RunArgs& a) {
    const Scene scene = load_scene(a.scene, a.sets);
    const int steps = a.steps >= 0 ? a.steps : scene.steps;
    RunOptions opt;
    opt.collide = a.collide;
    opt.threads = resolve_threads(a.threads);
    parode::omp::set_threads(opt.threads);
    opt.snapshot_path = a.snapshot;
    opt.snapshot_every = a.snapshot.empty() ? 0 : std::max(1, a.snapshot_every);
    Pipeline pipeline(scene, opt);
    Progress progress(steps, !a.quiet && isatty(STDERR_FILENO));
    const auto t0 = std::chrono::steady_clock::now();
    for (int s = 0; s < steps; ++s) {
        pipeline.step();
        progress.update(s + 1);
    }
    pipeline.finish();
    RunInfo info{a.scene, opt.threads, 1, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()};
    const nlohmann::json report = make_report(scene, pipeline, info);
    if (!a.quiet) print_summary(std::cout, report);
    if (!a.report.empty()) write_report(a.report, report);
    return 0;
}

void add_run(CLI::App& app, RunArgs& a, std::function<int()>& action) {
    CLI::App* run = app.add_subcommand("run", "Simulate a scene and report speed and diagnostics");
    run->add_option("scene", a.scene, "Scene file (TOML), e.g. jobs/scenes/tennis.toml")->required();
    run->add_option("--steps", a.steps, "Number of steps (default: the scene's scene.steps)")->check(CLI::NonNegativeNumber);
    run->add_option("--threads", a.threads, "Threads (default: OMP_NUM_THREADS, else 1)")->check(CLI::NonNegativeNumber);
    run->add_option("--collide", a.collide, "Collision backend: " + backend_list())->capture_default_str();
    run->add_option("--report", a.report, "Write the JSON run report to this file");
    run->add_option("--set", a.sets, "Override a scene value, key=value (e.g. catoms.count=8000); repeatable")
        ->allow_extra_args(false);
    run->add_option("--snapshot", a.snapshot, "Write body poses as CSV to this file");
    run->add_option("--snapshot-every", a.snapshot_every, "Steps between snapshots (default 1 when --snapshot)");
    run->add_flag("--quiet,-q", a.quiet, "No summary table and no progress bar");
    run->callback([&] { action = [&] { return run_command(a); }; });
}

}  // namespace
}  // namespace parode::cli

int main(int argc, char** argv) {
    using namespace parode::cli;
    parode::omp::register_backends();
    CLI::App app{"parode: parallel rigid-body simulation on ODE (see README.md)"};
    app.require_subcommand(1);
    RunArgs run_args;
    BenchArgs bench_args;
    std::function<int()> action;
    add_run(app, run_args, action);
    add_bench(app, bench_args, action);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        const int rc = app.exit(e);
        return rc == 0 ? 0 : kExitUsage;
    }
    return guarded(action);
}
