// A thin layer over the HDF5 C API for the snapshot writer: handles that close
// themselves, every failure turned into an OutputError naming the file and
// HDF5's own reason, and the few shapes H5MD needs (groups, string and number
// attributes, chunked datasets that grow by frames, block writes). A file is
// opened by every process of the domain together (MPI-IO; each process writes its own block)
// or by the one process alone (HDF5's POSIX driver), as Domain::h5_parallel
// decides; every call here is then collective.
// Crash safety: a file of one process is written in HDF5's SWMR mode (file
// format 1.10) once its objects exist, so that its metadata reach the disk in
// an order that keeps it readable at every moment; a file of several
// processes (MPI-IO, where HDF5 has no SWMR) keeps format 1.8, whose
// superblock carries no "open for writing" flag, and whose metadata reach the
// disk in no fixed order: the writer then takes the space of every frame it
// expects at creation (`series` with `early`), so that a frame changes no
// metadata but its step count's extent (h5md.cpp). Both are flushed after
// every frame by the writer. Strings are variable-length UTF-8, as h5py
// writes them.
// Trade-off: the C API (the C++ binding is not supported with parallel HDF5)
// behind a dozen functions, rather than a general wrapper.
#pragma once
#include <hdf5.h>

#include <cstdint>
#include <string>
#include <vector>

#include "domain/collectives.hpp"

namespace parode::h5 {

// An hid_t and the function that closes it.
class Id {
public:
    Id() = default;
    Id(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
    Id(Id&& o) noexcept : id_(o.id_), close_(o.close_) { o.id_ = H5I_INVALID_HID; }
    Id& operator=(Id&& o) noexcept;
    Id(const Id&) = delete;
    Id& operator=(const Id&) = delete;
    ~Id() { reset(); }
    void reset();
    hid_t release() {  // the caller closes it
        const hid_t id = id_;
        id_ = H5I_INVALID_HID;
        return id;
    }
    hid_t get() const { return id_; }
    explicit operator bool() const { return id_ >= 0; }

private:
    hid_t id_ = H5I_INVALID_HID;
    herr_t (*close_)(hid_t) = nullptr;
};

// Element types: HDF5's native ones in memory, little-endian in the file.
enum class Type { F64, F32, I64 };

class File {
public:
    // Creates (truncates) `path`; collective over `domain`.
    File(const std::string& path, const Collectives& domain);
    // Collective; the object handles must be closed first. Throws on failure.
    void close();
    // Once every group, dataset and attribute exists: SWMR writing, for a
    // file of one process (nothing for several).
    void start_swmr() const;
    bool swmr() const { return swmr_; }
    bool single() const { return single_; }  // one process (HDF5's POSIX driver)
    // Collective: what was written so far, to the operating system.
    void flush() const;

    const std::string& path() const { return path_; }
    hid_t id() const { return file_.get(); }
    Id group(hid_t parent, const std::string& name) const;
    void link(hid_t target, hid_t parent, const std::string& name) const;  // a hard link

    void attribute(hid_t obj, const std::string& name, const std::string& value) const;
    void attribute(hid_t obj, const std::string& name, const std::vector<std::string>& values) const;
    void attribute(hid_t obj, const std::string& name, const std::vector<std::int64_t>& values) const;  // stored as int32
    void attribute(hid_t obj, const std::string& name, double value) const;

    // A dataset of `dims`; dims[0] == 0 makes it grow along its first axis
    // (frames), in chunks of one frame by at most 2^20 rows.
    Id dataset(hid_t parent, const std::string& name, Type type, const std::vector<hsize_t>& dims) const;
    // A time series: its first axis (frames) holds dims[0] frames now and may
    // grow or shrink; chunks of `frames` frames by at most 2^20 rows. `early`:
    // the file space of every chunk within the extent is taken when the
    // extent is set (never filled: every element is written).
    Id series(hid_t parent, const std::string& name, Type type, const std::vector<hsize_t>& dims, hsize_t frames,
              bool early) const;
    // Sets `dset`'s first axis to `n` frames (grows or shrinks it).
    void extend(hid_t dset, hsize_t n) const;
    // Writes the box `start`, `count` of `dset` from `data` (contiguous, in
    // row-major order); a process with nothing to write passes a zero count.
    void write(hid_t dset, Type type, const std::vector<hsize_t>& start, const std::vector<hsize_t>& count,
               const void* data) const;

    // Throws OutputError("<path>: <what>: <HDF5's reason>") when rc < 0.
    std::int64_t check(std::int64_t rc, const std::string& what) const;

private:
    std::string path_;
    bool single_ = false;  // one process, HDF5's POSIX driver
    mutable bool swmr_ = false;
    Id transfer_;
    Id file_;
};

}  // namespace parode::h5
