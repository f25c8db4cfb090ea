// Run memory estimate (see memory_estimate.hpp).
// Trade-off: the constants below come from peak RSS measurements of one scene
// family; they are re-measured when the data structures change, not derived.
//
// Measurements (peak RSS from /usr/bin/time -f %M, 2 steps, 1 thread, tennis.toml):
//   parode run jobs/scenes/tennis.toml --set catoms.count=N --steps 2 -q --threads 1 (grid, parallel)
//     N =     8,000:    31,264 kB,    11,831 contacts per step
//     N =    64,000:   138,896 kB,    96,897 contacts per step
//     N =   200,000:   376,932 kB,   304,918 contacts per step
//     N = 1,000,000: 1,794,404 kB, 1,532,468 contacts per step
//   the same with --set catoms.spacing=1.2 (no catom touches another):
//     N =     8,000:    28,584 kB,       214 contacts per step
//     N =   200,000:   297,580 kB,     1,855 contacts per step
//   bytes = a + b N + c contacts, least squares over all six: a = 21.0 MB,
//   b = 1,416 bytes per body (of which ODE's own body and sphere records are
//   about 1,050), c = 262 bytes per contact; within 0.5 % from 200,000 up,
//   11 % high at 8,000 (the fixed part is smaller for small scenes).
//   The prism has 1.5 contacts per catom at the start (1.2 to 1.3 later in the
//   collapse, 1.7 over the first five steps at 10^6); the estimate takes 2.
//   magnetic-tennis.toml: 153,524 kB at N = 64,000 and 423,156 kB at 200,000,
//   240 and 244 bytes a catom more than tennis once the contacts are
//   accounted: the magnet pass's data, counted only when the magnets act.
//   --collide ode-hash: 732,640 kB at N = 64,000 and 5,213,836 kB at 200,000:
//   ODE's hash space allocates a bit per ordered pair of geoms, geoms^2 / 8 bytes.
//   --collide ode-sap / grid with --solver ode: 3 to 10 % below grid/parallel.
//   --trajectory: 24 bytes per body per frame (8,000 bodies, 101 frames: +17 MB).
//   --program gradient: 166,284 kB at N = 64,000 and 470,220 kB at 200,000
//   (tennis, the same contacts), 582 and 518 bytes a catom more; wave 515 and
//   407: each catom's record and program object and the pass's lists (a
//   program library's own objects add what they hold).
// The estimate for N = 200,000 (grid, parallel) is 0.41 GB against 0.39 GB
// measured; at N = 10^6, 1.96 GB against 1.84 GB (2 steps) and 1.92 GB (5
// steps, analysis/results/vm-amd-epyc-2c/list-build).
#include "run/memory_estimate.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

namespace parode {
namespace {

constexpr double kFixedBytes = 21.0e6;
constexpr double kBytesPerBody = 1416;
constexpr double kBytesPerContact = 262;
constexpr double kContactsPerBody = 2;
constexpr double kBytesPerMagnetCatom = 242;
constexpr double kBytesPerProgramCatom = 520;
constexpr double kBytesPerFramePerBody = 24;   // trajectory positions
constexpr double kBytesPerFrameHeader = 128;   // 16 doubles
constexpr double kBytesPerDumpBody = 13 * 8;   // guard: position, quaternion, velocities

// Contacts of a prism at `spacing`: its catoms touch a neighbour per axis at
// spacing 2r; closer spacing reaches more neighbours, as the volume within 2r.
double prism_contacts(double count, double radius, double spacing) {
    const double reach = 2 * radius / spacing;
    return count * kContactsPerBody * std::max(1.0, reach * reach * reach);
}

double statics_and_planes(const Scene& sc) { return static_cast<double>(sc.statics.size() + sc.planes.size()); }

}  // namespace

SceneSize scene_size(const Scene& scene) {
    SceneSize s;
    s.bodies = static_cast<double>(scene.bodies.size());
    s.geoms = s.bodies + statics_and_planes(scene);
    s.contacts = s.bodies * kContactsPerBody;
    const double n = static_cast<double>(scene.catoms.count);  // the generated prism
    s.bodies += n;
    s.geoms += n;
    if (n > 0) s.contacts += prism_contacts(n, scene.catoms.proto.shape.radius, scene.catoms.spacing);
    s.magnet_catoms = scene.any_magnets() ? static_cast<double>(scene.catom_count()) : 0;
    s.program_catoms = scene.program.enabled ? static_cast<double>(scene.catom_count()) : 0;
    return s;
}

SceneSize scene_size(const Scene& so_far, const CatomPlan& catoms) {
    SceneSize s = scene_size(so_far);
    const double n = static_cast<double>(catoms.count);
    s.bodies += n;
    s.geoms += n;
    if (n > 0) s.contacts += prism_contacts(n, catoms.radius, catoms.spacing);
    // The magnets are read after the prism: the plan says whether they act,
    // so every catom counts (a [magnets] off list is not subtracted).
    s.magnet_catoms = catoms.magnets ? static_cast<double>(so_far.catom_count()) + n : 0;
    s.program_catoms = catoms.program ? static_cast<double>(so_far.catom_count()) + n : 0;  // read after the prism
    return s;
}

MemoryEstimate estimate_memory(const SceneSize& size, const RunShape& run, int ranks) {
    MemoryEstimate e;
    e.ranks = std::max(1, ranks);
    const double r = e.ranks, p = std::max(1, run.pipelines);
    const double bodies = size.bodies / r, geoms = size.geoms / r;
    const double world = bodies * kBytesPerBody + size.contacts / r * kBytesPerContact +
                         size.magnet_catoms / r * kBytesPerMagnetCatom + size.program_catoms / r * kBytesPerProgramCatom;
    const double hash = run.collide == "ode-hash" ? geoms * geoms / 8 : 0;
    const double frames = run.record_trajectory ? static_cast<double>(run.steps / std::max(1L, run.observe_every) + 2) : 0;
    const double trajectory = frames * (bodies * kBytesPerFramePerBody + kBytesPerFrameHeader);
    const double dump = run.dump_on_failure ? bodies * kBytesPerDumpBody : 0;
    e.bytes_per_rank = kFixedBytes + p * (world + hash) + trajectory + dump;
    e.bytes = r * e.bytes_per_rank;
    std::ostringstream os;
    os.setf(std::ios::fixed);
    os.precision(0);
    os << size.bodies << " bodies and " << size.contacts << " contacts: " << format_bytes(r * p * world);
    if (hash > 0) os << ", ODE's hash space (--collide ode-hash): " << format_bytes(r * p * hash);
    if (trajectory > 0) os << ", trajectory: " << format_bytes(r * trajectory);
    if (p > 1) os << ", " << p << " worlds";
    e.detail = os.str();
    return e;
}

MemoryEstimate estimate_memory(const Scene& scene, const RunShape& run, int ranks) {
    return estimate_memory(scene_size(scene), run, ranks);
}

namespace {

// A "Key: value kB" field of /proc/meminfo, in bytes; < 0 when absent.
double meminfo_bytes(const std::string& key) {
    std::ifstream in("/proc/meminfo");
    std::string name, unit;
    double kb = 0;
    while (in >> name >> kb) {
        std::getline(in, unit);
        if (name == key + ":") return kb * 1024;
    }
    return -1;
}

// First number in a file ("max" and unreadable files: < 0).
double file_number(const std::string& path) {
    std::ifstream in(path);
    double x = -1;
    if (!(in >> x)) return -1;
    return x;
}

// Limit less usage of this process's cgroup (v2, else v1); < 0 when unlimited or unknown.
double cgroup_headroom() {
    std::ifstream in("/proc/self/cgroup");
    std::string line, v2, v1;
    while (std::getline(in, line)) {
        if (line.rfind("0::", 0) == 0) v2 = line.substr(3);
        const auto m = line.find(":memory:");
        if (m != std::string::npos) v1 = line.substr(m + 8);
    }
    const std::pair<std::string, std::string> tries[] = {
        {"/sys/fs/cgroup" + v2 + "/memory.max", "/sys/fs/cgroup" + v2 + "/memory.current"},
        {"/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"},
        {"/sys/fs/cgroup/memory" + v1 + "/memory.limit_in_bytes", "/sys/fs/cgroup/memory" + v1 + "/memory.usage_in_bytes"},
        {"/sys/fs/cgroup/memory/memory.limit_in_bytes", "/sys/fs/cgroup/memory/memory.usage_in_bytes"}};
    for (const auto& [max_path, used_path] : tries) {
        const double limit = file_number(max_path);
        if (limit < 0 || limit > 1e18) continue;  // "max", v1's "unlimited" (2^63 - page)
        return std::max(0.0, limit - std::max(0.0, file_number(used_path)));
    }
    return -1;
}

// RLIMIT_AS less the address space already mapped; < 0 when unlimited.
double address_space_headroom() {
    rlimit lim{};
    if (getrlimit(RLIMIT_AS, &lim) != 0 || lim.rlim_cur == RLIM_INFINITY) return -1;
    const double mapped = std::max(0.0, file_number("/proc/self/statm")) * static_cast<double>(sysconf(_SC_PAGESIZE));
    return std::max(0.0, static_cast<double>(lim.rlim_cur) - mapped);
}

}  // namespace

MemoryAvailable available_memory() {
    MemoryAvailable a{meminfo_bytes("MemAvailable"), "MemAvailable in /proc/meminfo"};
    if (a.bytes < 0) a = {static_cast<double>(sysconf(_SC_AVPHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGESIZE)),
                          "free physical memory"};
    const double cgroup = cgroup_headroom();
    if (cgroup >= 0 && cgroup < a.bytes) a = {cgroup, "the cgroup's memory limit less its usage"};
    const double as = address_space_headroom();
    if (as >= 0 && as < a.bytes) a = {as, "the address-space limit (ulimit -v) less what is mapped"};
    return a;
}

void require_memory(const MemoryEstimate& need, const MemoryAvailable& have) {
    if (need.bytes <= have.bytes) return;
    const bool hash = need.detail.find("ode-hash") != std::string::npos;
    throw MemoryError("the run needs about " + format_bytes(need.bytes) + " (" + need.detail + ") but " +
                      format_bytes(have.bytes) + " is available (" + have.source + "); " +
                      (hash ? "--collide grid gives the same contacts without the hash space's geoms^2/8-byte matrix"
                            : "use fewer catoms or a larger machine"));
}

std::string format_bytes(double bytes) {
    const char* units[] = {"bytes", "kB", "MB", "GB", "TB", "PB", "EB"};
    int u = 0;
    while (std::fabs(bytes) >= 1000 && u < 6) {
        bytes /= 1000;
        ++u;
    }
    std::ostringstream os;
    os.precision(3);
    os << bytes << ' ' << units[u];
    return os.str();
}

}  // namespace parode
