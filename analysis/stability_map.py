#!/usr/bin/env python3
"""Stability map table from jobs/stability_map.py output.

Reads DIR/<case>/dt<k>.json and it<n>.json and writes OUT/stability_map.csv
and .md (OUT: default results/analysis; `--out analysis/results` updates the
committed ones): for each hard case, its own dt and
iterations, the largest dt (at its own iterations) such that it and every
smaller dt tried pass the case's [checks], the first failing dt and why, and
the fewest iterations (at its own dt) such that it and every larger count
tried pass.
Trade-off: thresholds are bracketed by the ladder (factors of 2 in dt), not
bisected.

Usage: python3 analysis/stability_map.py DIR [--out results/analysis]
"""
import argparse
import glob
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def fail(message):
    print(f"stability_map: {message}", file=sys.stderr)
    sys.exit(2)


def why(r):
    if "failed" in r:
        return "guard: " + r["failed"].split(": ", 2)[-1][:70]
    items = r["report"].get("checks", {}).get("items", [])
    return "; ".join(f"{i['name']} = {i['value']:.3g} (bound {i['bound']:.3g})" for i in items if not i["passed"])


def ladder(results, key, reverse):
    """Largest (or smallest) value before the first failure, walking from the scene's own setting."""
    best, first_fail = None, None
    for value, r in sorted(results, key=lambda x: x[0], reverse=reverse):
        if not r["passed"]:
            first_fail = (value, why(r))
            break
        best = value
    return best, first_fail


def case_row(case_dir):
    dts, its, base_it = [], [], None
    for path in glob.glob(os.path.join(case_dir, "*.json")):
        r = json.load(open(path))
        name = os.path.basename(path)
        s = dict(x.split("=", 1) for x in r["sets"])
        if name.startswith("dt"):
            dts.append((float(s["scene.dt"]), r))
            if "report" in r and name == "dt1.json":
                base_it = r["report"]["solver"]["iterations"] if r["report"]["solver"]["stepper"] == "quick" else None
        else:
            its.append((int(s["solver.iterations"]), r))
    base_dt = min(d for d, _ in dts)
    if base_it is not None:
        its.append((base_it, dict(dts)[base_dt]))
    max_dt, dt_fail = ladder(dts, "dt", reverse=False)
    min_it, it_fail = ladder(its, "it", reverse=True) if its else (None, None)
    return {"case": os.path.basename(os.path.normpath(case_dir)), "dt": base_dt,
            "iterations": base_it if base_it is not None else "dWorldStep",
            "largest_passing_dt": max_dt, "first_failing_dt": dt_fail[0] if dt_fail else "none tried",
            "dt_failure": dt_fail[1] if dt_fail else "",
            "fewest_passing_iterations": min_it if its else "n/a",
            "first_failing_iterations": it_fail[0] if it_fail else ("none tried" if its else "n/a"),
            "iterations_failure": it_fail[1] if it_fail else ""}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", help="jobs/stability_map.py --out")
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "analysis"),
                    help="where the table goes (default results/analysis; analysis/results updates the committed one)")
    args = ap.parse_args()
    if not os.path.isdir(args.dir):
        fail(f"no such folder: {args.dir} (run jobs/stability_map.py first, or pass the committed "
             "analysis/results/<machine>/stability)")
    cases = [d for d in sorted(glob.glob(os.path.join(args.dir, "*", ""))) if glob.glob(os.path.join(d, "dt*.json"))]
    if not cases:
        fail(f"{args.dir} has no case folders with dt*.json reports (from jobs/stability_map.py)")
    os.makedirs(args.out, exist_ok=True)
    rows = [case_row(d) for d in cases]
    keys = list(rows[0].keys())
    with open(os.path.join(args.out, "stability_map.csv"), "w") as f:
        f.write(",".join(keys) + "\n")
        for r in rows:
            f.write(",".join('"' + str(r[k]).replace('"', "'") + '"' for k in keys) + "\n")
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(str(r[k]) for k in keys) + " |" for r in rows]
    open(os.path.join(args.out, "stability_map.md"), "w").write("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
