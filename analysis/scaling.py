#!/usr/bin/env python3
"""Thread-scaling table from parode run reports.

Reads every *.json run report in DIR (one per thread count of the same scene and
size, as jobs/omp_scaling.sh writes them) and prints, per thread count: ms per
step, the collide and solve stages per step, the speed-up against the fewest
threads and the parallel efficiency; also checks that all runs give the same
state hash (determinism across thread counts). Writes DIR/scaling.md as well.
Trade-off: one run per thread count (the script that makes them decides how
many); medians over repeated runs belong to farm-style repetition of the script.

Usage: python3 analysis/scaling.py DIR
"""
import glob
import json
import os
import sys


def load(directory):
    rows = []
    for path in sorted(glob.glob(os.path.join(directory, "*.json"))):
        with open(path) as f:
            r = json.load(f)
        if "threads" not in r or "stages" not in r:
            continue
        steps = max(r["steps"], 1)
        rows.append({
            "threads": r["threads"], "bodies": r["bodies"], "scene": r["scene"],
            "ms": r["ms_per_step"], "collide": 1e3 * r["stages"]["collide"] / steps,
            "solve": 1e3 * r["stages"]["solve"] / steps, "hash": r["state_hash"],
        })
    return sorted(rows, key=lambda x: x["threads"])


def table(rows):
    base = rows[0]
    lines = [f"{base['scene']}, {base['bodies']} bodies",
             "| threads | ms/step | collide ms | solve ms | speed-up | efficiency | state hash |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        s = base["ms"] / r["ms"] * base["threads"]
        lines.append(f"| {r['threads']} | {r['ms']:.2f} | {r['collide']:.2f} | {r['solve']:.2f} | "
                     f"{s:.2f} | {s / r['threads']:.2f} | {r['hash']} |")
    same = len({r["hash"] for r in rows}) == 1
    lines.append("")
    lines.append("state hash identical for every thread count" if same else "STATE HASHES DIFFER")
    return "\n".join(lines), same


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    rows = load(sys.argv[1])
    if not rows:
        sys.exit(f"{sys.argv[1]}: no run reports found")
    text, same = table(rows)
    print(text)
    with open(os.path.join(sys.argv[1], "scaling.md"), "w") as f:
        f.write(text + "\n")
    sys.exit(0 if same else 1)


if __name__ == "__main__":
    main()
