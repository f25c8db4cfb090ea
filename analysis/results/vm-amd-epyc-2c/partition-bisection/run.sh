#!/bin/sh
# The partition's figures (deterministic: ghost fraction, edge cut, the
# partition's colour imbalance, which partitioner won) of 10^6 tennis catoms
# on 2 to 16 ranks, METIS alone against the default (the better of METIS and
# the bisection) and the bisection alone; STEPS steps, oversubscribed, each
# rank's peak memory in the report.
# Usage (repository root): sh analysis/results/vm-amd-epyc-2c/partition-bisection/run.sh
set -e
OUT=$(dirname "$0")
PARODE=${PARODE:-build/ci/parode}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
for r in ${RANKS:-2 4 8 16}; do
  for v in metis best bisection; do
    mpiexec -n $r --oversubscribe $PARODE run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
      --steps ${STEPS:-1} --threads 1 --set catoms.count=${CATOMS:-1000000} --set "parallel.partitioner=\"$v\"" \
      --report $OUT/${TAG:-}$v-r$r.json
  done
done
