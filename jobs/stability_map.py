#!/usr/bin/env python3
"""Stability map of the hard cases (jobs/scenes/hard/*.toml).

For each hard case, runs the scene for its own simulated duration (its
scene.steps x scene.dt) with a ladder of larger time steps (1, 2, 4, 8, 16 x
its dt) at its own iterations, and a ladder of fewer QuickStep iterations at
its own dt, and records whether the scene's [checks] pass (a run the guard
stops, NaN or runaway, fails). One compact JSON per run: DIR/<case>/dt<x>.json
or it<n>.json, with `passed` and the run report (or the guard's message);
DIR/machine.json says where and when (host, CPU, cores, date, commit).
analysis/stability_map.py turns them into the table of the largest dt and
the fewest iterations at which each case still passes.
Trade-off: a ladder of factors of 2 bounds the thresholds to within a factor
of 2 in a dozen short runs per case; the 100,000-catom pile is left out
(minutes per run).

Usage: python3 jobs/stability_map.py [--out results/stability] [--parode build/ci/parode] [--cases a,b]
"""
import argparse
import glob
import json
import os
import subprocess
import tomllib

from sweep import machine

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SKIP = {"pile-100k"}
DT_FACTORS = (1, 2, 4, 8, 16)
ITERATIONS = (100, 50, 20, 10, 5, 2, 1)


def run_case(parode, scene, duration, sets, report):
    cmd = [parode, "run", os.path.relpath(scene, ROOT), "--duration", f"{duration:g}", "-q", "--threads", "1",
           "--report", report]
    for s in sets:
        cmd += ["--set", s]
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT)
    if p.returncode == 1:  # the guard stopped the run: no report
        result = {"passed": False, "failed": p.stderr.strip(), "sets": sets}
    else:
        result = {"passed": p.returncode == 0, "sets": sets, "report": json.load(open(report))}
    with open(report, "w") as f:
        json.dump(result, f, separators=(",", ":"))
    print(f"  {' '.join(sets):40s} {'pass' if result['passed'] else 'FAIL'}", flush=True)


def map_case(args, scene):
    case = os.path.splitext(os.path.basename(scene))[0]
    spec = tomllib.load(open(scene, "rb"))
    dt = spec["scene"].get("dt", 0.005)
    duration = spec["scene"].get("steps", 1000) * dt
    solver = spec.get("solver", {})
    iterations = solver.get("iterations", 20)
    out = os.path.join(args.out, case)
    os.makedirs(out, exist_ok=True)
    print(f"{case}: dt {dt:g}, {iterations} iterations, {duration:g} s", flush=True)
    for f in DT_FACTORS:
        run_case(args.parode, scene, duration, [f"scene.dt={dt * f:g}"], os.path.join(out, f"dt{f}.json"))
    if solver.get("stepper", "quick") != "quick":
        return  # dWorldStep has no iterations
    for it in ITERATIONS:
        if it < iterations:
            run_case(args.parode, scene, duration, [f"solver.iterations={it}"], os.path.join(out, f"it{it}.json"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "stability"))
    ap.add_argument("--parode", default=os.path.join(ROOT, "build", "ci", "parode"))
    ap.add_argument("--cases", default="", help="comma-separated case names (default: all but pile-100k)")
    args = ap.parse_args()
    args.parode, args.out = os.path.abspath(args.parode), os.path.abspath(args.out)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "machine.json"), "w") as f:
        json.dump(machine(args.parode), f, indent=1)
    chosen = set(filter(None, args.cases.split(",")))
    for scene in sorted(glob.glob(os.path.join(ROOT, "jobs", "scenes", "hard", "*.toml"))):
        case = os.path.splitext(os.path.basename(scene))[0]
        if (chosen and case not in chosen) or (not chosen and case in SKIP):
            continue
        map_case(args, scene)


if __name__ == "__main__":
    main()
