#!/bin/sh
# Hard-case verdicts behind the series' wider claims: fewer plain iterations
# (10, 5), more substep counts at SOR w = 1 and 3 substeps at w = 1.3 on the
# cases that decide
# (exit 0 = pass, 5 = a check failed). Usage (from the repository root): sh .../hard-extra.sh PARODE > .../hard-extra.txt
P=$1
W="solver.sor_w=1"
for cfg in "it10 solver.iterations=10" "it5 solver.iterations=5" \
           "s4i1w1 solver.substeps=4 solver.iterations=1 $W" \
           "s6i1w1 solver.substeps=6 solver.iterations=1 $W" \
           "s8i1w1 solver.substeps=8 solver.iterations=1 $W" \
           "s3i2w1 solver.substeps=3 solver.iterations=2 $W" \
           "s5i2w1 solver.substeps=5 solver.iterations=2 $W" \
           "s2i3w1 solver.substeps=2 solver.iterations=3 $W" \
           "s4i5w1 solver.substeps=4 solver.iterations=5 $W" \
           "s3i3 solver.substeps=3 solver.iterations=3" \
           "s3i4 solver.substeps=3 solver.iterations=4"; do
  set -- $cfg; name=$1; shift; sets=""
  for s in "$@"; do sets="$sets --set $s"; done
  for case in fast-catom mass-ratio pile-100k; do
    out=$($P run jobs/scenes/hard/$case.toml --solver parallel $sets --threads 2 2>&1)
    rc=$?
    echo "$name $case rc=$rc $(echo "$out" | grep -E 'checks (passed|failed)|simulation failed' | head -1 | cut -c1-240)"
  done
done
