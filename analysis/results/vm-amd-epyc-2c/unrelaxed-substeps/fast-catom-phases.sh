#!/bin/sh
# Is fast-catom's verdict robust? The bullet (60 m/s, 0.3 m a step) starts
# at z = 12 + k * 0.05 m, k = 0..5: six phases of where within a step it
# first meets the apex. Prints each configuration's lowest bullet centre at
# every phase (bound 1.0: the base layer) and how many phases pass.
# Usage (from the repository root): sh .../fast-catom-phases.sh PARODE > .../fast-catom-phases.txt
P=$1
T=$(mktemp -d); trap 'rm -rf "$T"' EXIT
for k in 0 1 2 3 4 5; do
  z=$(echo "12 + $k * 0.05" | bc)
  sed "s/^position = \[0.000000, 0.000000, 12.000000\]/position = [0.0, 0.0, $z]/" \
    jobs/scenes/hard/fast-catom.toml > "$T/p$k.toml"
done
W="solver.sor_w=1"
for cfg in "default" "it10 solver.iterations=10" "it30 solver.iterations=30" \
           "s4i3 solver.substeps=4 solver.iterations=3" \
           "s4i1w1 solver.substeps=4 solver.iterations=1 $W" \
           "s4i2w1 solver.substeps=4 solver.iterations=2 $W" \
           "s4i5w1 solver.substeps=4 solver.iterations=5 $W" \
           "s8i1w1 solver.substeps=8 solver.iterations=1 $W" \
           "s3i3 solver.substeps=3 solver.iterations=3" \
           "s3i4 solver.substeps=3 solver.iterations=4"; do
  set -- $cfg; name=$1; shift; sets=""
  for s in "$@"; do sets="$sets --set $s"; done
  line="$name"; pass=0
  for k in 0 1 2 3 4 5; do
    out=$($P run "$T/p$k.toml" --solver parallel $sets --threads 2 2>&1)
    [ $? -eq 0 ] && pass=$((pass + 1))
    zmin=$(echo "$out" | grep -oE 'bullet.z always >= min = [0-9.e+-]+' | awk '{print $NF}' | tail -1)
    line="$line $zmin"
  done
  echo "$line  passes $pass/6"
done
