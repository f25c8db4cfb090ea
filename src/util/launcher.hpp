// What an MPI launcher tells the processes it starts, read from its
// environment variables in one place: whether this process was started by
// one (mpirun, mpiexec, srun), how many processes it started, and how many of
// them share this node. Open MPI sets OMPI_COMM_WORLD_*, MPICH's Hydra PMI_*
// and MPI_LOCALNRANKS, PMIx PMIX_RANK, Slurm SLURM_NTASKS*.
// Trade-off: environment variables, not MPI calls: the command line decides
// whether to initialise MPI at all before it may call it, and a build without
// MPI can still refuse to run as N copies of itself.
#pragma once
#include <cstdlib>
#include <initializer_list>

namespace parode::launcher {

namespace detail {
// The first of `names` set to a positive integer, else 0.
inline int first_count(std::initializer_list<const char*> names) {
    for (const char* v : names) {
        if (const char* s = std::getenv(v)) {
            char* end = nullptr;
            const long n = std::strtol(s, &end, 10);
            if (end != s && *end == '\0' && n > 0 && n < (1L << 30)) return static_cast<int>(n);
        }
    }
    return 0;
}
}  // namespace detail

// Started by an MPI launcher: MPI is initialised only then.
inline bool launched() {
    for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK", "PMI_SIZE", "MPI_LOCALNRANKS"}) {
        if (std::getenv(v)) return true;
    }
    return false;
}

// Processes the launcher started (1 when none says).
inline int size() {
    const int n = detail::first_count({"OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "SLURM_NTASKS"});
    return n > 0 ? n : 1;
}

// Processes on this node (1 when none says).
inline int local_size() {
    const int n = detail::first_count({"OMPI_COMM_WORLD_LOCAL_SIZE", "MPI_LOCALNRANKS", "SLURM_NTASKS_PER_NODE"});
    return n > 0 ? n : 1;
}

}  // namespace parode::launcher
