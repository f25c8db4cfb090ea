// `parode bench collide SCENE`: times the collide stage of several backends
// (each optionally with a thread count, "grid:2") on identical states in one
// process. A driver pipeline advances the scene; every --every steps its body
// states are copied into one World per variant and each variant's collide() is
// timed --repeats times, the variants alternating, each into its own contact
// buffer kept between calls (as a run keeps its step's buffer: no timing pays
// for first touching 100+ MB of fresh pages). Prints per-variant medians,
// ratios against the first variant, and whether all contact sets were identical.
// Trade-off: one World per variant costs memory, but every backend then sees
// exactly the same geoms in the space kind it wants.

#include <algorithm>
#include <array>
#include <chrono>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "cli_common.hpp"
#include "omp/grid/grid_collide.hpp"
#include "util/errors.hpp"
#include "util/hash.hpp"
#include "util/median.hpp"
#include "util/peak_memory.hpp"
#include "run/pipeline.hpp"
#include "run/stages.hpp"
#include "scene/scene_file.hpp"

namespace parode::cli {
namespace {

struct Variant {
    std::string label;
    std::vector<std::array<double, 6>> phases;  // grid: refresh+read, build, pairs, deferred, merge, total
    std::unique_ptr<Execution> exec;  // the variant's own threads
    std::unique_ptr<CollideBackend> backend;
    std::unique_ptr<World> world;
    std::vector<double> seconds;
    double rss_mb = 0;  // peak-RSS growth on the first collide call
    std::size_t contacts = 0;
    ContactBuffer out;  // kept between calls, as a run keeps its step's buffer
};

double peak_rss_mb() { return static_cast<double>(peak_rss_bytes()) / (1024.0 * 1024.0); }

Variant make_variant(const Scene& scene, const std::string& spec) {
    Variant v;
    v.label = spec;
    const auto [name, threads] = split_threads(spec);
    ExecutionConfig config;
    config.threads = threads;
    config.threads_from = "--backends " + spec;
    v.exec = Stages::instance().execution(config);
    v.backend = Stages::instance().collide.make(name, *v.exec);
    v.world = std::make_unique<World>(scene, v.backend->space_kind());
    v.backend->set_geoms(v.world->space(), &v.world->geoms());  // as the pipeline does
    v.backend->set_sphere_bodies(v.world->sphere_bodies());
    return v;
}

void copy_state(const World& from, World& to) {
    for (std::size_t i = 0; i < from.body_count(); ++i) {
        dBodyID a = from.body(i), b = to.body(i);
        const dReal* p = dBodyGetPosition(a);
        dBodySetPosition(b, p[0], p[1], p[2]);
        dBodySetQuaternion(b, dBodyGetQuaternion(a));
        if (dBodyIsEnabled(a)) dBodyEnable(b);
        else dBodyDisable(b);
    }
}

void record_phases(Variant& v) {
    const auto* grid = dynamic_cast<const parode::omp::GridBackend*>(v.backend.get());
    if (!grid) return;
    const auto& t = grid->engine().last_phase_times();
    v.phases.push_back({t.read, t.build, t.pairs, t.deferred, t.merge, v.seconds.back()});
}

// Time every variant on the current driver state; returns false if contact sets differ.
bool sample(const World& driver, std::vector<Variant>& vars, int repeats, int max_contacts) {
    std::vector<std::uint64_t> digests(vars.size());
    for (auto& v : vars) copy_state(driver, *v.world);
    for (int r = 0; r < repeats; ++r) {
        for (std::size_t k = 0; k < vars.size(); ++k) {
            ContactBuffer& out = vars[k].out;
            const double before = peak_rss_mb();
            const auto t0 = std::chrono::steady_clock::now();
            vars[k].backend->collide(vars[k].world->space(), max_contacts, out);
            vars[k].seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
            record_phases(vars[k]);
            vars[k].rss_mb = std::max(vars[k].rss_mb, peak_rss_mb() - before);
            vars[k].contacts = out.size();
            digests[k] = contact_digest(out);
        }
    }
    return std::all_of(digests.begin(), digests.end(), [&](std::uint64_t d) { return d == digests[0]; });
}

void print_table(const Scene& scene, const std::vector<Variant>& vars, bool identical, std::ostream& os) {
    const double base = median(vars[0].seconds);
    const double n = static_cast<double>(scene.body_count());
    os << "collide benchmark: " << scene.name << ", " << scene.body_count() << " bodies, "
       << vars[0].seconds.size() << " timings per variant\n";
    os << "  variant            median ms   us/body   x vs " << vars[0].label << "   contacts  +RSS MB\n";
    for (const auto& v : vars) {
        const double m = median(v.seconds);
        os << "  " << std::left << std::setw(18) << v.label << std::right << std::fixed << std::setprecision(3)
           << std::setw(10) << 1e3 * m << std::setw(10) << 1e6 * m / n << std::setw(12) << std::setprecision(2)
           << (m > 0 ? base / m : 0.0) << std::setw(11) << v.contacts << std::setw(9) << std::setprecision(1)
           << v.rss_mb << "\n";
    }
    for (const auto& v : vars) {
        if (v.phases.empty()) continue;
        const char* names[6] = {"read", "build", "pairs", "deferred", "merge", "total"};
        os << "  " << v.label << " phases (median ms):";
        for (int p = 0; p < 6; ++p) {
            std::vector<double> x;
            for (const auto& ph : v.phases) x.push_back(ph[static_cast<std::size_t>(p)]);
            os << ' ' << names[p] << ' ' << std::setprecision(3) << 1e3 * median(x);
        }
        os << "\n";
    }
    os << "  contact sets " << (identical ? "identical across variants (bit for bit)" : "DIFFER between variants") << "\n";
}

void write_csv(const std::string& path, const Scene& scene, const std::vector<Variant>& vars) {
    std::ofstream out(path);
    if (!out) throw OutputError(path + ": cannot open CSV file for writing");
    out << "scene,bodies,variant,median_s,speedup_vs_first,contacts,rss_mb\n";
    const double base = median(vars[0].seconds);
    for (const auto& v : vars) {
        const double m = median(v.seconds);
        out << scene.name << ',' << scene.body_count() << ',' << v.label << ',' << m << ',' << (m > 0 ? base / m : 0)
            << ',' << v.contacts << ',' << v.rss_mb << '\n';
    }
    if (!out) throw OutputError(path + ": error while writing the CSV file");
}

int bench_collide(const BenchArgs& a) {
    const Scene scene = load_bench_scene(a, static_cast<int>(a.backends.size()) + 1);
    std::vector<Variant> vars;
    for (const auto& spec : a.backends) vars.push_back(make_variant(scene, spec));
    RunOptions opt;
    opt.collide = a.backends.front().substr(0, a.backends.front().find(':'));
    Pipeline driver(scene, opt);
    bool identical = sample(driver.world(), vars, a.repeats, scene.solver.max_contacts);
    for (int s = 1; s <= a.steps; ++s) {
        driver.step();
        if (s % a.every == 0) identical = sample(driver.world(), vars, a.repeats, scene.solver.max_contacts) && identical;
    }
    print_table(scene, vars, identical, std::cout);
    if (!a.csv.empty()) write_csv(a.csv, scene, vars);
    return identical ? 0 : 1;
}

}  // namespace

Scene load_bench_scene(const BenchArgs& a, int pipelines) {
    check_output_path("--csv", a.csv);
    if (a.backends.empty()) throw std::invalid_argument("--backends: expected at least one variant");
    for (const auto& spec : a.backends) split_threads(spec);  // fails early on a bad THREADS
    return load_scene(a.scene, a.sets, memory_guard([&a, pipelines](const Scene& sc) {
        RunShape shape;
        shape.collide = a.reference_iterations > 0 ? "ode-hash" : "";  // bench step's reference
        for (const auto& spec : a.backends) {
            if (spec.rfind("ode-hash", 0) == 0) shape.collide = "ode-hash";  // the largest: counts for every world
        }
        shape.steps = a.steps > 0 ? a.steps : sc.steps;
        shape.pipelines = pipelines;
        return shape;
    }));
}

void add_bench(CLI::App& app, BenchArgs& a, std::function<int()>& action) {
    CLI::App* b = app.add_subcommand("bench", "Benchmark a stage of several implementations side by side");
    b->add_option("what", a.what, "collide: the collide stage on identical states; step: whole steps")
        ->required()->check(CLI::IsMember({"collide", "step"}));
    b->add_option("scene", a.scene, "Scene file (TOML)")->required();
    b->add_option("--set", a.sets, "Override a scene value, key=value; repeatable")->allow_extra_args(false);
    a.backends = {"ode-hash", "ode-sap"};
    b->add_option("--backends", a.backends,
                  "Variants; collide: NAME[:THREADS], the first drives the scene; step: COLLIDE[/SOLVER][:THREADS]; "
                  "the first is the baseline")
        ->delimiter(',')->capture_default_str();
    b->add_option("--steps", a.steps, "Steps to advance the scene (samples along the way)")->check(int_in(0, kMaxSteps));
    b->add_option("--reference-iterations", a.reference_iterations,
                  "step: also run ode-hash/ode with this many iterations as the error reference")
        ->check(int_in(0, 100000));
    b->add_option("--error-at", a.error_at, "step: steps after which the RMS position error is taken")
        ->check(int_in(1, kMaxSteps))->capture_default_str();
    b->add_option("--every", a.every, "collide: sample every N steps; step: steps per turn")
        ->check(int_in(1, kMaxSteps))->capture_default_str();
    b->add_option("--repeats", a.repeats, "Timings per variant per sample")->check(int_in(1, 1000000))->capture_default_str();
    b->add_option("--csv", a.csv, "Also write the table as CSV");
    b->callback([&] { action = [&] { return a.what == "step" ? bench_step(a) : bench_collide(a); }; });
}

}  // namespace parode::cli
