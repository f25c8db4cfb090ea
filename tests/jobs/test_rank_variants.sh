#!/usr/bin/env bash
# jobs/rank_variants.py's hash check with the real parode (1,000 catoms, 3
# steps, one turn): two layouts of one computation give one hash (exit 0);
# two solver settings under one label differ (exit 1); under two labels
# they are two computations, each with its own hash (exit 0).
# Usage: test_rank_variants.sh BUILD_DIR
# Trade-off: tiny runs, so the check is about the labels, not the timings.
set -uo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
parode="$1/parode"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
variants() {
  python3 "$root/jobs/rank_variants.py" --parode "$parode" --catoms 1000 --steps 3 --repeats 1 --out "$out" "$@" >"$out/log" 2>&1
}
expect() {  # expected exit, what, variants...
  local want=$1 what=$2 got
  shift 2
  variants "$@"
  got=$?
  if [ "$got" != "$want" ]; then
    echo "FAIL: $what: exit $got, expected $want"
    cat "$out/log"
    exit 1
  fi
  echo "ok: $what: $(grep 'state hash' "$out/variants.md" | tr '\n' ' ')"
}
expect 0 "one computation on 1 and 2 threads" one=ranks=0,threads=1 two=ranks=0,threads=2
expect 1 "two settings under one label" it20=ranks=0 it10=ranks=0,solver.iterations=10
expect 0 "two settings under two labels" it20=ranks=0,same=a it10=ranks=0,solver.iterations=10,same=b
grep -q '^state hash: b (it10): ' "$out/variants.md" || { echo "FAIL: no line for label b"; cat "$out/variants.md"; exit 1; }
