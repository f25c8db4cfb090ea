// The processes of a run, as the command line sees them: under an MPI
// launcher (mpirun, mpiexec, srun) MPI is initialised and a run on more than
// one process gets the distributed decomposition ("mpi" in the stage registry); otherwise MPI is never touched
// and the run is one process. Only the root process prints and writes.
// A failure that every process meets at the same point (a scene error, the
// guard, a bad option) ends every process with its exit code; any other
// failure on one process ends all of them through MPI_Abort, so no process
// waits forever for one that stopped.
// Trade-off: the launcher is recognised by its environment variables, which
// covers Open MPI, MPICH and Slurm; a build without MPI refuses to run as
// several copies rather than silently simulating the same scene N times.
#pragma once
#include <memory>
#include <string>


namespace parode::cli {

class Processes {
public:
    Processes(int& argc, char**& argv);
    ~Processes();
    Processes(const Processes&) = delete;
    Processes& operator=(const Processes&) = delete;

    int rank() const { return rank_; }
    int size() const { return size_; }
    bool root() const { return rank_ == 0; }
    // Ends the run on every process (a failure only this one met).
    [[noreturn]] void abort(int code) const;
    // One line on what runs where, for --version and the report.
    std::string describe() const;
    // Collective: {ping-pong one way, one neighbour-exchange round}, each with
    // `bytes` per message, in seconds; zeros on one process.
    std::pair<double, double> latency(int rounds, std::size_t bytes) const;

    static Processes* current();

private:
    struct Mpi;
    std::unique_ptr<Mpi> mpi_;
    int rank_ = 0, size_ = 1;
};

}  // namespace parode::cli
