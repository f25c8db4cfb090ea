#!/usr/bin/env bash
# Collision-stage timings of the sphere prism (radius 0.5, touching, 1 % jitter,
# over a plane) for ODE's hash and sweep-and-prune spaces and the grid backend
# on 1 and 2 threads (or THREADS), at 1,000 / 8,000 / 64,000 / 1,000,000 spheres
# (or SIZES, as cube edges). Writes CSV to results/omp_scaling-<host>.csv.
# Above 64,000 spheres only the grid runs: ODE's hash space needs an n^2/8-byte
# matrix (125 GB at 10^6) and sweep-and-prune degenerates on the lattice (every
# sphere of an x-slab overlaps on the sweep axis: ~10^10 tests at 10^6).
# Then the whole pipeline: `parode run` of tennis (CATOMS, default 8000) with the
# grid backend and the parallel solver for STEPS steps on each thread count
# 1..cores (or THREADS), one JSON run report each in results/scaling-<host>/;
# analysis/scaling.py turns them into a speed-up and efficiency table.
# Usage: jobs/omp_scaling.sh [build-dir]    (default build/omp; built if missing)
# Trade-off: backends alternate within each repetition and medians are kept, so
# a noisy machine inflates spread rather than biasing one backend.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$ROOT/build/omp}"
SIZES="${SIZES:-10 20 40 100}"
THREADS="${THREADS:-$(seq -s, 1 "$(nproc)")}"
CATOMS="${CATOMS:-8000}"
STEPS="${STEPS:-300}"
OUT="$ROOT/results/omp_scaling-$(hostname).csv"

if [ ! -x "$BUILD/tests/omp/omp_collide_bench" ]; then
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPARODE_WITH_MPI=OFF >/dev/null
fi
cmake --build "$BUILD" --target omp_collide_bench parode
mkdir -p "$(dirname "$OUT")"
: >"$OUT"
for n in $SIZES; do
  if [ "$n" -le 40 ]; then backends="ode-hash,ode-sap,grid"; else backends="grid"; fi
  reps=21
  [ "$n" -ge 40 ] && reps=7
  [ "$n" -ge 100 ] && reps=5
  skip=1  # the CSV header, once
  [ -s "$OUT" ] && skip=2
  "$BUILD/tests/omp/omp_collide_bench" "$n" "$reps" "$backends" "$THREADS" | tail -n +"$skip" >>"$OUT"
done
cat "$OUT"

REPORTS="$ROOT/results/scaling-$(hostname)"
mkdir -p "$REPORTS"
for t in ${THREADS//,/ }; do
  "$BUILD/parode" run "$ROOT/jobs/scenes/tennis.toml" --set "catoms.count=$CATOMS" --steps "$STEPS" \
    --collide grid --solver parallel --threads "$t" -q --report "$REPORTS/tennis-$CATOMS-t$t.json"
done
python3 "$ROOT/analysis/scaling.py" "$REPORTS"
