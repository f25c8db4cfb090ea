#!/bin/bash
# 10^6 tennis, 4 steps, a checkpoint every step; 3 repeats; reports kept.
set -e
OUT=analysis/results/vm-amd-epyc-2c/checkpoint-durability
D=$(mktemp -d /work/ckcost.XXXX)
for r in 1 2 3; do
  build/ci/parode run jobs/scenes/tennis.toml --set catoms.count=1000000 --steps 4 --threads 2 -q \
    --checkpoint $D/c.ckpt --checkpoint-every 1 --report $OUT/write-$r.json
  build/ci/parode run jobs/scenes/tennis.toml --set catoms.count=1000000 --steps 1 --threads 2 -q \
    --restart $D/c.ckpt --report $OUT/restart-$r.json
done
rm -rf $D
