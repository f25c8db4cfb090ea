#!/bin/sh
# A 400,000-catom checkpoint with the gradient program (written by 4 ranks),
# restarted for one step on 8 ranks (two turns) and 16 (one), by the build
# before (OLD) and this one (NEW), each beside a run of the same scene from
# scratch: the peak memory a rank. Run from the repository root.
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 PARODE_HUGE_PAGES=0
NEW=${NEW:-build/ci/parode} OLD=${OLD:?the build before, e.g. /tmp/base/build/parode}
OUT=${OUT:-analysis/results/vm-amd-epyc-2c/program-arrays/restart-stream}
SC=jobs/scenes/tennis.toml
COMMON="--set catoms.count=400000 --program gradient --threads 1 -q"
mpiexec -x PARODE_HUGE_PAGES -n 4 --oversubscribe $NEW run $SC $COMMON --steps 2 --checkpoint /tmp/c.ckpt
for turn in 8-1 8-2 16-1; do
  R=${turn%-*}; T=${turn#*-}; TAG=""; [ $R = 16 ] && TAG=r16-
  for b in before after; do
    P=$NEW; [ $b = before ] && P=$OLD
    mpiexec -x PARODE_HUGE_PAGES -n $R --oversubscribe $P run $SC $COMMON --steps 1 --restart /tmp/c.ckpt --report $OUT/${TAG}restart-$b-$T.json
    mpiexec -x PARODE_HUGE_PAGES -n $R --oversubscribe $P run $SC $COMMON --steps 1 --report $OUT/${TAG}plain-$b-$T.json
  done
done
