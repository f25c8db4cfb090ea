# HDF5 for the H5MD snapshots, in the flavour that matches the build. Debian
# installs its flavours side by side (headers in /usr/include/hdf5/serial and
# /usr/include/hdf5/openmpi, pkg-config modules hdf5-serial and hdf5-openmpi;
# the plain module `hdf5` follows whichever was installed last), so the module
# is named explicitly: the Open MPI flavour when MPI is built in (the ranks
# write one file together), the serial one otherwise. Other systems fall back
# to the plain `hdf5` module, which must then be parallel for an MPI build.
# Defines the target parode::hdf5 and PARODE_HDF5_FLAVOUR ("parallel" or
# "serial"), or nothing when PARODE_WITH_HDF5 is OFF.
# Trade-off: pkg-config rather than FindHDF5, which may pick either flavour
# through the compiler wrappers (h5cc, h5pcc) on a machine that has both.
option(PARODE_WITH_HDF5 "Write H5MD snapshots (HDF5: libhdf5-dev, libhdf5-openmpi-dev with MPI)" ON)
if(NOT PARODE_WITH_HDF5)
  return()
endif()
if(PARODE_WITH_MPI)
  set(_parode_hdf5_module hdf5-openmpi)
else()
  set(_parode_hdf5_module hdf5-serial)
endif()
pkg_check_modules(PARODE_HDF5 QUIET IMPORTED_TARGET GLOBAL ${_parode_hdf5_module})
if(NOT PARODE_HDF5_FOUND)
  set(_parode_hdf5_module hdf5)
  pkg_check_modules(PARODE_HDF5 QUIET IMPORTED_TARGET GLOBAL hdf5)
endif()
set(PARODE_HDF5_MODULE ${_parode_hdf5_module})  # parodeConfig.cmake looks it up again
if(NOT PARODE_HDF5_FOUND)
  message(FATAL_ERROR "PARODE_WITH_HDF5 needs HDF5 (pkg-config ${_parode_hdf5_module}: Debian's "
                      "libhdf5-openmpi-dev with MPI, libhdf5-dev without): run jobs/setup.sh, or configure "
                      "with -DPARODE_WITH_HDF5=OFF (then .h5 snapshots are refused)")
endif()
include(CheckSymbolExists)
set(CMAKE_REQUIRED_INCLUDES ${PARODE_HDF5_INCLUDE_DIRS})
check_symbol_exists(H5_HAVE_PARALLEL "H5pubconf.h" PARODE_HDF5_PARALLEL)
unset(CMAKE_REQUIRED_INCLUDES)
if(PARODE_WITH_MPI AND NOT PARODE_HDF5_PARALLEL)
  message(FATAL_ERROR "an MPI build needs the parallel HDF5 (libhdf5-openmpi-dev); found a serial one in "
                      "${PARODE_HDF5_INCLUDE_DIRS}")
endif()
if(PARODE_HDF5_PARALLEL)
  set(PARODE_HDF5_FLAVOUR parallel)
else()
  set(PARODE_HDF5_FLAVOUR serial)
endif()
add_library(parode::hdf5 ALIAS PkgConfig::PARODE_HDF5)
