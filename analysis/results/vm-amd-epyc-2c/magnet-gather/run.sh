#!/bin/sh
# The magnet pass before and after, interleaved: magnetic-tennis at CATOMS
# (default 64,000) catoms, STEPS steps (default 20), TURNS turns (default 3),
# 1 and 2 threads. OLD: the parode built before (required).
# Usage (repository root): OLD=/path/to/parode sh .../magnet-gather/run.sh; python3 .../magnet-gather/table.py
set -e
OUT=$(dirname "$0")
NEW=${NEW:-build/ci/parode}
N=${CATOMS:-64000}
mkdir -p "$OUT/$N"
for turn in $(seq 1 "${TURNS:-3}"); do
  for t in 1 2; do
    for v in before after; do
      bin=$NEW; [ $v = before ] && bin=$OLD
      $bin run jobs/scenes/magnetic-tennis.toml --collide grid --solver parallel -q --threads $t \
        --steps "${STEPS:-20}" --set catoms.count=$N --report "$OUT/$N/$v-t$t-r$turn.json"
    done
  done
done
