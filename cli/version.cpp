// `parode --version`: the project version and git commit (both fixed when CMake
// configures the build), ODE's version and precision, OpenMP and MPI.
// Trade-off: the commit is the one checked out at configure time; a build made
// after later commits without reconfiguring shows the older one (the build
// folder is reconfigured by every `cmake --preset`).
#include <ode/ode.h>

#include <string>

#include "cli_common.hpp"
#include "io/snapshot.hpp"

#ifndef PARODE_VERSION
#define PARODE_VERSION "unknown"
#endif
#ifndef PARODE_GIT_COMMIT
#define PARODE_GIT_COMMIT ""
#endif
#ifndef PARODE_ODE_VERSION
#define PARODE_ODE_VERSION "unknown"
#endif
#ifndef PARODE_OPENMP_VERSION
#define PARODE_OPENMP_VERSION ""
#endif
#ifndef PARODE_MPI_VERSION
#define PARODE_MPI_VERSION ""
#endif

namespace parode::cli {

std::string version_text() {
    const std::string commit = PARODE_GIT_COMMIT, omp = PARODE_OPENMP_VERSION, mpi = PARODE_MPI_VERSION;
    std::string s = "parode " PARODE_VERSION;
    s += commit.empty() ? " (git commit unknown)\n" : " (git commit " + commit + ")\n";
    s += "ODE " PARODE_ODE_VERSION ", ";
    s += dCheckConfiguration("ODE_double_precision") ? "double precision\n" : "single precision\n";
    s += omp.empty() ? "OpenMP: no (every stage runs on one thread)\n"
                     : "OpenMP: yes (" + omp + "), up to " + std::to_string(kMaxThreads) + " threads\n";
    s += mpi.empty() ? "MPI: no (runs on one process)"
                     : "MPI: yes (" + mpi + "): distributed runs under mpirun, mpiexec or srun";
    const std::string h5 = hdf5_version();
    s += h5.empty() ? "\nHDF5: no (snapshots as CSV only)" : "\nHDF5: " + h5 + " (H5MD snapshots)";
    return s;
}

}  // namespace parode::cli
