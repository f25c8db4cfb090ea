# ctest driver (cmake -P): installs the build into a fresh temporary prefix,
# checks the installed layout and program, then configures, builds and runs
# tests/consumer against that prefix only. Variables: BUILD_DIR, SOURCE_DIR,
# WORK_DIR, GENERATOR, CXX_COMPILER, C_COMPILER, LINK_FLAGS (may be empty).
# Trade-off: a real install and a real find_package in a separate CMake
# project (seconds of configure and compile) rather than checking the
# generated files by eye: what a user's project sees is what is tested.
foreach(v BUILD_DIR SOURCE_DIR WORK_DIR GENERATOR CXX_COMPILER C_COMPILER)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "install_consumer.cmake: -D${v}=... is required")
  endif()
endforeach()

function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  message(STATUS "${what}:\n${out}${err}")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc})")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE "${WORK_DIR}")
set(prefix "${WORK_DIR}/prefix")
step("install" "${CMAKE_COMMAND}" --install "${BUILD_DIR}" --prefix "${prefix}")

foreach(f bin/parode include/parode/omp/grid/parallel_collide.hpp include/parode/collide/contacts.hpp
          include/parode/scene/scene.hpp)
  if(NOT EXISTS "${prefix}/${f}")
    message(FATAL_ERROR "not installed: ${f}")
  endif()
endforeach()
foreach(f parodeConfig.cmake parodeConfigVersion.cmake parodeTargets.cmake)
  file(GLOB found "${prefix}/lib*/cmake/parode/${f}" "${prefix}/lib/*/cmake/parode/${f}")
  if(NOT found)
    message(FATAL_ERROR "not installed: <libdir>/cmake/parode/${f}")
  endif()
endforeach()

step("installed parode --version" "${prefix}/bin/parode" --version)
if(NOT step_output MATCHES "parode ")
  message(FATAL_ERROR "installed parode --version printed no version")
endif()

step("configure the consumer" "${CMAKE_COMMAND}" -S "${SOURCE_DIR}/tests/consumer" -B "${WORK_DIR}/build"
     -G "${GENERATOR}" "-DCMAKE_PREFIX_PATH=${prefix}" "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}"
     "-DCMAKE_C_COMPILER=${C_COMPILER}" "-DCMAKE_EXE_LINKER_FLAGS=${LINK_FLAGS}"
     -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON)
step("build the consumer" "${CMAKE_COMMAND}" --build "${WORK_DIR}/build")
step("run the consumer" "${WORK_DIR}/build/consumer")
if(NOT step_output MATCHES "consumer: ok")
  message(FATAL_ERROR "the consumer did not report ok")
endif()
# The program library, run by the installed parode on the magnetic prism:
# every catom of the 4 x 4 x 4 prism hears from each neighbour once.
file(WRITE "${WORK_DIR}/program.toml" "[program]\nname = \"${WORK_DIR}/build/neighbour_count.so\"\n")
file(READ "${SOURCE_DIR}/jobs/scenes/magnetic-tennis.toml" prism)
file(READ "${WORK_DIR}/program.toml" program)
file(WRITE "${WORK_DIR}/scene.toml" "${prism}\n${program}")
step("run the program library" "${prefix}/bin/parode" run "${WORK_DIR}/scene.toml" --steps 3 -q
     --set catoms.count=64 --report "${WORK_DIR}/program.json")
file(READ "${WORK_DIR}/program.json" report)
string(JSON name GET "${report}" program name)
string(JSON heard GET "${report}" program values heard 0)
string(JSON count GET "${report}" program values neighbours 0)
if(NOT name STREQUAL "neighbour-count" OR NOT heard EQUAL count OR NOT count EQUAL 3)
  message(FATAL_ERROR "the program library ran wrongly: ${name}, catom 0 heard ${heard} of ${count} neighbours (3 expected)")
endif()
file(REMOVE_RECURSE "${WORK_DIR}")
