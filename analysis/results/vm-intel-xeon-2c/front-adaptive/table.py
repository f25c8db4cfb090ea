#!/usr/bin/env python3
"""Medians over turns of what cost.sh ran: ms a step and of the solve stage
and its substages over the steps after the first, the adaptive solver's
listed sweeps and relaxed contacts a step, and the ratios to the first
variant. Usage: table.py OUT VARIANT..."""
import glob
import json
import statistics
import sys

out, variants = sys.argv[1], sys.argv[2:]
rows = []
for i, v in enumerate(variants, 1):
    vals = {}
    for fn in sorted(glob.glob(f"{out}/v{i}.t*.json")):
        r = json.load(open(fn))
        f, n = r["first_step"], r["steps"]
        d = {"step": 1e3 * (r["steps_wall_s"] - f["wall_s"]) / (n - 1),
             "solve": 1e3 * (r["stages"]["solve"] - f["stages"].get("solve", 0)) / (n - 1)}
        for k, x in r["substages"]["solve"].items():
            d[k] = 1e3 * (x - f["substages"].get("solve", {}).get(k, 0)) / (n - 1)
        a = r["solver"].get("active") or {}
        d["listed"], d["relaxed"] = a.get("sweeps_per_step", 0.0), a.get("relaxed_per_step", 0.0)
        d["hash"] = r["state_hash"]
        for k, x in d.items():
            vals.setdefault(k, []).append(x)
    rows.append({k: (statistics.median(x) if k != "hash" else sorted(set(x))) for k, x in vals.items()})
cols = ["step", "solve", "build", "warm_start", "sweeps", "active", "integrate", "listed", "relaxed"]
print("| variant | " + " | ".join(cols) + " | solve / first | hash |")
print("|" + "---|" * (len(cols) + 3))
for v, r in zip(variants, rows):
    print(f"| `{v}` | " + " | ".join(f"{r.get(c, 0):.2f}" for c in cols) +
          f" | {r['solve'] / rows[0]['solve']:.3f} | {' '.join(r['hash'])} |")
