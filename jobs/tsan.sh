#!/usr/bin/env bash
# Race detection for the OpenMP stages (collision, the parallel contact solver,
# the magnet pass): builds their tests with
# clang and LLVM's OpenMP runtime (libomp) under ThreadSanitizer, with Archer
# (libomp's TSan tool) so that TSan understands OpenMP's barriers and tasks,
# and runs them (the tests themselves use 1 to 4 threads). Installs what it
# needs from Debian (idempotent). ODE itself is not instrumented: TSan sees
# the accesses of parode's own code, which is where the parallel writes are.
# Usage: jobs/tsan.sh [build-dir]     (default build/tsan)
# Trade-off: a separate clang build (minutes) instead of GCC's libgomp, whose
# synchronisation TSan cannot see and would report as races.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build/tsan}"
LLVM=14
ARCHER="/usr/lib/llvm-$LLVM/lib/libarcher.so"

need=()
command -v "clang++-$LLVM" >/dev/null || need+=("clang-$LLVM")
[ -e "$ARCHER" ] || need+=("libomp-$LLVM-dev")
dpkg -s libode-dev libgtest-dev nlohmann-json3-dev cmake ninja-build >/dev/null 2>&1 ||
  need+=(libode-dev libgtest-dev nlohmann-json3-dev cmake ninja-build)
if [ "${#need[@]}" -gt 0 ]; then
  echo "tsan.sh: installing ${need[*]}"
  apt-get update -q
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q "${need[@]}"
fi

SAN="-fsanitize=thread -fno-omit-frame-pointer -g"
cmake -S "$ROOT" -B "$BUILD" -G Ninja \
  -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER="clang-$LLVM" -DCMAKE_CXX_COMPILER="clang++-$LLVM" \
  -DCMAKE_C_FLAGS="$SAN" -DCMAKE_CXX_FLAGS="$SAN" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" \
  -DOpenMP_CXX_FLAGS="-fopenmp=libomp" -DOpenMP_CXX_LIB_NAMES=omp \
  -DOpenMP_omp_LIBRARY="/usr/lib/llvm-$LLVM/lib/libomp.so" \
  -DPARODE_WITH_OPENMP=ON -DPARODE_WITH_MPI=OFF -DPARODE_WERROR=OFF >/dev/null
cmake --build "$BUILD" --target test_omp_collide parode

export OMP_TOOL_LIBRARIES="$ARCHER"
export ARCHER_OPTIONS="verbose=1"
export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 ignore_noninstrumented_modules=1"
status=0
for threads in 2 4; do
  echo "tsan.sh: OMP_NUM_THREADS=$threads"
  OMP_NUM_THREADS=$threads "$BUILD/tests/omp/test_omp_collide" || status=$?
  [ "$status" -eq 0 ] || break
  # The whole pipeline at a size where every parallel path runs: grid
  # collision, the parallel contact solver and (magnetic-tennis) the magnet pass.
  for scene in tennis magnetic-tennis; do
    "$BUILD/parode" run "$ROOT/jobs/scenes/$scene.toml" --set catoms.count=8000 --steps 20 \
      --collide grid --solver parallel --threads "$threads" -q || status=$?
  done
  [ "$status" -eq 0 ] || break
done
if [ "$status" -eq 0 ]; then
  echo "tsan.sh: clean (no data race reported)"
else
  echo "tsan.sh: FAILED (exit $status)"
fi
exit "$status"
