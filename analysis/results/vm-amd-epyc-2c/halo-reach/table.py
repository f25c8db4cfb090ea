"""The weak series' table: per rank count and partitioner, before and after,
the fullest rank's peak memory (MB), its growth over one rank, the ghost
fraction and the state hash; medians over the turns. Usage: python3 table.py DIR"""
import glob
import json
import os
import statistics
import sys

d = sys.argv[1]
print("| ranks | partition | peak MB before | after | growth over 1 rank before | after | ghost fraction before | after | same hash |")
print("|---|---|---|---|---|---|---|---|---|")
base = {}
for r in (1, 2, 4, 8):
    for v in ("best", "bisection"):
        row = {}
        for b in ("before", "after"):
            runs = [json.load(open(f)) for f in sorted(glob.glob(os.path.join(d, f"weak-{v}-{b}-r{r}-*.json")))]
            if not runs:
                break
            j = runs[0]
            peak = statistics.median(x["memory"]["peak_rss_bytes"]["max"] for x in runs) / 2**20
            row[b] = (peak, (j.get("parallel") or {}).get("ghost_fraction", 0.0), j["state_hash"])
            if r == 1:
                base[(v, b)] = row[b][0]
        if len(row) < 2:
            continue
        g = {b: 100 * (row[b][0] / base[(v, b)] - 1) for b in row}
        print(f"| {r} | {v} | {row['before'][0]:.1f} | {row['after'][0]:.1f} | {g['before']:+.1f} % | {g['after']:+.1f} % | "
              f"{row['before'][1]:.3f} | {row['after'][1]:.3f} | {'yes' if row['before'][2] == row['after'][2] else 'NO'} |")
