#!/usr/bin/env bash
# ctest cases for the scaling study driver (jobs/rank_scaling.sh) on a small
# machine: `dry MODE` checks the printed commands (launcher, ranks, threads,
# catoms, report names); `tiny MODE` runs a study of 125 catoms for 2 steps on
# 1 and 2 ranks or threads, then analysis/rank_scaling.py on its reports, and
# checks one report per run, machine.json and the tables and plot.
# Usage: tests/jobs/test_scaling_study.sh dry|tiny strong|weak|threads BUILD_DIR
# Trade-off: the tiny study measures nothing (2 steps of 125 catoms); it
# checks that the driver and the analysis work together end to end.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
KIND="${1:?dry|tiny}" MODE="${2:?strong|weak|threads}" BUILD="${3:?build dir}"
WORK="$(mktemp -d)"
trap 'rm -rf "$WORK"' EXIT
fail() { echo "FAIL: $*" >&2; cat "$WORK/out.txt" >&2 2>/dev/null || true; exit 1; }
expect() { grep -qE -- "$1" "$WORK/out.txt" || fail "no line matches /$1/"; }

if [ "$KIND" = dry ]; then
  DRY_RUN=1 REPEATS=2 THREADS="1 2" OUT="$WORK/r" MPIEXEC="" bash "$ROOT/jobs/rank_scaling.sh" "$MODE" "$BUILD" >"$WORK/out.txt"
  case "$MODE" in
    strong) [ "$(wc -l <"$WORK/out.txt")" -eq 8 ] || fail "expected 2 repeats x 2 ranks x 2 threads = 8 commands"
            expect "^OMP_NUM_THREADS=2 mpiexec .*-n 2 $BUILD/parode run .*tennis.toml --set catoms.count=1000000 .*--collide grid --solver parallel --threads 2 -q --report $WORK/r/strong-n1000000-r2-t2-2.json$" ;;
    weak)   expect "^OMP_NUM_THREADS=1 $BUILD/parode run .*--set catoms.count=250000 .*--report $WORK/r/weak-n250000-r1-t1-1.json$"
            expect "^OMP_NUM_THREADS=1 mpiexec .*-n 2 .*--set catoms.count=500000 .*weak-n500000-r2-t1-1.json$" ;;
    threads) [ "$(wc -l <"$WORK/out.txt")" -eq 4 ] || fail "expected 2 repeats x 2 thread counts = 4 commands"
             expect "^OMP_NUM_THREADS=2 $BUILD/parode run .*--set catoms.count=8000 .*--threads 2 -q --report $WORK/r/threads-n8000-r1-t2-1.json$"
             if grep -q mpiexec "$WORK/out.txt"; then fail "a thread study started MPI"; fi ;;
  esac
  echo "ok: dry $MODE"
  exit 0
fi

python3 -c "import numpy, pandas, matplotlib" 2>/dev/null || { echo "skipped: numpy, pandas or matplotlib missing (jobs/setup.sh)"; exit 77; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
ranks="1 2" want=4
[ "$MODE" != threads ] || ranks=1 want=2  # a thread study runs one process
CATOMS=125 PER_RANK=125 STEPS=2 REPEATS=1 RANKS="$ranks" THREADS="1 2" OUT="$WORK/r" \
  MPIEXEC="mpiexec --oversubscribe --bind-to none" bash "$ROOT/jobs/rank_scaling.sh" "$MODE" "$BUILD" >"$WORK/out.txt" 2>&1 ||
  fail "the study failed"
reports=$(find "$WORK/r" -name "$MODE-*.json" | wc -l)
[ "$reports" -eq "$want" ] || fail "expected $want reports, found $reports"
[ -s "$WORK/r/machine.json" ] || fail "no machine.json"
python3 "$ROOT/analysis/rank_scaling.py" "$WORK/r" --out "$WORK/a" >"$WORK/out.txt" 2>&1 || fail "analysis/rank_scaling.py failed"
for f in rank_scaling.md rank_scaling.csv rank_scaling.png; do [ -s "$WORK/a/$f" ] || fail "no $f"; done
expect "state hash identical for every rank and thread count"
echo "ok: tiny $MODE ($reports runs)"
