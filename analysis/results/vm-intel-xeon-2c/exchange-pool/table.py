#!/usr/bin/env python3
"""run.sh's reports as tables: the fullest rank's peak (MiB) per build and
rank count (each turn, median, growth over one rank, the peak's exchange and
solve parts), and the ghost exchange's time at 10^6 catoms on 2 ranks over
steps 2-4 (ms a step, each turn, median, after/before).
Usage: python3 table.py [FOLDER]"""
import glob, json, os, statistics, sys
from collections import defaultdict

folder = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
MiB = 2 ** 20
mem = defaultdict(list)
for f in sorted(glob.glob(os.path.join(folder, "m-*.json"))):
    build, ranks, _ = os.path.basename(f)[2:-5].split("-")
    mem[(build, int(ranks[1:]))].append(json.load(open(f)))


def peak(j):
    return j["memory"]["peak_rss_bytes"]["max"] / MiB


def part(js, name):
    return statistics.median(j["memory"]["peak_by_stage"][name] / MiB for j in js)


print("| build | ranks | peak MiB (turns) | median | over 1 rank | exchange part | solve part | state hash |")
print("|---|---|---|---|---|---|---|---|")
for (build, ranks), js in sorted(mem.items(), key=lambda kv: (kv[0][1], kv[0][0] != "before")):
    med = statistics.median(peak(j) for j in js)
    one = statistics.median(peak(j) for j in mem.get((build, 1), js))
    grow = "" if ranks == 1 else f"{100 * (med / one - 1):+.1f} %"
    print(f"| {build} | {ranks} | {', '.join(f'{peak(j):.1f}' for j in js)} | {med:.1f} | {grow} | "
          f"{part(js, 'exchange'):.1f} | {part(js, 'solve'):.1f} | {js[0]['state_hash']} |")

ex = defaultdict(list)
for f in sorted(glob.glob(os.path.join(folder, "e-*.json"))):
    j = json.load(open(f))
    steps = j["steps"] - 1
    ms = 1000 * (j["stages"]["exchange"] - j["first_step"]["stages"]["exchange"]) / steps
    ex[os.path.basename(f).split("-")[1]].append((ms, j["state_hash"]))
if ex:
    print()
    print("| build | exchange, ms a step over steps 2-4 (turns) | median | state hash |")
    print("|---|---|---|---|")
    for build in ("before", "after"):
        v = ex.get(build, [])
        if v:
            print(f"| {build} | {', '.join(f'{m:.1f}' for m, _ in v)} | {statistics.median(m for m, _ in v):.1f} | {v[0][1]} |")
    if ex.get("before") and ex.get("after"):
        r = statistics.median(m for m, _ in ex["after"]) / statistics.median(m for m, _ in ex["before"])
        print(f"\nafter / before: {r:.2f}")
