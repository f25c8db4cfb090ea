#!/usr/bin/env python3
"""Medians of run.sh's reports: ms a step after the first, of the whole step
and of the forces stage (the magnet pass), before and after, per size and
thread count. Usage: python3 table.py [FOLDER]"""
import glob
import json
import os
import statistics
import sys

here = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
rows = {}
for p in glob.glob(os.path.join(here, "*", "*.json")):
    n = os.path.basename(os.path.dirname(p))
    v, t, _ = os.path.basename(p)[:-5].split("-")
    with open(p) as f:
        r = json.load(f)
    k = r["steps"] - 1
    first = r["first_step"]
    e = rows.setdefault((int(n), t, v), {"step": [], "forces": [], "hash": set()})
    e["step"].append(1e3 * (r["steps_wall_s"] - first["wall_s"]) / k)
    e["forces"].append(1e3 * (r["stages"]["forces"] - first["stages"]["forces"]) / k)
    e["hash"].add(r["state_hash"])
print("| catoms | threads | step before | after | ratio | forces before | after | ratio | runs | hash |")
print("|---|---|---|---|---|---|---|---|---|---|")
for n, t in sorted({(n, t) for n, t, _ in rows}):
    b, a = rows[(n, t, "before")], rows[(n, t, "after")]
    sb, sa = statistics.median(b["step"]), statistics.median(a["step"])
    fb, fa = statistics.median(b["forces"]), statistics.median(a["forces"])
    same = "same" if b["hash"] == a["hash"] and len(a["hash"]) == 1 else "DIFFERENT"
    print(f"| {n:,} | {t[1:]} | {sb:.1f} | {sa:.1f} | {sa / sb:.3f} | {fb:.1f} | {fa:.1f} | {fa / fb:.3f} | "
          f"{len(a['step'])} | {same} |")
