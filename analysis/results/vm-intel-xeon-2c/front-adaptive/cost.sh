#!/bin/bash
# Solver configurations side by side: the tennis prism of N catoms, STEPS
# steps, T threads, TURNS interleaved turns, one `parode run` per variant
# and turn (each variant: the options after the scene); the reports in OUT;
# then prints the medians of the steps after the first (table.py).
# Usage: cost.sh OUT N STEPS T TURNS "--solver parallel" "--solver adaptive/omp" ...
set -euo pipefail
OUT=$1; N=$2; STEPS=$3; T=$4; TURNS=$5; shift 5
P=${PARODE:-build/ci/parode}
mkdir -p "$OUT"
for turn in $(seq 1 "$TURNS"); do
  i=0
  for V in "$@"; do
    i=$((i + 1))
    # shellcheck disable=SC2086  # the variant is a list of options
    "$P" run jobs/scenes/tennis.toml --set catoms.count="$N" --steps "$STEPS" --threads "$T" -q \
      --report "$OUT/v$i.t$turn.json" $V
  done
done
python3 "$(dirname "$0")/table.py" "$OUT" "$@"
