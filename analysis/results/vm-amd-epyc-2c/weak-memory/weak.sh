#!/bin/sh
# Peak memory a rank with the same catoms a rank (PER_RANK, default 50,000)
# on 1, 2, 4 and 8 ranks (RANKS; oversubscribed), STEPS steps (default 2),
# REPEATS interleaved turns (default 3), default partition, 1 thread a rank,
# for this build ("after") and, when BEFORE=path/to/parode is set, that one.
# Reports: OUT (default beside this script)/weak-PER-{before,after}-rR-K.json.
# Usage (repository root): [BEFORE=...] PER_RANK=... sh .../weak-memory/weak.sh
set -e
OUT=${OUT:-$(dirname "$0")}
PER=${PER_RANK:-50000}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
for k in $(seq ${REPEATS:-3}); do
for r in ${RANKS:-1 2 4 8}; do
  for b in ${BEFORE:+before} after; do
    P=build/ci/parode; [ $b = before ] && P=$BEFORE
    mpiexec -n $r --oversubscribe $P run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
      --steps ${STEPS:-2} --threads 1 --set catoms.count=$((PER * r)) --report $OUT/weak-$PER-$b-r$r-$k.json
  done
done
done
python3 "$(dirname "$0")/table.py" "$OUT" $PER
