#!/bin/sh
# The solve's substages (ms a step over all 30 steps, one thread, 64,000
# catoms), three interleaved turns of: the default, 4 x 3 before, 4 x 3 after.
# Usage: sh substages.sh BEFORE/parode AFTER/parode > substages.txt
B=$1; A=$2
for turn in 1 2 3; do
  for v in "default $A" "before-4x3 $B --set solver.substeps=4 --set solver.iterations=3" \
           "after-4x3 $A --set solver.substeps=4 --set solver.iterations=3"; do
    set -- $v; name=$1; bin=$2; shift 2
    $bin run jobs/scenes/tennis.toml --set catoms.count=64000 --steps 30 --threads 1 -q "$@" --report /tmp/sub.json
    python3 -c "
import json; r = json.load(open('/tmp/sub.json')); n = r['steps']; s = r['substages']['solve']
print('$name', $turn, ' '.join(f'{k}={1e3 * s[k] / n:.1f}' for k in ('build', 'warm_start', 'sweeps', 'integrate')),
      f'solve={1e3 * r[\"stages\"][\"solve\"] / n:.1f}', r['state_hash'])"
  done
done
