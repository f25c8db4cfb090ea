#!/bin/bash
# Builds (or wrappers that set a variable) side by side: the tennis prism of
# N catoms, STEPS steps, T threads, TURNS turns, one run of each a turn, the
# order rotated from turn to turn; the reports in OUT as vI.tTURN.json; then
# the medians of the steps after the first (../front-adaptive/table.py).
# Usage: side_by_side.sh OUT N STEPS T TURNS NAME=BINARY...
# (EXTRA: more options for every run, e.g. EXTRA="--solver adaptive/omp".)
set -euo pipefail
OUT=$1; N=$2; STEPS=$3; T=$4; TURNS=$5; shift 5
mkdir -p "$OUT"; vs=("$@"); k=${#vs[@]}
read -r -a extra <<< "${EXTRA:-}"
for turn in $(seq 1 "$TURNS"); do
  for j in $(seq 0 $((k - 1))); do
    i=$(( (j + turn) % k )); bin=${vs[$i]#*=}
    "$bin" run jobs/scenes/tennis.toml --set catoms.count="$N" --steps "$STEPS" --threads "$T" -q \
      --report "$OUT/v$((i + 1)).t$turn.json" "${extra[@]}"
  done
done
names=(); for v in "${vs[@]}"; do names+=("${v%%=*}"); done
python3 "$(dirname "$0")/../front-adaptive/table.py" "$OUT" "${names[@]}"
