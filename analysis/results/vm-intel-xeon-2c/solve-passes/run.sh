#!/bin/sh
# The solve's passes at 64,000 tennis catoms on one thread, in interleaved
# turns: today's default (20 sweeps), 10 sweeps, and 4 substeps of 3 sweeps.
# Usage: sh run.sh [PARODE] (from the repository root); writes runs.csv here.
set -e
P=${1:-build/ci/parode}
HERE=$(dirname "$0")
OUT=$HERE/runs.csv
echo "turn,config,steps,solve_ms,build_ms,warm_start_ms,sweeps_ms,integrate_ms,hash" > "$OUT"
for turn in 1 2 3; do
  for cfg in "default:solver.substeps=1:solver.iterations=20" "it10:solver.substeps=1:solver.iterations=10" \
             "s4it3:solver.substeps=4:solver.iterations=3"; do
    name=${cfg%%:*}; rest=${cfg#*:}; a=${rest%%:*}; b=${rest#*:}
    "$P" run jobs/scenes/tennis.toml --set catoms.count=64000 --set "$a" --set "$b" --steps 40 --threads 1 \
        --report /tmp/solve-passes.json -q
    python3 - "$turn" "$name" >> "$OUT" <<'PY'
import json, sys
r = json.load(open('/tmp/solve-passes.json'))
n = r['steps']; s = r['substages']['solve']
ms = lambda v: '%.3f' % (1e3 * v / n)
print(','.join([sys.argv[1], sys.argv[2], str(n), ms(r['stages']['solve']), ms(s['build']), ms(s['warm_start']),
                ms(s['sweeps']), ms(s['integrate']), r['state_hash']]))
PY
  done
done
python3 "$HERE/table.py" "$OUT"
