#!/usr/bin/env python3
"""run.sh's reports as a table: per build and rank count, the fullest rank's
peak (MiB) without and with a checkpoint at the end (medians of the turns),
the checkpoint's part of the peak (memory.peak_by_stage "other": what came
after the last stage) and the checkpoint's seconds (the slowest rank).
Usage: python3 table.py [FOLDER]"""
import glob, json, os, statistics, sys
from collections import defaultdict

folder = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
MiB = 2 ** 20
runs = defaultdict(list)
for f in sorted(glob.glob(os.path.join(folder, "m-*.json"))):
    build, ranks, ckpt, _ = os.path.basename(f)[2:-5].split("-")
    runs[(build, int(ranks[1:]), ckpt)].append(json.load(open(f)))


def med(js, get):
    return statistics.median(get(j) for j in js)


peak = lambda j: j["memory"]["peak_rss_bytes"]["max"] / MiB
print("| build | ranks | peak, no checkpoint | peak, checkpoint (turns) | median | checkpoint's part | checkpoint s | state hash |")
print("|---|---|---|---|---|---|---|---|")
for build, ranks in sorted({(b, r) for b, r, _ in runs}, key=lambda k: (k[1], k[0] != "before")):
    none, ck = runs[(build, ranks, "none")], runs[(build, ranks, "ckpt")]
    print(f"| {build} | {ranks} | {med(none, peak):.1f} | {', '.join(f'{peak(j):.1f}' for j in ck)} | {med(ck, peak):.1f} | "
          f"{med(ck, lambda j: j['memory']['peak_by_stage']['other'] / MiB):.1f} | "
          f"{med(ck, lambda j: j['checkpoints']['seconds']):.3f} | {ck[0]['state_hash']} |")
