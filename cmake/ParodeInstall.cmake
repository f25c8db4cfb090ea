# `cmake --install BUILD --prefix P`: the parode program (bin/), its static
# libraries (lib/), the headers (include/parode/<folder>/..., omp/ and mpi/
# under include/parode/omp and include/parode/mpi) and a CMake package
# (lib/cmake/parode: parodeConfig.cmake, its version file, the exported
# targets parode::core, parode::omp and, in MPI builds, parode::partition and
# parode::mpi), so that another ODE program can find_package(parode) and call
# parode::collide_space (omp/parallel_collide.hpp).
# Trade-off: static libraries only, so an installed program needs no runtime
# path; a consumer links ODE, OpenMP, MPI and METIS itself, found again by the
# package's config file exactly as this build found them.
include(CMakePackageConfigHelpers)

set(PARODE_CMAKE_DIR "${CMAKE_INSTALL_LIBDIR}/cmake/parode")
set(_parode_libs parode_core parode_omp)
if(TARGET parode_mpi)
  list(APPEND _parode_libs parode_partition parode_mpi)
endif()
foreach(lib IN LISTS _parode_libs)
  string(REPLACE "parode_" "" _export_name "${lib}")
  set_target_properties(${lib} PROPERTIES EXPORT_NAME ${_export_name})
endforeach()

install(TARGETS parode RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS ${_parode_libs} EXPORT parodeTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/parode)
install(DIRECTORY src/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/parode FILES_MATCHING PATTERN "*.hpp")
install(DIRECTORY omp/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/parode/omp FILES_MATCHING PATTERN "*.hpp")
if(TARGET parode_mpi)
  install(DIRECTORY mpi/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/parode/mpi FILES_MATCHING PATTERN "*.hpp")
  install(FILES cmake/FindMETIS.cmake DESTINATION ${PARODE_CMAKE_DIR})
endif()
install(EXPORT parodeTargets NAMESPACE parode:: DESTINATION ${PARODE_CMAKE_DIR})

# What the config file must find again for the exported targets.
set(PARODE_WITH_OPENMP_FOUND ${OpenMP_CXX_FOUND})
set(PARODE_WITH_MPI_FOUND OFF)
if(TARGET parode_mpi)
  set(PARODE_WITH_MPI_FOUND ON)
endif()
configure_package_config_file(cmake/parodeConfig.cmake.in "${PROJECT_BINARY_DIR}/parodeConfig.cmake"
                              INSTALL_DESTINATION ${PARODE_CMAKE_DIR})
# 0.x: a minor version may change the interfaces, so only the same minor matches.
write_basic_package_version_file("${PROJECT_BINARY_DIR}/parodeConfigVersion.cmake"
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES "${PROJECT_BINARY_DIR}/parodeConfig.cmake" "${PROJECT_BINARY_DIR}/parodeConfigVersion.cmake"
        DESTINATION ${PARODE_CMAKE_DIR})
