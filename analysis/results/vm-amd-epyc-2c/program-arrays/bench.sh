#!/bin/sh
# The catom program pass before and after its re-indexing by the catoms a
# rank holds: the fullest rank's peak memory with and without `gradient` at
# 50,000 catoms a rank on 1, 2, 4, 8 ranks (tennis, 2 steps, huge pages off),
# and the pass's time on magnetic tennis with `gradient` at 10^5 catoms
# (20 steps; 1 x 1, 1 x 2, 2 x 1), the two builds interleaved, TURNS turns.
# Usage (repository root, nothing else running):
#   BEFORE=/path/to/old/parode AFTER=build/ci/parode TURNS=3 sh analysis/results/vm-amd-epyc-2c/program-arrays/bench.sh
set -e
D=analysis/results/vm-amd-epyc-2c/program-arrays
OUT=${OUT:-$D/runs}
mkdir -p $OUT
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive PARODE_HUGE_PAGES=0
G=analysis/results/vm-amd-epyc-2c/catom-programs/magnetic-tennis-gradient.toml
for turn in $(seq 1 ${TURNS:-3}); do
  for r in 1 2 4 8; do
    for b in before after; do
      P=$BEFORE; [ $b = after ] && P=$AFTER
      for prog in none gradient; do
        extra=""; [ $prog = gradient ] && extra="--program gradient"
        mpiexec -x PARODE_HUGE_PAGES -n $r --oversubscribe $P run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
          --steps 2 --threads 1 --set catoms.count=$((50000 * r)) $extra --report $OUT/mem-$b-$prog-r$r-t$turn.json
      done
    done
  done
  for b in before after; do
    P=$BEFORE; [ $b = after ] && P=$AFTER
    for t in 1 2; do
      $P run $G --set catoms.count=100000 --steps 20 --threads $t -q --report $OUT/speed-$b-1x$t-t$turn.json
    done
    mpiexec -n 2 --oversubscribe $P run $G --set catoms.count=100000 --steps 20 --threads 1 -q --report $OUT/speed-$b-2x1-t$turn.json
  done
done
python3 analysis/results/vm-amd-epyc-2c/catom-programs/strip_reports.py "$OUT"
