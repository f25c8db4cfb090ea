#!/usr/bin/env bash
# Sets up and builds (jobs/setup.sh), then runs the default test suite: every
# ctest label except `longrun` (use `ctest --preset ci -L longrun` for those).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
"$root/jobs/setup.sh" ci
cd "$root"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
exec ctest --preset ci "$@"
