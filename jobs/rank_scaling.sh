#!/usr/bin/env bash
# Strong and weak scaling of a distributed run over MPI ranks x OpenMP threads:
# `parode run` of a scene (default tennis, the grid backend and the parallel
# contact solver) once per (ranks, threads) pair, in turns (every pair once,
# then again REPEATS times), each writing its JSON run report into
#   results/rank_scaling-<host>/<mode>-n<catoms>-r<ranks>-t<threads>-<repeat>.json
# strong: the same CATOMS for every pair; weak: PER_RANK catoms per rank.
# analysis/rank_scaling.py turns the reports into speed-up and efficiency
# tables; analysis/scaling_model.py projects weak scaling to 1,000+ ranks.
#
# Usage: jobs/rank_scaling.sh strong|weak [build-dir]     (default build/ci)
# Environment (defaults): RANKS="1 2" THREADS="1" CATOMS=1000000 PER_RANK=250000
#   STEPS=5 REPEATS=3 SCENE=jobs/scenes/tennis.toml OUT=results/rank_scaling-<host>
#   MPIEXEC="mpiexec --bind-to core --map-by slot:PE=<threads>" (on Slurm: MPIEXEC=srun)
#   DRY_RUN=1 prints the commands instead of running them.
# Trade-off: turns rather than blocks of repeats, so a machine that gets
# busier during the study widens every pair's spread instead of biasing one.
set -euo pipefail

MODE="${1:?usage: jobs/rank_scaling.sh strong|weak [build-dir]}"
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${2:-$ROOT/build/ci}"
RANKS="${RANKS:-1 2}"
THREADS="${THREADS:-1}"
CATOMS="${CATOMS:-1000000}"
PER_RANK="${PER_RANK:-250000}"
STEPS="${STEPS:-5}"
REPEATS="${REPEATS:-3}"
SCENE="${SCENE:-$ROOT/jobs/scenes/tennis.toml}"
OUT="${OUT:-$ROOT/results/rank_scaling-$(hostname)}"
case "$MODE" in strong|weak) ;; *) echo "rank_scaling.sh: mode must be strong or weak, not '$MODE'" >&2; exit 2 ;; esac

export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
run() {  # run RANKS THREADS REPEAT
  local r="$1" t="$2" k="$3" n="$CATOMS"
  [ "$MODE" = weak ] && n=$((PER_RANK * r))
  local launcher="${MPIEXEC:-mpiexec --oversubscribe --bind-to none}"
  local report="$OUT/$MODE-n$n-r$r-t$t-$k.json"
  local cmd=("$BUILD/parode" run "$SCENE" --set "catoms.count=$n" --steps "$STEPS" --collide grid
             --solver parallel --threads "$t" -q --report "$report")
  if [ "$r" -gt 1 ]; then
    # shellcheck disable=SC2206  # the launcher is a command line of its own
    cmd=($launcher -n "$r" "${cmd[@]}")
  fi
  if [ -n "${DRY_RUN:-}" ]; then echo "${cmd[*]}"; return; fi
  echo "rank_scaling: $MODE n=$n ranks=$r threads=$t repeat=$k" >&2
  OMP_NUM_THREADS="$t" "${cmd[@]}"
}

if [ -z "${DRY_RUN:-}" ]; then
  [ -x "$BUILD/parode" ] || "$ROOT/jobs/setup.sh" ci
  mkdir -p "$OUT"
fi
for k in $(seq 1 "$REPEATS"); do
  for r in $RANKS; do
    for t in $THREADS; do run "$r" "$t" "$k"; done
  done
done
[ -n "${DRY_RUN:-}" ] || echo "rank_scaling: reports in $OUT; python3 analysis/rank_scaling.py $OUT" >&2
