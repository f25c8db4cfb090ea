// Backend timing (see collide_bench.hpp).
// Trade-off: std::chrono::steady_clock per call; fine for calls of ~10 us and up.
#include "collide_bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "collide/collide.hpp"
#include "collide/contacts.hpp"
#include "omp/stages.hpp"
#include "util/median.hpp"

namespace parode::omp {
namespace {

struct Config {
    std::unique_ptr<Execution> exec;  // the configuration's threads
    std::unique_ptr<CollideBackend> backend;
    int threads;
    std::vector<double> times;
    ContactBuffer out;
};

bool uses_threads(const std::string& name) { return name.rfind("ode-", 0) != 0; }

// Scratch spaces of each kind; geoms move to the one a backend needs.
class SpaceShuttle {
public:
    explicit SpaceShuttle(dSpaceID home) : home_(home), current_(home) {}
    ~SpaceShuttle() {
        move_to(home_);
        for (dSpaceID s : scratch_) dSpaceDestroy(s);
    }
    dSpaceID current() const { return current_; }
    dSpaceID for_kind(SpaceKind kind) {
        const int cls = kind == SpaceKind::Hash ? dHashSpaceClass
                        : kind == SpaceKind::SweepAndPrune ? dSweepAndPruneSpaceClass
                                                           : dSimpleSpaceClass;
        if (dSpaceGetClass(current_) == cls) return current_;
        if (dSpaceGetClass(home_) == cls) return move_to(home_);
        for (dSpaceID s : scratch_) {
            if (dSpaceGetClass(s) == cls) return move_to(s);
        }
        scratch_.push_back(make(cls));
        return move_to(scratch_.back());
    }

private:
    static dSpaceID make(int cls) {
        if (cls == dHashSpaceClass) return dHashSpaceCreate(nullptr);
        if (cls == dSweepAndPruneSpaceClass) return dSweepAndPruneSpaceCreate(nullptr, dSAP_AXES_XZY);
        return dSimpleSpaceCreate(nullptr);
    }
    dSpaceID move_to(dSpaceID target) {
        if (target == current_) return current_;
        std::vector<dGeomID> geoms;
        for (int i = 0, n = dSpaceGetNumGeoms(current_); i < n; ++i) geoms.push_back(dSpaceGetGeom(current_, i));
        for (dGeomID g : geoms) dSpaceRemove(current_, g);
        for (dGeomID g : geoms) dSpaceAdd(target, g);
        current_ = target;
        return current_;
    }
    dSpaceID home_;
    dSpaceID current_;
    std::vector<dSpaceID> scratch_;
};

std::vector<Config> make_configs(const std::vector<std::string>& backends,
                                 const std::vector<int>& threads) {
    std::vector<Config> configs;
    for (const std::string& name : backends) {
        const std::vector<int> counts = uses_threads(name) ? threads : std::vector<int>{1};
        for (int t : counts) {
            ExecutionConfig config;
            config.threads = t > 0 ? t : default_threads();
            Config c{Stages::instance().execution(config), nullptr, t, {}, {}};
            c.backend = Stages::instance().collide.make(name, *c.exec);
            configs.push_back(std::move(c));
        }
    }
    return configs;
}

double time_call(Config& c, dSpaceID space, int max_contacts) {
    const auto t0 = std::chrono::steady_clock::now();
    c.backend->collide(space, max_contacts, c.out);
    const auto t1 = std::chrono::steady_clock::now();
    return std::chrono::duration<double>(t1 - t0).count();
}

// Seconds for a fixed amount of square roots spread over `threads` threads.
double compute_seconds(int threads) {
    (void)threads;  // unused when built without OpenMP
    const long n = 40000000;
    double sum = 0;
    const auto t0 = std::chrono::steady_clock::now();
#pragma omp parallel for num_threads(threads) schedule(static) reduction(+ : sum)
    for (long i = 0; i < n; ++i) sum += std::sqrt(static_cast<double>(i));
    const auto t1 = std::chrono::steady_clock::now();
    return sum < 0 ? 0 : std::chrono::duration<double>(t1 - t0).count();
}

}  // namespace

double machine_speedup(int threads) {
    double one = HUGE_VAL, many = HUGE_VAL;
    for (int rep = 0; rep < 3; ++rep) {
        one = std::min(one, compute_seconds(1));
        many = std::min(many, compute_seconds(std::max(1, threads)));
    }
    return one / many;
}

std::vector<BenchResult> bench_collide(dSpaceID space, const std::vector<std::string>& backends,
                                       const std::vector<int>& threads, int max_contacts,
                                       int repetitions) {
    std::vector<Config> configs = make_configs(backends, threads);
    SpaceShuttle shuttle(space);
    const std::size_t k = configs.size();
    for (int rep = -1; rep < repetitions; ++rep) {
        // Each repetition starts with the next configuration, so none always
        // runs right after another one's (cache-warming) call.
        for (std::size_t j = 0; j < k; ++j) {
            Config& c = configs[(j + static_cast<std::size_t>(rep + 1)) % k];
            // Backends of this library accept any space: no move for them.
            const bool any_space = uses_threads(c.backend->name());
            dSpaceID s = any_space ? shuttle.current() : shuttle.for_kind(c.backend->space_kind());
            dSpaceClean(s);
            const double t = time_call(c, s, max_contacts);
            if (rep >= 0) c.times.push_back(t);
        }
    }
    std::vector<BenchResult> results;
    for (Config& c : configs) {
        BenchResult r;
        r.backend = c.backend->name();
        r.threads = c.threads;
        r.median_s = median(c.times);
        r.min_s = c.times.empty() ? 0 : *std::min_element(c.times.begin(), c.times.end());
        r.contacts = c.out.size();
        r.digest = contact_digest(c.out);
        results.push_back(r);
    }
    return results;
}

}  // namespace parode::omp
