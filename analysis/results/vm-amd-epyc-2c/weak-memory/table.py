"""The weak-memory table for one size a rank: per rank count, the fullest
rank's peak memory (MB, median over the turns) before and after (where
both ran), its growth over one rank, the ghost fraction and whether the
state hashes agree. Usage: python3 table.py DIR PER_RANK"""
import glob
import json
import os
import statistics
import sys

d, per = sys.argv[1], sys.argv[2]
builds = [b for b in ("before", "after") if glob.glob(os.path.join(d, f"weak-{per}-{b}-r*-*.json"))]
print(f"{int(per):,} catoms a rank; " + ", ".join(builds))
print("| ranks | " + " | ".join(f"peak MB {b} | growth {b} | ghost fraction {b}" for b in builds) + " | turns | one hash |")
print("|---|" + "---|---|---|" * len(builds) + "---|---|")
base = {}
for r in (1, 2, 4, 8, 16):
    cells, hashes, turns = [], set(), 0
    for b in builds:
        runs = [json.load(open(f)) for f in sorted(glob.glob(os.path.join(d, f"weak-{per}-{b}-r{r}-*.json")))]
        if not runs:
            cells = None
            break
        turns = len(runs)
        peak = statistics.median(x["memory"]["peak_rss_bytes"]["max"] for x in runs) / 2**20
        base.setdefault(b, peak if r == 1 else None)
        growth = f"{100 * (peak / base[b] - 1):+.1f} %" if base[b] else "-"
        ghost = statistics.median((x.get("parallel") or {}).get("ghost_fraction", 0.0) for x in runs)
        cells += [f"{peak:.1f}", growth, f"{ghost:.4f}"]
        hashes |= {x["state_hash"] for x in runs}
    if cells:
        print(f"| {r} | " + " | ".join(cells) + f" | {turns} | {'yes' if len(hashes) == 1 else 'NO'} |")
