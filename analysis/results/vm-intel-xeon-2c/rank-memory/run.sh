#!/bin/sh
# The fullest rank's peak memory with PER (default 250,000) catoms a rank on RANKS
# (default 1 8) ranks, STEPS (2) steps, REPEATS (2) interleaved turns, huge pages off,
# this build ("after") and, with BEFORE=path/to/parode, that one.
# Usage (repository root): [BEFORE=...] [RANKS="1 2 4 8"] sh .../rank-memory/run.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive PARODE_HUGE_PAGES=0
OUT=${OUT:-$(dirname "$0")}
for k in $(seq ${REPEATS:-2}); do
for r in ${RANKS:-1 8}; do
for b in ${BEFORE:+before} after; do
  P=build/ci/parode; [ $b = before ] && P=$BEFORE
  mpiexec -n $r --oversubscribe $P run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
    --steps ${STEPS:-2} --threads 1 --set catoms.count=$((${PER:-250000} * r)) --report $OUT/m-$b-r$r-$k.json
done; done; done
