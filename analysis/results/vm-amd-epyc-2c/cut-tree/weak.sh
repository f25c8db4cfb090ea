#!/bin/sh
# The partition step at the same catoms a rank (PER_RANK, default 50,000) on
# 1, 2, 4 and 8 ranks: the root's gathered partition (METIS against the
# bisection, parallel.partitioner "best" below 2^18 occupied cells) against
# the tree every process cuts together ("bisection"); STEPS steps (default
# 2), oversubscribed. Usage (repository root): sh .../cut-tree/weak.sh
set -e
OUT=$(dirname "$0")
PARODE=${PARODE:-build/ci/parode}
PER=${PER_RANK:-50000}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
for r in 1 2 4 8; do
  for v in best bisection; do
    mpiexec -n $r --oversubscribe $PARODE run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
      --steps ${STEPS:-2} --threads 1 --set catoms.count=$((PER * r)) --set "parallel.partitioner=\"$v\"" \
      --report $OUT/weak-$v-r$r.json
  done
done
