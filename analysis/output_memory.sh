#!/bin/sh
# What writing output costs a rank's peak memory: 250,000 catoms a rank (PER) on
# RANKS (default "1 2") ranks, 2 steps, each run once without output and once with
# KIND's output (ckpt: a checkpoint at the end; snap: an H5MD frame at every step),
# this build ("after") against BEFORE, REPEATS (default 3) interleaved turns, huge
# pages off; the first turn's files of the two builds compared (cmp for a
# checkpoint, h5diff of /particles for snapshots). Reports go to OUT as
# m-<build>-r<ranks>-<none|KIND>-<turn>.json; analysis/output_memory.py tabulates them.
# Usage (repository root): KIND=ckpt OUT=analysis/results/... BEFORE=/tmp/base/build/parode sh analysis/output_memory.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive PARODE_HUGE_PAGES=0
: "${KIND:?KIND=ckpt or snap}" "${OUT:?OUT=folder for the reports}" "${BEFORE:?BEFORE=path to the other build}"
F=${TMPDIR:-/tmp}/parode-output
for k in $(seq ${REPEATS:-3}); do
  for r in ${RANKS:-1 2}; do
    for b in before after; do
      P=build/ci/parode; [ $b = before ] && P=$BEFORE
      for c in none $KIND; do
        A=""
        [ $c = ckpt ] && A="--checkpoint $F-$b.ckpt"
        [ $c = snap ] && A="--snapshot $F-$b.h5 --snapshot-every 1"
        mpiexec -n $r --oversubscribe $P run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
          --steps 2 --threads 1 --set catoms.count=$((${PER:-250000} * r)) $A --report $OUT/m-$b-r$r-$c-$k.json
      done
    done
    [ $k = 1 ] && [ $KIND = ckpt ] && cmp $F-before.ckpt $F-after.ckpt && echo "r$r: the same checkpoint bytes"
    [ $k = 1 ] && [ $KIND = snap ] && command -v h5diff > /dev/null &&
      h5diff -q $F-before.h5 $F-after.h5 /particles /particles && echo "r$r: the same particles in both files"
  done
done
