#!/usr/bin/env python3
"""The fullest rank's peak (MiB) from run.sh's reports: per build and rank
count, each turn, the median's growth over one rank, the ghost fraction and
(this build) the fullest rank's peak in parts (memory.peak_by_stage).
Usage: python3 table.py [FOLDER]"""
import glob, json, os, statistics, sys
from collections import defaultdict

folder = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
runs = defaultdict(list)
for f in sorted(glob.glob(os.path.join(folder, "m-*.json"))):
    build, ranks, _ = os.path.basename(f)[2:-5].split("-")
    runs[(build, int(ranks[1:]))].append(json.load(open(f)))
MiB = 2 ** 20
print("| build | ranks | peak MiB (turns) | median | over 1 rank | ghost fraction | state hash |")
print("|---|---|---|---|---|---|---|")
for (build, ranks), js in sorted(runs.items()):
    peaks = [j["memory"]["peak_rss_bytes"]["max"] / MiB for j in js]
    one = statistics.median(j["memory"]["peak_rss_bytes"]["max"] / MiB for j in runs[(build, 1)])
    med = statistics.median(peaks)
    grow = "" if ranks == 1 else f"{100 * (med / one - 1):+.1f} %"
    print(f"| {build} | {ranks} | {', '.join(f'{p:.1f}' for p in peaks)} | {med:.1f} | {grow} | "
          f"{js[0]['parallel'].get('ghost_fraction', 0):.4f} | {js[0]['state_hash']} |")
print()
print("The fullest rank's peak in parts, MiB (this build, first turn):")
print()
names = ["setup", "migrate", "exchange", "forces", "collide", "joints", "solve", "observe", "output", "other"]
print("| ranks | " + " | ".join(names) + " |")
print("|---|" + "---|" * len(names))
for (build, ranks), js in sorted(runs.items()):
    parts = js[0]["memory"].get("peak_by_stage")
    if build == "after" and parts:
        print(f"| {ranks} | " + " | ".join(f"{parts[n] / MiB:.1f}" for n in names) + " |")
