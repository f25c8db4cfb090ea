#!/bin/sh
# 4 ranks, 400,000 catoms with the gradient program, 2 steps, with and
# without a checkpoint at the end, by the build before (OLD) and this one
# (NEW), two turns: the peak memory a rank and the checkpoint's cost.
# Run from the repository root.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 PARODE_HUGE_PAGES=0
NEW=${NEW:-build/ci/parode} OLD=${OLD:?the build before, e.g. /tmp/base/build/parode}
OUT=${OUT:-analysis/results/vm-amd-epyc-2c/program-arrays/checkpoint-pieces}
COMMON="jobs/scenes/tennis.toml --set catoms.count=400000 --program gradient --steps 2 --threads 1 -q"
for t in 1 2; do
  for b in before after; do
    P=$NEW; [ $b = before ] && P=$OLD
    mpiexec -x PARODE_HUGE_PAGES -n 4 --oversubscribe $P run $COMMON --report $OUT/$b-no-$t.json
    mpiexec -x PARODE_HUGE_PAGES -n 4 --oversubscribe $P run $COMMON --checkpoint /tmp/pieces-$b.ckpt --report $OUT/$b-yes-$t.json
  done
done
cmp /tmp/pieces-before.ckpt /tmp/pieces-after.ckpt && echo "the same checkpoint bytes"
