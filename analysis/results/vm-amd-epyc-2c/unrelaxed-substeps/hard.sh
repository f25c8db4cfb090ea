#!/bin/sh
# Hard-case verdicts of substeps at SOR w = 1 beside 4 x 3 and the default
# (exit 0 = pass, 5 = a check failed). Usage: sh hard.sh PARODE > hard.txt
P=$1
for cfg in "default" "s4i3 solver.substeps=4 solver.iterations=3" \
           "s4i2w1 solver.substeps=4 solver.iterations=2 solver.sor_w=1" \
           "s4i1w1 solver.substeps=4 solver.iterations=1 solver.sor_w=1" \
           "s4i3w1 solver.substeps=4 solver.iterations=3 solver.sor_w=1"; do
  set -- $cfg; name=$1; shift; sets=""
  for s in "$@"; do sets="$sets --set $s"; done
  for case in fast-catom mass-ratio column pyramid overlap pile-100k; do
    out=$($P run jobs/scenes/hard/$case.toml --solver parallel $sets --threads 2 2>&1)
    rc=$?
    echo "$name $case rc=$rc $(echo "$out" | grep -E 'checks (passed|failed)|simulation failed' | head -1 | cut -c1-240)"
  done
done
