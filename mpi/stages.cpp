// Registration of the distributed decomposition (see stages.hpp).
#include "stages.hpp"

#include <memory>

#include "mpi_domain.hpp"

namespace parode::mpi {

void add_stages(Stages& stages) {
    stages.domain.add("mpi", [](const Scene& s, Execution& e) { return std::make_unique<MpiDomain>(s, e); }, {},
                      "METIS-partitioned cells over the MPI processes (needs a launcher)");
}

}  // namespace parode::mpi
