// `parode memory`: what this machine's memory does, to read a scaling study
// by. It measures the STREAM triad (a[i] = b[i] + s * c[i], 24 bytes moved per
// element, as STREAM counts them) on 1 to T threads, and the rate at which
// fresh memory is touched for the first time (one write per 4 KB page of a new
// mapping, the kernel zeroing each page), in 4 KB pages and advised for 2 MB
// pages as parode's large buffers are (util/huge_pages.hpp). On bare metal the second is a few
// times the first; on a virtual machine whose host takes freed memory back
// (free page reporting, ballooning) it can be a fiftieth of it, and a run's
// first steps, which touch every per-step buffer for the first time, pay that.
// Trade-off: medians of a few repeats over arrays of a fixed size, seconds in
// all; not a substitute for STREAM's full protocol, enough to tell a machine
// whose bandwidth is shared or whose fresh memory is slow.
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#if defined(__linux__)
#include <sys/mman.h>
#endif

#include "cli_common.hpp"
#include "omp/stages.hpp"
#include "util/huge_pages.hpp"
#include "util/median.hpp"
#include "util/substages.hpp"

namespace parode::cli {
namespace {

constexpr int kRepeats = 5;

// Median triad GB/s on `threads` threads over arrays of n doubles (each
// thread first touches the part it later streams, as STREAM does).
double triad(std::size_t n, int threads) {
    std::unique_ptr<double[]> a(new double[n]), b(new double[n]), c(new double[n]);
    double* pa = a.get();
    double* pb = b.get();
    double* pc = c.get();
    const auto sn = static_cast<long>(n);
#pragma omp parallel for schedule(static) num_threads(threads)
    for (long i = 0; i < sn; ++i) pa[i] = 0, pb[i] = 1, pc[i] = 2;
    std::vector<double> rates;
    for (int r = 0; r < kRepeats; ++r) {
        const double t0 = now_seconds();
#pragma omp parallel for schedule(static) num_threads(threads)
        for (long i = 0; i < sn; ++i) pa[i] = pb[i] + 3.0 * pc[i];
        rates.push_back(24.0 * static_cast<double>(n) / (now_seconds() - t0) / 1e9);
    }
    if (pa[n / 2] != 7.0) throw std::runtime_error("memory probe: the triad computed a wrong value");
    return median(rates);
}

// GB/s at which `bytes` of a fresh mapping are touched (one write per page) on
// `threads` threads, for each of kRepeats mappings made and unmapped in turn;
// with `huge`, each mapping is advised for huge pages first.
std::vector<double> first_touch(std::size_t bytes, int threads, bool huge) {
    std::vector<double> rates;
    for (int r = 0; r < kRepeats; ++r) {
#if defined(__linux__)
        void* m = mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
        if (m == MAP_FAILED) throw std::runtime_error("memory probe: mmap failed");
        char* p = static_cast<char*>(m);
        if (huge) advise_huge_pages(p, bytes);
#else
        (void)huge;
        std::unique_ptr<char[]> own(new char[bytes]);
        char* p = own.get();
#endif
        const auto pages = static_cast<long>(bytes / 4096);
        const double t0 = now_seconds();
#pragma omp parallel for schedule(static) num_threads(threads)
        for (long k = 0; k < pages; ++k) p[k * 4096] = 1;
        rates.push_back(static_cast<double>(bytes) / (now_seconds() - t0) / 1e9);
#if defined(__linux__)
        munmap(m, bytes);
#endif
    }
    return rates;
}

int probe(const MemoryArgs& a) {
    const std::size_t n = static_cast<std::size_t>(a.mb) * (std::size_t{1} << 20) / sizeof(double);
    const int top = a.threads > 0 ? a.threads : omp::default_threads();
    nlohmann::json j = {{"array_mb", a.mb}};
    for (int t = 1; t <= top; ++t) {
        const double gbs = triad(n, t);
        j["threads"].push_back(t);
        j["triad_gb_s"].push_back(gbs);
        std::printf("triad, %d thread(s): %.1f GB/s\n", t, gbs);
    }
    for (const bool huge : {false, true}) {
        const std::vector<double> touch = first_touch(3 * n * sizeof(double), top, huge);
        j[huge ? "first_touch_huge_gb_s" : "first_touch_gb_s"] = touch;
        // The first mapping meets memory no process used lately; the later
        // ones, on a host that takes freed memory back lazily, meet memory the
        // previous mapping freed.
        const char* pages = !huge ? "4 KB" : huge_pages_wanted() ? "2 MB" : "4 KB (PARODE_HUGE_PAGES=0)";
        std::printf("first touch, %s pages, %d thread(s): first mapping %.2f GB/s, later ones median %.2f GB/s\n",
                    pages, top, touch.front(), median({touch.begin() + 1, touch.end()}));
    }
    j["first_touch_threads"] = top;
    if (!a.json.empty()) write_json(a.json, j);
    return 0;
}

}  // namespace

void add_memory(CLI::App& app, MemoryArgs& a, std::function<int()>& action) {
    CLI::App* m = app.add_subcommand("memory", "Measure this machine's memory: triad bandwidth per thread count, first touch");
    m->add_option("--mb", a.mb, "Size of each of the triad's three arrays, MB")->check(CLI::Range(1, 65536))->capture_default_str();
    m->add_option("--threads", a.threads, "Up to this many threads (default: OpenMP's maximum)")->check(CLI::Range(1, 4096));
    m->add_option("--json", a.json, "Also write the figures as JSON");
    m->callback([&] { action = [&] { return probe(a); }; });
}

}  // namespace parode::cli
