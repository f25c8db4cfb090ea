// Snapshot formats and the CSV writer (see snapshot.hpp).
#include "io/snapshot.hpp"

#include <fstream>
#include <ode/ode.h>
#include <stdexcept>

#include "domain/gather.hpp"
#include "util/errors.hpp"
#ifdef PARODE_HAVE_HDF5
#include "io/h5md.hpp"
#endif

namespace parode {
namespace {

// One line per body and frame; the root writes what every process sends it.
class CsvWriter final : public SnapshotWriter {
public:
    CsvWriter(const std::string& path, const Collectives& domain) : path_(path), domain_(domain) {
        if (!domain_.root()) return;
        out_.open(path);
        if (!out_) throw OutputError(path + ": cannot open snapshot file for writing");
        out_.precision(17);
        out_ << "step,body,x,y,z,qw,qx,qy,qz\n";
    }
    void write(const World& world, long step, double) override {
        const std::vector<double> rows = gather_rows(domain_, world, 7, [&world](std::size_t i, double* out) {
            const dReal* p = dBodyGetPosition(world.body(i));
            const dReal* q = dBodyGetQuaternion(world.body(i));
            for (int k = 0; k < 3; ++k) out[k] = p[k];
            for (int k = 0; k < 4; ++k) out[3 + k] = q[k];
        });
        for (std::size_t i = 0; i < rows.size() / 7; ++i) {
            const double* r = rows.data() + 7 * i;
            out_ << step << ',' << i;
            for (int k = 0; k < 7; ++k) out_ << ',' << r[k];
            out_ << '\n';
        }
        if (domain_.root() && !out_.flush()) throw OutputError(path_ + ": the snapshot could not be written (disk full?)");
    }

private:
    std::string path_;
    const Collectives& domain_;
    std::ofstream out_;
};

}  // namespace

bool is_h5md_path(const std::string& path) {
    for (const char* ext : {".h5", ".hdf5"}) {
        const std::string e(ext);
        if (path.size() > e.size() && path.compare(path.size() - e.size(), e.size(), e) == 0) return true;
    }
    return false;
}

std::string hdf5_version() {
#ifdef PARODE_HAVE_HDF5
    return h5md_library();
#else
    return "";
#endif
}

std::unique_ptr<SnapshotWriter> make_snapshot_writer(const std::string& path, const Scene& scene, const World& world,
                                                     const Collectives& domain, long step, double time,
                                                     std::size_t frames) {
    std::unique_ptr<SnapshotWriter> w;
    if (is_h5md_path(path)) {
#ifdef PARODE_HAVE_HDF5
        w = make_h5md_writer(path, scene, world, domain, frames);
#else
        (void)scene;
        (void)frames;
        throw std::invalid_argument("--snapshot " + path + ": this parode was built without HDF5, so it cannot write "
                                    "H5MD; install libhdf5-dev (libhdf5-openmpi-dev with MPI) and rebuild, or name a "
                                    ".csv file");
#endif
    } else {
        w = std::make_unique<CsvWriter>(path, domain);
    }
    w->write(world, step, time);
    return w;
}

}  // namespace parode
