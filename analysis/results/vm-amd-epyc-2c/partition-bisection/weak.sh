#!/bin/sh
# Peak memory a rank with the same catoms a rank (PER_RANK, default 50,000) on
# 1, 2, 4 and 8 ranks, METIS alone against the default; STEPS steps,
# oversubscribed (OUT: where the reports go; VARIANTS: the partitioners). Usage (repository root): sh .../partition-bisection/weak.sh
set -e
OUT=${OUT:-$(dirname "$0")}
PARODE=${PARODE:-build/ci/parode}
PER=${PER_RANK:-50000}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
for r in 1 2 4 8; do
  for v in ${VARIANTS:-metis best}; do
    mpiexec -n $r --oversubscribe $PARODE run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
      --steps ${STEPS:-2} --threads 1 --set catoms.count=$((PER * r)) --set "parallel.partitioner=\"$v\"" \
      --report $OUT/weak-$v-r$r.json
  done
done
