// omp_collide_bench: times collision backends on the sphere prism of the
// performance targets (n^3 spheres of radius 0.5, touching, 1 % jitter, over a
// plane) through omp::bench_collide, and prints one CSV row per configuration,
// with the machine's own speedup on the largest thread count (compute-bound
// loop) as the last column.
// Usage: omp_collide_bench N REPS BACKEND[,BACKEND...] THREADS[,THREADS...]
//   e.g. omp_collide_bench 20 21 ode-hash,ode-sap,grid 1,2
// Trade-off: a fixed scene generator rather than scene files, so the numbers
// depend on nothing but the build and the machine.
#include <ode/ode.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

#include "collide/collide.hpp"
#include "collide_bench.hpp"
#include "random_scene.hpp"
#include "omp/stages.hpp"

namespace {

std::vector<std::string> split(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream in(s);
    for (std::string item; std::getline(in, item, ',');) {
        if (!item.empty()) out.push_back(item);
    }
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 5) {
        std::fprintf(stderr, "usage: %s N REPS BACKENDS THREADS\n", argv[0]);
        return 2;
    }
    const int n = std::atoi(argv[1]);
    const int reps = std::atoi(argv[2]);
    const std::vector<std::string> backends = split(argv[3]);
    std::vector<int> threads;
    for (const std::string& t : split(argv[4])) threads.push_back(std::atoi(t.c_str()));
    dInitODE2(0);
    dAllocateODEDataForThread(dAllocateMaskAll);
    parode::omp::add_stages();
    {
        parode::test::SpherePrism prism(n, 0.5, 0.01, 1, dSimpleSpaceClass);
        const auto results = parode::omp::bench_collide(prism.space(), backends, threads, 4, reps);
        const int most = *std::max_element(threads.begin(), threads.end());
        const double machine = parode::omp::machine_speedup(most);
        std::printf("spheres,backend,threads,median_ms,min_ms,contacts,digest,machine_speedup_%d\n",
                    most);
        for (const auto& r : results) {
            std::printf("%d,%s,%d,%.4f,%.4f,%zu,%016llx,%.2f\n", n * n * n, r.backend.c_str(),
                        r.threads, r.median_s * 1e3, r.min_s * 1e3, r.contacts,
                        static_cast<unsigned long long>(r.digest), machine);
        }
    }
    dCloseODE();
    return 0;
}
