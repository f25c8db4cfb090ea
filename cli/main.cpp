// The `parode` command line: `parode run SCENE ...`, `parode info SCENE ...`,
// `parode bench ...`, `parode compare ...`, `parode latency`, `parode memory`, `parode keys`,
// `parode --version`.
// Under mpirun every process runs this; the root prints and writes (processes.hpp).
// Exit codes (README "Exit codes"):
//   0  success
//   1  the simulation failed: the guard stopped it (NaN, runaway energy or speed)
//   2  bad command line (unknown option, value out of range, unreadable --reference)
//   3  bad scene file (file, line, key and what was expected)
//   4  an output file cannot be written (checked before the run starts)
//   5  a [checks] criterion of the scene failed
//   6  not enough memory: the estimate exceeds what the machine has, or an
//      allocation failed
//   7  interrupted by SIGTERM or SIGINT: the step finished, a checkpoint and the
//      report (marked "interrupted") were written
//   8  the --restart checkpoint cannot be used (a checksum differs, it is
//      truncated, or it is no parode checkpoint): nothing was run
//   70 internal error: any other exception, a bug (the message says what)
// Trade-off: CLI11 handles parsing, validation and help; each subcommand is a
// function of its own options so new ones do not grow main().
#include <CLI/CLI.hpp>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <sstream>

#include "cli_common.hpp"
#include "util/huge_pages.hpp"
#include "interrupts.hpp"
#include "processes.hpp"
#include "io/error_metrics.hpp"
#include "run/report.hpp"
#include "io/snapshot.hpp"
#include "io/xdmf.hpp"
#include "progress.hpp"
#include "omp/stages.hpp"
#include "run/stages.hpp"
#ifdef PARODE_HAVE_MPI
#include "mpi/stages.hpp"
#endif
#include "run/pipeline.hpp"
#include "scene/scene_file.hpp"

namespace parode::cli {
namespace {

struct RunArgs {
    std::string scene;
    long steps = -1;
    double duration = -1;
    int threads = 0;  // 0: not given
    std::string collide;  // empty: the scene's [run], else the fastest default
    std::string solver;
    std::string report;
    std::vector<std::string> sets;
    std::string program;  // empty: the scene's [program], if any
    std::string snapshot;
    long snapshot_every = 1;
    std::string trajectory;
    std::string reference;
    std::string dump;
    int check_every = 0;
    std::string checkpoint;
    long checkpoint_every = 0;
    std::string restart;
    bool quiet = false;
};

long step_count(const RunArgs& a, const Scene& scene) {
    if (a.duration < 0) return a.steps >= 0 ? a.steps : scene.steps;
    const double steps = std::round(a.duration / scene.dt);
    if (steps > kMaxSteps) {
        std::ostringstream os;
        os << "--duration " << a.duration << " s at dt = " << scene.dt << " s is more than " << kMaxSteps << " steps";
        throw std::invalid_argument(os.str());
    }
    return static_cast<long>(steps);
}

// Every process decides alike, so all of them stop together.
void check_snapshot_format(const RunArgs& a) {
    if (is_h5md_path(a.snapshot) && hdf5_version().empty()) {
        throw std::invalid_argument("--snapshot " + a.snapshot + ": this parode was built without HDF5 and cannot "
                                    "write H5MD; name a .csv file, or install HDF5 (jobs/setup.sh) and rebuild");
    }
}

void check_outputs(const RunArgs& a) {
    check_output_path("--report", a.report);
    check_output_path("--trajectory", a.trajectory);
    check_output_path("--snapshot", a.snapshot);
    if (is_h5md_path(a.snapshot)) check_output_path("--snapshot", xdmf_path(a.snapshot));  // its XDMF beside it
    check_output_path("--dump-on-failure", a.dump);
    check_output_path("--checkpoint", a.checkpoint);
}

// The collide backend: --collide, else the scene's [run] collide, else grid.
std::string collide_of(const RunArgs& a, const Scene& sc) {
    return resolve_backend(a.collide, sc.run.collide, sc.run.collide_where, Stages::instance().collide.accepted(),
                           kDefaultCollide);
}

std::string solver_of(const RunArgs& a, const Scene& sc) {
    return resolve_backend(a.solver, sc.run.solver, sc.run.solver_where, Stages::instance().solver.accepted(),
                           kDefaultSolver);
}

Scene load_run_scene(const RunArgs& a) {
    std::vector<std::string> sets = a.sets;  // --program first: an explicit --set program.name wins
    if (!a.program.empty()) sets.insert(sets.begin(), "program.name=" + a.program);
    return load_scene(a.scene, sets, memory_guard([&a](const Scene& sc) {
        RunShape shape;
        shape.collide = collide_of(a, sc);
        shape.steps = step_count(a, sc);
        shape.observe_every = sc.observe_every;
        shape.record_trajectory = !a.trajectory.empty() || !a.reference.empty();
        shape.dump_on_failure = !a.dump.empty();
        return shape;
    }));
}

// The `error` block of a run against --reference, and the optional trajectory file.
void add_error(const RunArgs& a, const Pipeline& pipeline, nlohmann::json& report) {
    if (!a.trajectory.empty()) write_trajectory(a.trajectory, *pipeline.trajectory());
    if (a.reference.empty()) return;
    report["error"] = compare_with_reference(*pipeline.trajectory(), a.reference, report);
    report["error"]["reference_file"] = a.reference;
}

// The steps of a run, checkpoints on the way; true when a signal stopped it.
bool run_steps(const RunArgs& a, long steps, Pipeline& pipeline, const Interrupts& interrupts, bool root) {
    Progress progress(steps, root && !a.quiet && isatty(STDERR_FILENO));
    for (long s = 0; s < steps; ++s) {
        pipeline.step();
        progress.update(s + 1);
        if (a.checkpoint_every > 0 && pipeline.steps_done() % a.checkpoint_every == 0 && s + 1 < steps) {
            pipeline.write_checkpoint(a.checkpoint);
        }
        if (interrupts.requested(pipeline.collectives())) return true;
    }
    return false;
}

int run_command(const RunArgs& a) {
    const Processes& procs = *Processes::current();
    check_snapshot_format(a);
    if (procs.root()) check_outputs(a);  // the root writes every file
    RunOptions opt;
    const Scene scene = load_run_scene(a);
    opt.execution = execution_config(resolve_threads(a.threads, scene.run.threads));
    const long steps = step_count(a, scene);
    opt.collide = collide_of(a, scene);
    opt.solver = solver_of(a, scene);
    opt.snapshot_path = a.snapshot;
    opt.snapshot_every = a.snapshot.empty() ? 0 : static_cast<int>(a.snapshot_every);
    opt.planned_steps = steps;
    opt.record_trajectory = !a.trajectory.empty() || !a.reference.empty();
    opt.dump_path = a.dump;
    opt.invariants_every = a.check_every;
    opt.restart_path = a.restart;
    opt.domain = procs.size() > 1 ? "mpi" : "single";
    Pipeline pipeline(scene, opt);
    const Interrupts interrupts;
    const auto t0 = std::chrono::steady_clock::now();
    const bool stopped = run_steps(a, steps, pipeline, interrupts, procs.root());
    pipeline.finish();
    const std::string checkpoint = stopped && a.checkpoint.empty() ? scene.name + "-interrupted.ckpt" : a.checkpoint;
    if (!checkpoint.empty()) pipeline.write_checkpoint(checkpoint);
    RunInfo info{a.scene, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count()};
    nlohmann::json report = make_report(scene, pipeline, info);
    if (!a.restart.empty()) {
        const std::string caveat = pipeline.restart_caveat();
        report["restart"] = {{"from", a.restart}, {"step", pipeline.first_step()}, {"exact", caveat.empty()},
                             {"inexact_bodies", pipeline.inexact_restores()}, {"why", caveat},
                             {"checked", pipeline.restart_checked()}};
        if (!caveat.empty() && procs.root()) std::cerr << "parode: restart not bit for bit: " << caveat << "\n";
    }
    if (const CheckpointCost& k = pipeline.checkpoint_cost(); k.written > 0) {
        report["checkpoints"] = {{"written", k.written}, {"seconds", k.seconds}, {"checksum_seconds", k.checksum_seconds},
                                 {"checksum_share", k.checksum_seconds / std::max(k.seconds, 1e-12)}, {"bytes", k.bytes}};
    }
    if (stopped) report["interrupted"] = {{"signal", interrupts.name()}, {"step", pipeline.steps_done()}, {"checkpoint", checkpoint}};
    if (!procs.root()) return stopped ? kExitInterrupted : checks_exit_code(report, false);
    add_error(a, pipeline, report);
    if (!a.quiet) print_summary(std::cout, report);
    if (!a.quiet && report.contains("error")) print_error_summary(std::cout, report["error"]);
    if (!a.report.empty()) write_report(a.report, report);
    if (!stopped) return checks_exit_code(report);
    std::cerr << "parode: interrupted by " << interrupts.name() << " after step " << pipeline.steps_done()
              << "; checkpoint written to " << checkpoint << " (continue with --restart " << checkpoint << ")\n";
    return kExitInterrupted;
}

void add_run(CLI::App& app, RunArgs& a, std::function<int()>& action) {
    CLI::App* run = app.add_subcommand("run", "Simulate a scene and report speed and diagnostics");
    run->add_option("scene", a.scene, "Scene file (TOML), e.g. jobs/scenes/tennis.toml")->required();
    run->add_option("--steps", a.steps, "Number of steps (default: the scene's scene.steps)")->check(int_in(0, kMaxSteps));
    run->add_option("--duration", a.duration, "Simulated seconds (steps = duration / dt; overrides --steps)")
        ->check(number_in(0, 1e9));
    run->add_option("--threads", a.threads,
                    "Threads (default: the scene's [run] threads, else OMP_NUM_THREADS, else SLURM_CPUS_PER_TASK, else "
                    "every core of the process's affinity mask)")
        ->check(int_in(1, kMaxThreads));
    run->add_option("--collide", a.collide,
                    "Collision backend: " + backend_list() + " (default: the scene's [run] collide, else grid)")
        ->check(CLI::IsMember(Stages::instance().collide.accepted()));
    run->add_option("--solver", a.solver, "Solver: " + solver_list() + " (default: the scene's [run] solver, else parallel)")
        ->check(CLI::IsMember(Stages::instance().solver.accepted()));
    run->footer(
        "Fastest by default: --collide grid --solver parallel on every core the process may use. grid gives the\n"
        "contacts of ODE's own spaces bit for bit, without their n^2 memory (ODE's hash space cannot hold a million\n"
        "catoms); parallel is parode's contact solver, on the speed-vs-error front of the classic scenes and at least\n"
        "as accurate as QuickStep on them and on the hard cases (README, \"Speed against error\"). Measured on the\n"
        "8,000-catom tennis collapse: 3.0x faster than ODE's path on one thread, 4.9x on two. Scenes with joints or\n"
        "auto-disable run ODE's stepper under it (the report says why). The reference, ODE's own path:\n"
        "--collide ode-hash --solver ode.");
    run->add_option("--report", a.report, "Write the JSON run report to this file");
    run->add_option("--set", a.sets, "Override a scene value, key=value (e.g. catoms.count=8000); repeatable")
        ->allow_extra_args(false);
    run->add_option("--program", a.program,
                    "Catom program for every catom: a built-in (gradient, sculpt, wave) or a program library FILE.so "
                    "(as --set program.name=...; parameters from the scene's [program.params] or --set)");
    CLI::Option* snapshot = run->add_option("--snapshot", a.snapshot,
                                            "Write every body's state at step 0 and every K steps: FILE.h5 is H5MD with "
                                            "FILE.xdmf for ParaView, any other name CSV (position, quaternion)");
    run->add_option("--snapshot-every", a.snapshot_every, "Steps between snapshots K (default 1)")
        ->check(int_in(1, kMaxSteps))->needs(snapshot);
    run->add_option("--trajectory", a.trajectory, "Write body positions at observed steps (a reference for --reference)");
    run->add_option("--reference", a.reference,
                    "Compare with a reference run: its --trajectory file (full error metrics) or its --report JSON "
                    "(final observables only); adds `error` to the report");
    run->add_option("--dump-on-failure", a.dump, "When the guard stops the run, write the last good state (CSV) here");
    run->add_option("--check-invariants", a.check_every,
                    "Steps between checks of the distributed invariants (one owner per body, constant count, ghosts "
                    "equal owners; default 100, every step in debug builds)")
        ->check(CLI::Range(1, 1000000000));
    CLI::Option* checkpoint = run->add_option(
        "--checkpoint", a.checkpoint,
        "Write a checkpoint here at the end of the run (and every --checkpoint-every steps, and on SIGTERM/SIGINT)");
    run->add_option("--checkpoint-every", a.checkpoint_every, "Steps between checkpoints")
        ->check(int_in(1, kMaxSteps))->needs(checkpoint);
    run->add_option("--restart", a.restart,
                    "Continue from this checkpoint (the same scene and --set options); --steps counts the steps to add");
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
    parode::omp::add_stages();
#ifdef PARODE_HAVE_MPI
    parode::mpi::add_stages();
#endif
    install_ode_handlers();
    CLI::App app{"parode: parallel rigid-body simulation on ODE (see README.md)"};
    app.set_version_flag("--version", version_text(), "Print the version, git commit, ODE, OpenMP and MPI, and exit");
    app.require_subcommand(1);
    RunArgs run_args;
    BenchArgs bench_args;
    CompareArgs compare_args;
    LatencyArgs latency_args;
    MemoryArgs memory_args;
    InfoArgs info_args;
    KeysArgs keys_args;
    std::function<int()> action;
    add_run(app, run_args, action);
    add_bench(app, bench_args, action);
    add_compare(app, compare_args, action);
    add_latency(app, latency_args, action);
    add_memory(app, memory_args, action);
    add_info(app, info_args, action);
    add_keys(app, keys_args, action);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e);  // --help, --version
        std::cerr << "parode: " << e.what() << "\n" << "Run with --help for more information.\n";
        return kExitUsage;
    }
    return guarded([&] {
        parode::huge_pages_wanted();  // a bad PARODE_HUGE_PAGES stops here, before any work
        return action ? action() : 0;
    });
}
