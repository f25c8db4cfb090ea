#!/bin/sh
# The ghost exchange's messages in the scratch pool: the fullest rank's peak at
# 250,000 catoms a rank on RANKS (default "1 4 8") ranks, and the exchange's time
# at 10^6 catoms on 2 ranks (steps 2-4), this build ("after") against BEFORE,
# REPEATS (default 3) interleaved turns. Usage (repository root):
#   BEFORE=/tmp/base/build/parode sh analysis/results/vm-intel-xeon-2c/exchange-pool/run.sh
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive PARODE_HUGE_PAGES=0
OUT=$(dirname "$0")
for k in $(seq ${REPEATS:-3}); do
  for r in ${RANKS:-1 4 8}; do for b in before after; do
    P=build/ci/parode; [ $b = before ] && P=$BEFORE
    mpiexec -n $r --oversubscribe $P run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
      --steps 2 --threads 1 --set catoms.count=$((250000 * r)) --report $OUT/m-$b-r$r-$k.json
  done; done
  for b in before after; do
    P=build/ci/parode; [ $b = before ] && P=$BEFORE
    mpiexec -n 2 --oversubscribe $P run jobs/scenes/tennis.toml --collide grid --solver parallel -q \
      --steps 4 --threads 1 --set catoms.count=1000000 --report $OUT/e-$b-$k.json
  done
done
