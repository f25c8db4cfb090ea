// Distribution rules (see distribution.hpp).
#include "domain/distribution.hpp"

#include <algorithm>

namespace parode {
namespace {

DistributionVerdict refuse(std::string reason, bool option = false) { return {false, option, std::move(reason)}; }

}  // namespace

DistributionVerdict distribution_verdict(const Scene& sc, const std::string& solver, int ranks, double cell_edge) {
    const std::string why = sc.source + ": a run on " + std::to_string(ranks) + " MPI processes needs ";
    const std::string one = "; run it as one process (without mpirun), with threads";
    if (!sc.joints.empty()) return refuse(why + "a contact-only scene, and this one has joints" + one);
    if (sc.controller.enabled) return refuse(why + "a contact-only scene, and this one has a [controller]" + one);
    if (sc.solver.auto_disable) return refuse(why + "solver.auto_disable off (sleeping bodies need ODE's islands)" + one);
    const bool contact_solver = solver == "parallel" || solver == "pgs" || solver == "pgs/omp" || solver == "adaptive" ||
                                solver == "adaptive/omp";
    if (!contact_solver) {
        return refuse("--solver " + solver + " runs ODE's stepper, which needs every body in one process; "
                      "use --solver parallel or adaptive/omp (parode's contact solvers: the same result for any number of processes)",
                      true);
    }
    if (sc.any_magnets()) {
        const double rmax = sc.max_bounding_radius(), reach = 2 * rmax + sc.magnets.cutoff;
        if (reach > cell_edge) {
            return refuse(sc.source + ": magnets.cutoff = " + std::to_string(sc.magnets.cutoff) +
                          " m reaches past the ghost halo of a distributed run (one cell of " +
                          std::to_string(cell_edge) + " m): it must be at most 2 r_max = " +
                          std::to_string(2 * rmax) + " m" + one);
        }
    }
    if (sc.program.enabled && sc.program_range() > cell_edge) {
        return refuse(sc.source + ": program.reach = " + std::to_string(sc.program_reach()) +
                      " m reaches past the ghost halo of a distributed run (one cell of " + std::to_string(cell_edge) +
                      " m): a catom's neighbours must lie within 2 r_max = " + std::to_string(2 * sc.max_bounding_radius()) +
                      " m of its surface" + one);
    }
    return {};
}

double halo_reach(const Scene& sc) {
    const double rmax = sc.max_bounding_radius();
    double reach = 2 * rmax;
    if (sc.any_magnets()) reach = std::max(reach, 2 * rmax + sc.magnets.cutoff);
    if (sc.program.enabled) reach = std::max(reach, sc.program_range());
    return reach;
}

std::string distributed_why(int ranks, double cell_edge) {
    return std::to_string(ranks) + " MPI processes, cells of " + std::to_string(cell_edge) + " m partitioned by METIS";
}

}  // namespace parode
