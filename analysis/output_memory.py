#!/usr/bin/env python3
"""analysis/output_memory.sh's reports as a table: per build and rank count,
the fullest rank's peak (MiB) without and with the output (medians of the
turns), what the output adds, and its cost in seconds (a checkpoint's
`checkpoints.seconds`, the slowest rank; snapshots: the output stage, frames
after step 0).
Usage: python3 analysis/output_memory.py FOLDER"""
import glob, json, os, statistics, sys
from collections import defaultdict

folder = sys.argv[1]
MiB = 2 ** 20
runs = defaultdict(list)
for f in sorted(glob.glob(os.path.join(folder, "m-*.json"))):
    build, ranks, kind, _ = os.path.basename(f)[2:-5].split("-")
    runs[(build, int(ranks[1:]), kind)].append(json.load(open(f)))
kind = next(k for _, _, k in runs if k != "none")
what = {"ckpt": "a checkpoint", "snap": "snapshots"}[kind]
cost = {"ckpt": lambda j: j["checkpoints"]["seconds"], "snap": lambda j: j["stages"]["output"]}[kind]


def med(js, get):
    return statistics.median(get(j) for j in js)


peak = lambda j: j["memory"]["peak_rss_bytes"]["max"] / MiB
print(f"| build | ranks | peak, no output | peak, {what} (turns) | median | {what} add | seconds | state hash |")
print("|---|---|---|---|---|---|---|---|")
for build, ranks in sorted({(b, r) for b, r, _ in runs}, key=lambda k: (k[1], k[0] != "before")):
    none, out = runs[(build, ranks, "none")], runs[(build, ranks, kind)]
    print(f"| {build} | {ranks} | {med(none, peak):.1f} | {', '.join(f'{peak(j):.1f}' for j in out)} | {med(out, peak):.1f} | "
          f"{med(out, peak) - med(none, peak):+.1f} | {med(out, cost):.3f} | {out[0]['state_hash']} |")
