#!/bin/sh
# The partition step at the same catoms a rank (PER_RANK, default 50,000) on
# 1, 2, 4 and 8 ranks: the root's gathered partition ("best", which gathers
# below 2^18 occupied cells) against the tree every process cuts together
# ("bisection"); partition-bisection/weak.sh's runs, written here.
# Usage (repository root): sh .../cut-tree/weak.sh
OUT=$(dirname "$0")
export OUT VARIANTS="best bisection"
exec sh "$OUT/../partition-bisection/weak.sh"
