// `parode bench step SCENE --backends ode-hash/ode:1,grid/parallel:2`: times
// whole steps of several configurations (collide backend / solver : threads)
// side by side in one process. Each variant runs its own pipeline on the same
// scene; they advance in turns, --every steps at a time, so all see the same
// phase of the run and the same machine noise. An untimed reference pipeline
// (ODE's hash space and QuickStep with --reference-iterations) steps along, and
// each variant's error is measured against it: RMS position error after
// --error-at steps, and at the end the centre-of-mass height and penetration.
// Trade-off: the variants' trajectories diverge in chaotic piles, so their
// timings compare equal scenes and phases, not identical states.
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "cli_common.hpp"
#include "util/errors.hpp"
#include "run/pipeline.hpp"
#include "scene/scene_file.hpp"

namespace parode::cli {
namespace {

struct StepVariant {
    std::string label, collide, solver;
    int threads = 1;
    std::unique_ptr<Pipeline> p;
    double seconds = 0;
    double rms_at = -1;
};

StepVariant parse_variant(const std::string& spec) {
    StepVariant v;
    v.label = spec;
    auto [s, threads] = split_threads(spec);
    v.threads = threads;
    const auto slash = s.find('/');
    v.collide = s.substr(0, slash);
    v.solver = slash == std::string::npos ? "ode" : s.substr(slash + 1);
    return v;
}

std::unique_ptr<Pipeline> make_pipeline(const Scene& sc, const std::string& collide, const std::string& solver, int threads) {
    RunOptions opt;
    opt.collide = collide;
    opt.solver = solver;
    opt.execution.threads = threads;
    opt.execution.threads_from = "--backends";
    return std::make_unique<Pipeline>(sc, opt);
}

double rms_position_error(const Pipeline& a, const Pipeline& ref) {
    double sum = 0;
    const std::size_t n = ref.world().body_count();
    for (std::size_t i = 0; i < n; ++i) {
        const dReal* x = dBodyGetPosition(a.world().body(i));
        const dReal* y = dBodyGetPosition(ref.world().body(i));
        sum += (x[0] - y[0]) * (x[0] - y[0]) + (x[1] - y[1]) * (x[1] - y[1]) + (x[2] - y[2]) * (x[2] - y[2]);
    }
    return std::sqrt(sum / static_cast<double>(n));
}

void advance(StepVariant& v, int steps) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int s = 0; s < steps; ++s) v.p->step();
    v.seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void print_step_table(const Scene& sc, int steps, std::vector<StepVariant>& vars, const Pipeline* ref, int error_at,
                      std::ostream& os) {
    os << "step benchmark: " << sc.name << ", " << sc.body_count() << " bodies, " << steps << " steps, "
       << sc.solver.iterations << " iterations" << (ref ? ", reference: ode-hash/ode with more iterations" : "") << "\n";
    os << "  variant                 ms/step  collide    solve  x vs first   rms@" << error_at
       << "    |dcom|   max pen  mean pen\n";
    const double base = vars[0].seconds;
    os << std::fixed;
    for (auto& v : vars) {
        v.p->finish();
        const double per = 1e3 / steps;
        os << "  " << std::left << std::setw(22) << v.label << std::right << std::setprecision(3) << std::setw(9)
           << v.seconds * per << std::setw(9) << v.p->stage(Stage::Collide).seconds * per << std::setw(9)
           << v.p->stage(Stage::Solve).seconds * per << std::setw(12) << std::setprecision(2) << base / v.seconds
           << std::setprecision(6) << std::setw(10) << v.rms_at << std::setw(10)
           << (ref ? std::fabs(v.p->last().com_height - ref->last().com_height) : -1.0) << std::setw(10)
           << v.p->totals().max_penetration << std::setw(10) << v.p->totals().mean_penetration() << "\n";
    }
}

// Turn sizes: --every steps, but a turn ends at exactly step --error-at when a
// reference is there, so the error is taken at that step whatever --every is.
int turn_length(const BenchArgs& a, int done, int steps, bool reference) {
    int n = std::min(a.every, steps - done);
    if (reference && done < a.error_at) n = std::min(n, a.error_at - done);
    return n;
}

void write_step_csv(const BenchArgs& a, const Scene& scene, int steps, const std::vector<StepVariant>& vars) {
    std::ofstream out(a.csv);
    if (!out) throw OutputError(a.csv + ": cannot open CSV file for writing");
    out << "scene,bodies,steps,variant,ms_per_step,collide_ms,solve_ms,speedup_vs_first,rms_at,error_at\n";
    for (const auto& v : vars) {
        out << scene.name << ',' << scene.bodies.size() << ',' << steps << ',' << v.label << ',' << 1e3 * v.seconds / steps
            << ',' << 1e3 * v.p->stage(Stage::Collide).seconds / steps << ',' << 1e3 * v.p->stage(Stage::Solve).seconds / steps
            << ',' << vars[0].seconds / v.seconds << ',' << v.rms_at << ',' << a.error_at << '\n';
    }
    if (!out) throw OutputError(a.csv + ": error while writing the CSV file");
}

}  // namespace

int bench_step(const BenchArgs& a) {
    const Scene scene = load_bench_scene(a, static_cast<int>(a.backends.size()) + (a.reference_iterations > 0 ? 1 : 0));
    std::vector<StepVariant> vars;
    for (const auto& spec : a.backends) {
        vars.push_back(parse_variant(spec));
        vars.back().p = make_pipeline(scene, vars.back().collide, vars.back().solver, vars.back().threads);
    }
    Scene ref_scene = scene;
    ref_scene.solver.iterations = a.reference_iterations;
    std::unique_ptr<Pipeline> ref;
    if (a.reference_iterations > 0) ref = make_pipeline(ref_scene, "ode-hash", "ode", 1);
    const int steps = a.steps > 0 ? a.steps : scene.steps;
    if (ref && a.error_at > steps) {
        throw std::invalid_argument("--error-at " + std::to_string(a.error_at) + " is past the last step (" +
                                    std::to_string(steps) + ")");
    }
    for (int done = 0; done < steps;) {
        const int n = turn_length(a, done, steps, ref != nullptr);
        for (auto& v : vars) advance(v, n);
        if (ref) {
            for (int s = 0; s < n; ++s) ref->step();
        }
        done += n;
        if (ref && done == a.error_at) {
            for (auto& v : vars) v.rms_at = rms_position_error(*v.p, *ref);
        }
    }
    if (ref) ref->finish();
    print_step_table(scene, steps, vars, ref.get(), a.error_at, std::cout);
    if (!a.csv.empty()) write_step_csv(a, scene, steps, vars);
    return 0;
}

}  // namespace parode::cli
