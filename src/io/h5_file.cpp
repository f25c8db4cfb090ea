// HDF5 files for the snapshot writer (see h5_file.hpp).
#include "io/h5_file.hpp"

#include <algorithm>
#include <type_traits>

#include "util/errors.hpp"

namespace parode::h5 {
namespace {

static_assert(std::is_same_v<hid_t, std::int64_t>, "Domain::h5_parallel passes hid_t as int64_t (HDF5 1.10+)");

constexpr hsize_t kChunkRows = hsize_t(1) << 20;  // at most 32 MB a chunk of 4 doubles a row

// The innermost description on HDF5's error stack (the actual reason).
herr_t keep_last(unsigned, const H5E_error2_t* e, void* out) {
    if (e->desc && *e->desc) *static_cast<std::string*>(out) = e->desc;
    return 0;
}

std::string reason() {
    std::string why;
    H5Ewalk2(H5E_DEFAULT, H5E_WALK_DOWNWARD, keep_last, &why);
    H5Eclear2(H5E_DEFAULT);
    return why.empty() ? "HDF5 gave no reason" : why;
}

hid_t file_type(Type t) { return t == Type::F64 ? H5T_IEEE_F64LE : t == Type::F32 ? H5T_IEEE_F32LE : H5T_STD_I64LE; }
hid_t memory_type(Type t) { return t == Type::F64 ? H5T_NATIVE_DOUBLE : t == Type::F32 ? H5T_NATIVE_FLOAT : H5T_NATIVE_INT64; }

// A scalar for one value, else a list of n.
Id attribute_space(const File& f, std::size_t n) {
    const hsize_t dims = n;
    return Id(f.check(n == 1 ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &dims, nullptr), "attribute space"), H5Sclose);
}

void put(const File& f, hid_t obj, const std::string& name, hid_t type, hid_t memory, std::size_t n, const void* data) {
    Id space = attribute_space(f, n);
    Id a(f.check(H5Acreate2(obj, name.c_str(), type, space.get(), H5P_DEFAULT, H5P_DEFAULT), "attribute " + name), H5Aclose);
    f.check(H5Awrite(a.get(), memory, data), "attribute " + name);
}

}  // namespace

Id& Id::operator=(Id&& o) noexcept {
    if (this != &o) {
        reset();
        id_ = o.id_;
        close_ = o.close_;
        o.id_ = H5I_INVALID_HID;
    }
    return *this;
}

void Id::reset() {
    if (id_ >= 0 && close_) close_(id_);
    id_ = H5I_INVALID_HID;
}

File::File(const std::string& path, const Collectives& domain) : path_(path) {
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // errors become exceptions with HDF5's reason
    Id access(check(H5Pcreate(H5P_FILE_ACCESS), "file access list"), H5Pclose);
    transfer_ = Id(check(H5Pcreate(H5P_DATASET_XFER), "transfer list"), H5Pclose);
    domain.h5_parallel(access.get(), transfer_.get());
    single_ = H5Pget_driver(access.get()) == H5FD_SEC2;
    // One process: format 1.10 (readers since 2016), which SWMR needs.
    // Several: format 1.8, as H5MD recommends (readers since 2008).
    const H5F_libver_t format = single_ ? H5F_LIBVER_V110 : H5F_LIBVER_V18;
    check(H5Pset_libver_bounds(access.get(), format, format), "format version");
    file_ = Id(check(H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, access.get()), "cannot create the file"), H5Fclose);
}

void File::close() {
    if (!file_) return;
    transfer_.reset();
    check(H5Fclose(file_.release()), "closing the file (disk full?)");
}

void File::start_swmr() const {
    if (!single_) return;
    check(H5Fstart_swmr_write(file_.get()), "SWMR writing");
    swmr_ = true;
}

void File::flush() const { check(H5Fflush(file_.get(), H5F_SCOPE_LOCAL), "flushing (disk full?)"); }

std::int64_t File::check(std::int64_t rc, const std::string& what) const {
    if (rc < 0) throw OutputError(path_ + ": " + what + ": " + reason());
    return rc;
}

Id File::group(hid_t parent, const std::string& name) const {
    return Id(check(H5Gcreate2(parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), "group " + name), H5Gclose);
}

void File::link(hid_t target, hid_t parent, const std::string& name) const {
    check(H5Lcreate_hard(target, ".", parent, name.c_str(), H5P_DEFAULT, H5P_DEFAULT), "link " + name);
}

void File::attribute(hid_t obj, const std::string& name, const std::string& value) const {
    attribute(obj, name, std::vector<std::string>{value});
}

// Variable-length UTF-8 strings, as h5py writes them: Python readers get str.
void File::attribute(hid_t obj, const std::string& name, const std::vector<std::string>& values) const {
    Id type(check(H5Tcopy(H5T_C_S1), "string type"), H5Tclose);
    check(H5Tset_size(type.get(), H5T_VARIABLE), "string type");
    check(H5Tset_cset(type.get(), H5T_CSET_UTF8), "string type");
    std::vector<const char*> ptrs;
    for (const std::string& v : values) ptrs.push_back(v.c_str());
    put(*this, obj, name, type.get(), type.get(), values.size(), ptrs.data());
}

void File::attribute(hid_t obj, const std::string& name, const std::vector<std::int64_t>& values) const {
    put(*this, obj, name, H5T_STD_I32LE, H5T_NATIVE_INT64, values.size(), values.data());
}

void File::attribute(hid_t obj, const std::string& name, double value) const {
    put(*this, obj, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, 1, &value);
}

Id File::dataset(hid_t parent, const std::string& name, Type type, const std::vector<hsize_t>& dims) const {
    if (dims[0] == 0) return series(parent, name, type, dims, 1, false);
    Id create(check(H5Pcreate(H5P_DATASET_CREATE), "dataset list"), H5Pclose);
    check(H5Pset_fill_time(create.get(), H5D_FILL_TIME_NEVER), "fill time");  // every element is written
    Id space(check(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr), "space of " + name), H5Sclose);
    return Id(check(H5Dcreate2(parent, name.c_str(), file_type(type), space.get(), H5P_DEFAULT, create.get(), H5P_DEFAULT),
                    "dataset " + name),
              H5Dclose);
}

Id File::series(hid_t parent, const std::string& name, Type type, const std::vector<hsize_t>& dims, hsize_t frames,
                bool early) const {
    std::vector<hsize_t> max = dims, chunk = dims;
    max[0] = H5S_UNLIMITED;
    chunk[0] = std::max<hsize_t>(1, std::min(frames, kChunkRows));
    if (chunk.size() > 1) chunk[1] = std::max<hsize_t>(1, std::min(chunk[1], kChunkRows));
    Id create(check(H5Pcreate(H5P_DATASET_CREATE), "dataset list"), H5Pclose);
    check(H5Pset_fill_time(create.get(), H5D_FILL_TIME_NEVER), "fill time");  // every element is written
    check(H5Pset_chunk(create.get(), static_cast<int>(chunk.size()), chunk.data()), "chunks of " + name);
    if (early) check(H5Pset_alloc_time(create.get(), H5D_ALLOC_TIME_EARLY), "allocation of " + name);
    Id space(check(H5Screate_simple(static_cast<int>(dims.size()), dims.data(), max.data()), "space of " + name), H5Sclose);
    return Id(check(H5Dcreate2(parent, name.c_str(), file_type(type), space.get(), H5P_DEFAULT, create.get(), H5P_DEFAULT),
                    "dataset " + name),
              H5Dclose);
}

void File::extend(hid_t dset, hsize_t n) const {
    Id space(check(H5Dget_space(dset), "dataset space"), H5Sclose);
    std::vector<hsize_t> dims(static_cast<std::size_t>(check(H5Sget_simple_extent_ndims(space.get()), "dataset rank")));
    H5Sget_simple_extent_dims(space.get(), dims.data(), nullptr);
    dims[0] = n;
    check(H5Dset_extent(dset, dims.data()), "sizing a dataset");
}

void File::write(hid_t dset, Type type, const std::vector<hsize_t>& start, const std::vector<hsize_t>& count,
                 const void* data) const {
    const bool none = std::find(count.begin(), count.end(), hsize_t(0)) != count.end();
    Id fspace(check(H5Dget_space(dset), "dataset space"), H5Sclose);
    const hsize_t one = 1;  // a process with nothing to write selects nothing of a 1-element space
    const int rank = none ? 1 : static_cast<int>(count.size());
    Id mspace(check(H5Screate_simple(rank, none ? &one : count.data(), nullptr), "memory space"), H5Sclose);
    if (none) {
        check(H5Sselect_none(fspace.get()), "selection");
        check(H5Sselect_none(mspace.get()), "selection");
    } else {
        check(H5Sselect_hyperslab(fspace.get(), H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr), "selection");
    }
    check(H5Dwrite(dset, memory_type(type), mspace.get(), fspace.get(), transfer_.get(), data), "writing (disk full?)");
}

}  // namespace parode::h5
