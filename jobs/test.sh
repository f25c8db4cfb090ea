#!/usr/bin/env bash
# Sets up and builds (jobs/setup.sh), then runs the default test suite: every
# ctest label except `longrun` (use `ctest --preset ci -L longrun` for those).
# Under CI (CI=true), or with PARODE_SANITIZER_TESTS=1, it then builds the
# `debug` preset (AddressSanitizer and UBSan) into build/debug and runs the
# unit and OpenMP tests there as well: about 12 more minutes on 2 cores.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/jobs/setup.sh" ci
cd "$root"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
ctest --preset ci "$@"
if [ "${CI:-}" = "true" ] || [ "${PARODE_SANITIZER_TESTS:-0}" = "1" ]; then
  echo "== unit and OpenMP tests under AddressSanitizer and UBSan (preset debug)"
  cmake --preset debug -DPARODE_WERROR=ON > /dev/null  # warnings are errors, as in the ci preset
  cmake --build --preset debug -j"$(nproc)"
  ctest --preset debug -L 'unit|omp'
fi
