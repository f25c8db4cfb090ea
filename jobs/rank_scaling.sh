#!/usr/bin/env bash
# Scaling studies of parode over MPI ranks x OpenMP threads, one command each:
#   strong   the same CATOMS for every (ranks, threads) pair
#   weak     PER_RANK catoms per rank (the prism grows with the ranks)
#   threads  one process, the same CATOMS, THREADS = 1 .. cores
# `parode run` of a scene (default tennis, the grid backend and the parallel
# contact solver) once per pair, in turns (every pair once, then again, REPEATS
# times), each writing its JSON run report into
#   OUT/<mode>-n<catoms>-r<ranks>-t<threads>-<repeat>.json
# with OUT/machine.json (host, CPU, cores, date, commit, parode binary).
# analysis/rank_scaling.py OUT turns the reports into speed-up, efficiency and
# time-per-stage tables and plots; analysis/scaling_model.py projects weak
# scaling to 1,000+ ranks.
#
# Usage: jobs/rank_scaling.sh strong|weak|threads [build-dir]   (default build/ci)
#        jobs/rank_scaling.sh --help
# Environment (defaults):
#   RANKS="1 2" (threads: 1)  THREADS="1" (threads: 1 .. nproc)
#   CATOMS=1000000 (threads: 8000)  PER_RANK=250000  STEPS=5  REPEATS=3
#   SCENE=jobs/scenes/tennis.toml   OUT=results/scaling-<host>/<mode>
#   MPIEXEC: the launcher of a run on 2+ ranks; default "mpiexec --map-by
#     slot:PE=<threads> --bind-to core" when ranks x threads fit the cores, else
#     "mpiexec --oversubscribe --bind-to none"; {threads} in MPIEXEC becomes the
#     thread count (on Slurm: MPIEXEC="srun --cpus-per-task={threads} --cpu-bind=cores").
#   OMP_PLACES=cores OMP_PROC_BIND=close unless set; NICE=10 runs niced.
#   DRY_RUN=1 prints the commands (one a line) instead of running them.
# Trade-off: turns rather than blocks of repeats, so a machine that gets
# busier during the study widens every pair's spread instead of biasing one.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
usage() { sed -n '2,/^set -euo/p' "${BASH_SOURCE[0]}" | sed '$d; s/^# \{0,1\}//'; }
die() { echo "rank_scaling.sh: $*" >&2; exit 2; }

case "${1:-}" in
  -h|--help) usage; exit 0 ;;
  strong|weak|threads) MODE="$1" ;;
  "") usage >&2; exit 2 ;;
  *) die "mode must be strong, weak or threads, not '$1' (see --help)" ;;
esac
BUILD="${2:-$ROOT/build/ci}"
CORES="$(nproc)"
if [ "$MODE" = threads ]; then
  RANKS="${RANKS:-1}"; THREADS="${THREADS:-$(seq -s ' ' 1 "$CORES")}"; CATOMS="${CATOMS:-8000}"
else
  RANKS="${RANKS:-1 2}"; THREADS="${THREADS:-1}"; CATOMS="${CATOMS:-1000000}"
fi
PER_RANK="${PER_RANK:-250000}"
STEPS="${STEPS:-5}"
REPEATS="${REPEATS:-3}"
SCENE="${SCENE:-$(realpath --relative-to=. "$ROOT/jobs/scenes/tennis.toml")}"  # relative: reports name it so
OUT="${OUT:-$ROOT/results/scaling-$(hostname)/$MODE}"
NICE="${NICE:-0}"

positive() { [[ "$2" =~ ^[1-9][0-9]*$ ]] || die "$1 must be a positive integer, not '$2'"; }
for v in $RANKS; do positive RANKS "$v"; done
for v in $THREADS; do positive THREADS "$v"; done
for v in "$CATOMS" "$PER_RANK" "$STEPS" "$REPEATS"; do positive "CATOMS, PER_RANK, STEPS and REPEATS" "$v"; done
[[ "$NICE" =~ ^-?[0-9]+$ ]] || die "NICE must be an integer, not '$NICE'"
[ -f "$SCENE" ] || die "SCENE=$SCENE: no such scene file"

export OMP_WAIT_POLICY="${OMP_WAIT_POLICY:-passive}"
export OMP_PLACES="${OMP_PLACES:-cores}" OMP_PROC_BIND="${OMP_PROC_BIND:-close}"
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

launcher() {  # launcher RANKS THREADS: the MPI launcher words of a run
  if [ -n "${MPIEXEC:-}" ]; then echo "${MPIEXEC//\{threads\}/$2}"
  elif [ $(($1 * $2)) -le "$CORES" ]; then echo "mpiexec --map-by slot:PE=$2 --bind-to core"
  else echo "mpiexec --oversubscribe --bind-to none"
  fi
}

run() {  # run RANKS THREADS REPEAT
  local r="$1" t="$2" k="$3" n="$CATOMS"
  [ "$MODE" = weak ] && n=$((PER_RANK * r))
  local report="$OUT/$MODE-n$n-r$r-t$t-$k.json"
  local cmd=("$BUILD/parode" run "$SCENE" --set "catoms.count=$n" --steps "$STEPS" --collide grid
             --solver parallel --threads "$t" -q --report "$report")
  if [ "$r" -gt 1 ]; then
    local words
    read -r -a words <<<"$(launcher "$r" "$t")"
    cmd=("${words[@]}" -n "$r" "${cmd[@]}")
  fi
  [ "$NICE" = 0 ] || cmd=(nice -n "$NICE" "${cmd[@]}")
  if [ -n "${DRY_RUN:-}" ]; then echo "OMP_NUM_THREADS=$t ${cmd[*]}"; return; fi
  echo "rank_scaling: $MODE n=$n ranks=$r threads=$t repeat=$k" >&2
  OMP_NUM_THREADS="$t" "${cmd[@]}"
}

if [ -z "${DRY_RUN:-}" ]; then
  [ -x "$BUILD/parode" ] || "$ROOT/jobs/setup.sh" ci
  mkdir -p "$OUT"
  python3 - "$BUILD/parode" "$OUT/machine.json" "$ROOT/jobs" <<'PY'
import json, sys
sys.path.insert(0, sys.argv[3])
from sweep import machine
with open(sys.argv[2], "w") as f:
    json.dump(machine(sys.argv[1]), f, indent=1)
PY
fi
for k in $(seq 1 "$REPEATS"); do
  for r in $RANKS; do
    for t in $THREADS; do run "$r" "$t" "$k"; done
  done
done
[ -n "${DRY_RUN:-}" ] || echo "rank_scaling: reports in $OUT; python3 analysis/rank_scaling.py $OUT" >&2
