// MPI start-up and the choice of domain (see processes.hpp).
#include "processes.hpp"

#include <algorithm>
#include <cstdlib>
#include <stdexcept>

#include "util/launcher.hpp"

#ifdef PARODE_HAVE_MPI
#include "comm.hpp"
#endif

namespace parode::cli {
namespace {

Processes* g_current = nullptr;

}  // namespace

#ifdef PARODE_HAVE_MPI
struct Processes::Mpi {
    mpi::Session session;
    mpi::Comm comm;
    Mpi(int& argc, char**& argv) : session(argc, argv) {}
};
#else
struct Processes::Mpi {};
#endif

Processes::Processes(int& argc, char**& argv) {
    g_current = this;
#ifdef PARODE_HAVE_MPI
    if (mpi::launched()) {
        mpi_ = std::make_unique<Mpi>(argc, argv);
        rank_ = mpi_->comm.rank();
        size_ = mpi_->comm.size();
    }
#else
    (void)argc;
    (void)argv;
    if (launcher::size() > 1) {
        throw std::invalid_argument("this parode was built without MPI, and " + std::to_string(launcher::size()) +
                                    " copies of it would each simulate the whole scene; build it with the ci, mpi "
                                    "or hybrid preset, or run it without a launcher");
    }
#endif
}

Processes::~Processes() { g_current = nullptr; }

Processes* Processes::current() { return g_current; }

void Processes::abort(int code) const {
#ifdef PARODE_HAVE_MPI
    if (mpi_) mpi_->comm.abort(code);
#endif
    std::exit(code);
}

std::pair<double, double> Processes::latency([[maybe_unused]] int rounds, [[maybe_unused]] std::size_t bytes) const {
#ifdef PARODE_HAVE_MPI
    if (size_ > 1) return {mpi_->comm.ping_pong_latency(rounds, bytes), mpi_->comm.exchange_round(rounds, bytes)};
#endif
    return {0.0, 0.0};
}

std::string Processes::describe() const {
#ifdef PARODE_HAVE_MPI
    return mpi_ ? std::to_string(size_) + " MPI process(es)" : "one process (MPI built in, not launched)";
#else
    return "one process (built without MPI)";
#endif
}

}  // namespace parode::cli
