#!/usr/bin/env python3
"""run.sh's reports as a table: per catoms a rank, rank count and build, the
fullest rank's peak (MiB, each turn and median), its growth over one rank of
the same build, bytes a catom, the ghost fraction and the state hash.
Usage: python3 table.py [FOLDER]"""
import glob, json, os, statistics, sys
from collections import defaultdict

folder = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
runs = defaultdict(list)
for f in glob.glob(os.path.join(folder, "m-*-n*-r*-*.json")):
    build, n, r, _ = os.path.basename(f)[2:-5].split("-")
    runs[(int(n[1:]), int(r[1:]), build)].append(json.load(open(f)))


def peak(j):
    return j["memory"]["peak_rss_bytes"]["max"] / 2 ** 20


print("| catoms a rank | ranks | build | peak MiB (turns) | median | over 1 rank | bytes a catom | ghost fraction | state hash |")
print("|---|---|---|---|---|---|---|---|---|")
for (n, r, build), js in sorted(runs.items(), key=lambda kv: (kv[0][0], kv[0][1], kv[0][2] != "before")):
    med = statistics.median(peak(j) for j in js)
    one = statistics.median(peak(j) for j in runs[(n, 1, build)])
    grow = "" if r == 1 else f"{100 * (med / one - 1):+.2f} %"
    ghosts = js[0].get("parallel", {}).get("ghost_fraction", 0) or 0
    hashes = {j["state_hash"] for j in js}
    print(f"| {n:,} | {r} | {build} | {', '.join(f'{peak(j):.1f}' for j in js)} | {med:.1f} | {grow} | "
          f"{med * 2 ** 20 / n:,.0f} | {ghosts:.4f} | {', '.join(sorted(hashes))} |")
