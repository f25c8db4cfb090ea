#!/bin/sh
# Peak memory a rank and ghost copies with the same catoms a rank (PER_RANK,
# default 50,000) on 1, 2, 4 and 8 ranks (oversubscribed), STEPS steps,
# REPEATS turns (default 3, interleaved), for
# the build before the halo by reach (BEFORE=path/to/parode) and this one,
# with the default partition ("best": METIS at this size) and the tree of
# cuts ("bisection"). Usage (repository root): BEFORE=... sh .../halo-reach/weak.sh
set -e
OUT=${OUT:-$(dirname "$0")}
PER=${PER_RANK:-50000}
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
for k in $(seq ${REPEATS:-3}); do
for r in 1 2 4 8; do
  for v in best bisection; do
    for b in before after; do
      P=build/ci/parode; [ $b = before ] && P=$BEFORE
      mpiexec -n $r --oversubscribe $P run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
        --steps ${STEPS:-2} --threads 1 --set catoms.count=$((PER * r)) --set "parallel.partitioner=\"$v\"" \
        --report $OUT/weak-$v-$b-r$r-$k.json
    done
  done
done
done
python3 "$OUT/table.py" "$OUT"
