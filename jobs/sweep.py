#!/usr/bin/env python3
"""Speed-against-error sweep of the classic scenes (tennis, magnetic-tennis, buggy).

For each scene: one reference run (high accuracy: dt/4 and 100 QuickStep
iterations, or dWorldStep at dt/4 for the buggy; one thread) writes its
trajectory; then every configuration runs for the same simulated time with
`parode run --reference`, which puts the error metrics into its report under
`error`. One JSON report per configuration: DIR/<scene>/<config>.json.
Configurations vary one setting at a time around the scene's defaults (dt,
QuickStep iterations, SOR w, stepper, ERP, CFM, threads with the grid backend),
plus a few combinations along the expected front. Trade-off: one-at-a-time
variation (about 20 runs per scene) instead of a full grid (hundreds), so it
fits a small machine; analysis/speed_error.py draws the front from whatever
reports exist.

Usage: python3 jobs/sweep.py [--out results/sweep] [--scenes tennis,buggy]
                             [--count 1000] [--duration S] [--parode build/ci/parode]
"""
import argparse
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# scene -> (file, duration s, reference overrides, configurations {name: [--set ...]})
def configs(scene, dt):
    c = {"default": []}
    for f in (0.5, 2, 4):
        c[f"dt{dt * f:g}"] = [f"scene.dt={dt * f:g}"]
    if scene != "buggy":
        for it in (5, 10, 40, 80):
            c[f"it{it}"] = [f"solver.iterations={it}"]
        for w in (1.0, 1.6):
            c[f"w{w:g}"] = [f"solver.sor_w={w:g}"]
        c[f"dt{dt * 2:g}-it40"] = [f"scene.dt={dt * 2:g}", "solver.iterations=40"]
        c[f"dt{dt * 0.5:g}-it10"] = [f"scene.dt={dt * 0.5:g}", "solver.iterations=10"]
        c["grid-2threads"] = ["@--collide", "@grid", "@--threads", "@2"]
        # The project contact solver (--solver parallel), alone and with fewer iterations.
        par = ["@--collide", "@grid", "@--solver", "@parallel"]
        c["parallel-1thread"] = par + ["@--threads", "@1"]
        c["parallel-2threads"] = par + ["@--threads", "@2"]
        for it in (5, 10):
            c[f"parallel-it{it}"] = par + ["@--threads", "@2", f"solver.iterations={it}"]
    else:
        c["quick-it20"] = ["solver.stepper=quick", "solver.iterations=20"]
        c["quick-it50"] = ["solver.stepper=quick", "solver.iterations=50"]
        c["quick-it100"] = ["solver.stepper=quick", "solver.iterations=100"]
    for erp in (0.1, 0.5):
        c[f"erp{erp:g}"] = [f"solver.erp={erp:g}"]
    for cfm in (1e-6, 1e-4):
        c[f"cfm{cfm:g}"] = [f"solver.cfm={cfm:g}"]
    return c

SCENES = {
    "tennis": ("jobs/scenes/tennis.toml", 5.0, 0.005, ["solver.iterations=100"]),
    "magnetic-tennis": ("jobs/scenes/magnetic-tennis.toml", 5.0, 0.005, ["solver.iterations=100"]),
    "buggy": ("jobs/scenes/buggy.toml", 20.0, 0.01, ["solver.stepper=world"]),
}


def run(parode, scene_file, duration, sets, extra, report, timeout):
    cmd = [parode, "run", os.path.join(ROOT, scene_file), "--duration", f"{duration:g}", "-q", "--report", report]
    for s in sets:
        cmd += ["--set", s]
    cmd += extra
    print(" ".join(cmd[1:]), flush=True)
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        json.dump({"failed": f"timed out after {timeout} s", "command": cmd}, open(report, "w"))
        return
    if p.returncode not in (0, 5):
        json.dump({"failed": p.stderr.strip(), "rc": p.returncode, "command": cmd}, open(report, "w"))


def sweep_scene(args, name):
    scene_file, duration, dt, ref_sets = SCENES[name]
    duration = args.duration or duration
    out = os.path.join(args.out, name)
    os.makedirs(out, exist_ok=True)
    size = [] if name == "buggy" else [f"catoms.count={args.count}"]
    ref_traj = os.path.join(out, "reference.traj")
    if not os.path.exists(ref_traj):
        run(args.parode, scene_file, duration, size + [f"scene.dt={dt / 4:g}"] + ref_sets,
            ["--threads", "1", "--trajectory", ref_traj], os.path.join(out, "reference.json"), args.timeout)
    for cname, sets in configs(name, dt).items():
        report = os.path.join(out, cname + ".json")
        if os.path.exists(report) and not args.force:
            continue
        extra = [s[1:] for s in sets if s.startswith("@")]
        plain = [s for s in sets if not s.startswith("@")]
        if "--threads" not in extra:
            extra += ["--threads", "1"]
        run(args.parode, scene_file, duration, size + plain, extra + ["--reference", ref_traj], report, args.timeout)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "sweep"))
    ap.add_argument("--scenes", default="tennis,magnetic-tennis,buggy")
    ap.add_argument("--count", type=int, default=1000, help="catoms in tennis and magnetic-tennis")
    ap.add_argument("--duration", type=float, default=0, help="simulated seconds (default: per scene)")
    ap.add_argument("--parode", default=os.path.join(ROOT, "build", "ci", "parode"))
    ap.add_argument("--timeout", type=int, default=900)
    ap.add_argument("--force", action="store_true", help="rerun configurations that have a report")
    args = ap.parse_args()
    for name in args.scenes.split(","):
        if name not in SCENES:
            sys.exit(f"sweep: unknown scene '{name}' (expected one of {', '.join(SCENES)})")
        sweep_scene(args, name)


if __name__ == "__main__":
    main()
