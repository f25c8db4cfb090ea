#!/bin/sh
# The fullest rank's peak memory on 1, 2, 4 and 8 ranks (oversubscribed) with
# the same catoms a rank, for each size a rank in PER (default "250000
# 1000000"): tennis prism, 2 steps, 1 thread a rank, huge pages off, REPEATS
# (default 2) turns; this build ("after") and, when BEFORE names another
# build's parode, that one ("before") interleaved. Reports
# m-<build>-n<per>-r<ranks>-<turn>.json beside this script; table.py makes
# the table. Usage (repository root, after cmake --build build/ci):
#   BEFORE=/tmp/base/build/parode sh analysis/results/vm-intel-xeon-2c/rank-memory-per-rank/run.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive PARODE_HUGE_PAGES=0
OUT=$(dirname "$0")
BUILDS=after; [ -n "$BEFORE" ] && BUILDS="before after"
for k in $(seq ${REPEATS:-2}); do
  for n in ${PER:-250000 1000000}; do for r in 1 2 4 8; do for b in $BUILDS; do
    P=build/ci/parode; [ $b = before ] && P=$BEFORE
    mpiexec -n $r --oversubscribe $P run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
      --steps 2 --threads 1 --set catoms.count=$((n * r)) --report $OUT/m-$b-n$n-r$r-$k.json
  done; done; done
done
