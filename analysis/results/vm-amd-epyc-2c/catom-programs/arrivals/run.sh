#!/bin/sh
# The catom programs' share of the step on 1-3 threads and processes, 10^5 and
# 10^6 catoms (gradient, sculpt, and no program for the memory baseline).
# Usage (repository root, build ci, nothing else running; run it three times,
# with REP=1, 2, 3, for the medians):
#   REP=1 sh analysis/results/vm-amd-epyc-2c/catom-programs/arrivals/run.sh
set -e
S=analysis/results/vm-amd-epyc-2c/catom-programs
OUT=$S/arrivals/run${REP:-1}
mkdir -p $OUT
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMP_WAIT_POLICY=passive
scene() {
  case $1 in
    gradient) echo $S/magnetic-tennis-gradient.toml ;;
    sculpt) echo $S/figures/magnetic-tennis-sculpt.toml ;;
    none) echo jobs/scenes/magnetic-tennis.toml ;;
  esac
}
for p in gradient sculpt none; do
  F=$(scene $p)
  for t in 1 2 3; do
    build/ci/parode run $F --set catoms.count=100000 --steps 20 --threads $t -q --report $OUT/$p-1e5-1x$t.json
  done
  for r in 2 3; do
    mpiexec -n $r --oversubscribe build/ci/parode run $F --set catoms.count=100000 --steps 20 --threads 1 -q --report $OUT/$p-1e5-${r}x1.json
  done
done
for p in gradient sculpt none; do
  F=$(scene $p)
  build/ci/parode run $F --set catoms.count=1000000 --steps 6 --threads 2 -q --report $OUT/$p-1e6-1x2.json
  [ $p = none ] || mpiexec -n 2 --oversubscribe build/ci/parode run $F --set catoms.count=1000000 --steps 6 --threads 1 -q --report $OUT/$p-1e6-2x1.json
done
python3 analysis/results/vm-amd-epyc-2c/catom-programs/strip_reports.py "$OUT"
