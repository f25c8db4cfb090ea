#!/bin/sh
# A checkpoint's cost to a rank's peak: 250,000 catoms a rank on RANKS (default
# "1 2") ranks, 2 steps, a checkpoint at the end (--checkpoint), this build
# ("after") against BEFORE, REPEATS (default 3) interleaved turns, huge pages off;
# the first turn's checkpoints of the two builds compared byte for byte.
# Usage (repository root): BEFORE=/tmp/base/build/parode sh analysis/results/vm-intel-xeon-2c/checkpoint-memory/run.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive PARODE_HUGE_PAGES=0
OUT=$(dirname "$0"); CK=${TMPDIR:-/tmp}/parode-ckpt
for k in $(seq ${REPEATS:-3}); do
  for r in ${RANKS:-1 2}; do for b in before after; do
    P=build/ci/parode; [ $b = before ] && P=$BEFORE
    for c in none ckpt; do
      A=""; [ $c = ckpt ] && A="--checkpoint $CK-$b.ckpt"
      mpiexec -n $r --oversubscribe $P run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
        --steps 2 --threads 1 --set catoms.count=$((250000 * r)) $A --report $OUT/m-$b-r$r-$c-$k.json
    done
  done
  [ $k = 1 ] && cmp $CK-before.ckpt $CK-after.ckpt && echo "r$r: before and after wrote the same bytes"
  done
done
