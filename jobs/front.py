#!/usr/bin/env python3
"""Runs for the speed-against-error front of the contact solver's settings,
with error measures that rank configurations where the end state is chaotic.

Three kinds of runs, all with parode's contact solvers (`--solver parallel`, or
`adaptive/omp` for the configurations named adaptive-*: a setting "solver=NAME"
in a configuration picks the solver):
- ensembles: every configuration on SEEDS seeds (scene.seed moves the jitter of
  the prism), and the same seeds with a converged reference configuration
  (dt / 4, 100 iterations): their trajectories give the ensemble observables
  (centre-of-mass height, horizontal spread, contacts per catom, kinetic
  energy) that analysis/front.py compares with confidence intervals;
- short horizons: seed 1 of every configuration against a fine reference
  (dt / 8, 200 iterations) with `--reference`, whose report holds the RMS
  position error at every observed step; a second fine reference started
  1e-9 m away (the jitter scaled by 1 + 2e-9 / radius: every catom moves by
  less than 1e-9 m) measures the pile's own divergence time, and the converged
  reference against the fine one shows how far two references agree;
- cost: the solve stage per step at --cost-counts catoms (default 64,000) of
  every configuration on 1 and 2 threads, the configurations interleaved in
  REPEATS rounds; the cores busy with other work are measured for 0.5 s
  before every timed run (/proc/stat), and runs started above --max-load are
  marked `disturbed`.

- exact: the invariants of tests/test_exact.py (incline, restitution apex,
  elastic head-on collision) for every configuration, measured over analytic.

Output: OUT/machine.json, OUT/exact.json, OUT/ensemble/<config>.seed<k>.json (+ .traj, not
meant to be committed: --traj), OUT/horizon/<config>.json, OUT/cost/<config>.t<T>.r<R>.json.
Existing reports are reused unless --force.

Usage: python3 jobs/front.py [--out results/front] [--scene jobs/scenes/tennis.toml]
       [--count 1000] [--duration 5] [--seeds 8] [--cost-counts 64000] [--repeats 3]
Trade-off: a handful of configurations around the settings that matter
(substeps, iterations, dt) rather than a grid, so that 8 seeds fit a small machine.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tomllib

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from sweep import busy_cores, machine  # noqa: E402  (the load before a run; host, CPU, commit, binary hash)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def same_spring(erp, cfm, s):
    """ERP and CFM at dt / s of the contact spring and damper that ERP and CFM
    define at dt (ERP = h kp / (h kp + kd), CFM = 1 / (h kp + kd)), as
    solver.substeps converts them (src/solve/contact_rows.hpp)."""
    a, b = erp / s, 1 - erp
    return [f"solver.erp={a / (a + b)!r}", f"solver.cfm={cfm / (a + b)!r}"]


class Plan:
    """The configurations and references of one scene, from its file: around
    its dt, iterations and contact (ERP, CFM). Over-relaxed substeps with
    fewer than 3 iterations each (4 x 2, 8 x 1, 8 x 2 at SOR w 1.3: measured
    in analysis/results/vm-amd-epyc-2c/front/) gain energy on a bounce, and
    substeps with magnets on pump energy into the lattice: parode refuses
    both, so they are not configurations; substeps of one or two sweeps at
    w = 1 are."""

    def __init__(self, scene):
        with open(scene, "rb") as f:
            sc = tomllib.load(f)
        self.dt = dt = sc["scene"]["dt"]
        sv = sc.get("solver", {})
        erp, cfm = sv.get("erp", 0.2), sv.get("cfm", 1e-5)
        cat = sc.get("catoms", {})
        self.radius, self.jitter = cat.get("radius", 0.5), cat.get("jitter", 0.01)
        adaptive = ["solver=adaptive/omp"]
        self.configs = {
            "default": [],
            "adaptive": adaptive,
            "adaptive-s6": adaptive + ["solver.adaptive_sweeps=6"],
            "adaptive-s10": adaptive + ["solver.adaptive_sweeps=10"],
            "adaptive-tol0.1": adaptive + ["solver.tolerance=0.1"],
            "adaptive-x10": adaptive + ["solver.extra_sweeps=10"],
            "it5": ["solver.iterations=5"],
            "it10": ["solver.iterations=10"],
            "it40": ["solver.iterations=40"],
            f"dt{1e3 * dt / 2:g}ms": [f"scene.dt={dt / 2:g}"],
            f"dt{1e3 * dt / 2:g}ms-it10": [f"scene.dt={dt / 2:g}", "solver.iterations=10"],
        }
        if not sc.get("magnets", {}).get("enabled", False):
            self.configs.update({
                "sub2-it5": ["solver.substeps=2", "solver.iterations=5"],
                "sub2-it10": ["solver.substeps=2", "solver.iterations=10"],
                "sub4-it3": ["solver.substeps=4", "solver.iterations=3"],
                "sub4-it5": ["solver.substeps=4", "solver.iterations=5"],
                "sub4-it1-w1": ["solver.substeps=4", "solver.iterations=1", "solver.sor_w=1"],
                "sub4-it2-w1": ["solver.substeps=4", "solver.iterations=2", "solver.sor_w=1"],
                # 4 substeps with STIFF's contact: ERP and CFM at dt that are the scene's at dt / 4.
                "sub4-it3-stiff": ["solver.substeps=4", "solver.iterations=3"] + stiffer(erp, cfm),
            })
        # References: converged in dt and iterations with the scene's contact
        # spring (ERP and CFM converted to the shorter step), and, as the
        # "converged" of earlier studies, with the same ERP and CFM at dt / 4:
        # a contact 4 x stiffer.
        self.converged = [f"scene.dt={dt / 4:g}", "solver.iterations=100"] + same_spring(erp, cfm, 4)
        self.stiff = [f"scene.dt={dt / 4:g}", "solver.iterations=100"]
        self.fine = [f"scene.dt={dt / 8:g}", "solver.iterations=200"] + same_spring(erp, cfm, 8)

    def all(self, only=None):
        """Every configuration and the references (only: these names, and the
        converged reference every measure compares with)."""
        every = list(self.configs.items()) + [("converged", self.converged), ("stiff", self.stiff)]
        return [(n, s) for n, s in every if not only or n in only or n == "converged"]


def stiffer(erp, cfm):
    """The ERP and CFM at dt whose conversion to dt / 4 (same_spring) is `erp`
    and `cfm` (tennis: ERP 0.5 and CFM 6.25e-6)."""
    h_kp = 4 * erp / cfm  # dt kp of the spring that ERP and CFM make at dt / 4
    kd = (1 - erp) / cfm
    return [f"solver.erp={h_kp / (h_kp + kd)!r}", f"solver.cfm={1 / (h_kp + kd)!r}"]


def parode_run(args, sets, report, extra=(), threads=1):
    if os.path.exists(report) and not args.force:
        return
    os.makedirs(os.path.dirname(report), exist_ok=True)
    solver = next((s.split("=", 1)[1] for s in sets if s.startswith("solver=")), "parallel")
    cmd = [args.parode, "run", args.scene, "--collide", "grid", "--solver", solver, "--threads", str(threads),
           "-q", "--report", report] + list(extra)
    for s in sets:
        if not s.startswith("solver="):
            cmd += ["--set", s]
    print(" ".join(os.path.relpath(c, ROOT) if c.startswith(ROOT) else c for c in cmd), flush=True)
    subprocess.run(cmd, check=True, timeout=args.timeout)


def ensembles(args):
    common = [f"catoms.count={args.count}"]
    length = ["--duration", str(args.duration)]
    for seed in range(1, args.seeds + 1):
        for name, sets in args.plan.all(args.configs):
            traj = os.path.join(args.traj, f"{name}.seed{seed}.traj")
            os.makedirs(args.traj, exist_ok=True)
            parode_run(args, common + sets + [f"scene.seed={seed}"],
                       os.path.join(args.out, "ensemble", f"{name}.seed{seed}.json"), length + ["--trajectory", traj])


def horizons(args):
    common = [f"catoms.count={args.count}", "scene.seed=1"]
    length = ["--duration", str(args.horizon)]
    fine = os.path.join(args.traj, "fine.traj")
    os.makedirs(args.traj, exist_ok=True)
    plan = args.plan
    parode_run(args, common + plan.fine, os.path.join(args.out, "horizon", "fine.json"), length + ["--trajectory", fine])
    nudge = plan.jitter * (1 + 2e-9 / plan.radius)  # every catom moves by less than 1e-9 m
    parode_run(args, common + plan.fine + [f"catoms.jitter={nudge!r}"], os.path.join(args.out, "horizon", "fine-nudged.json"),
               length + ["--reference", fine])
    for name, sets in plan.all(args.configs):
        parode_run(args, common + sets, os.path.join(args.out, "horizon", f"{name}.json"), length + ["--reference", fine])


def exact(args):
    """The exact invariants of tests/test_exact.py for every configuration (dt
    as the tests set it): measured over analytic."""
    sys.path.insert(0, os.path.join(ROOT, "tests"))
    import test_exact as te  # noqa: E402  (the tests' scenes and measurements)
    te.PARODE = args.parode
    configs = {"quickstep": ["--solver", "ode"]}
    for name, sets in args.plan.configs.items():
        if any(s.startswith("scene.dt=") for s in sets) or (args.configs and name not in args.configs):
            continue
        solver = next((s.split("=", 1)[1] for s in sets if s.startswith("solver=")), "parallel")
        configs[name] = ["--solver", solver] + [x for s in sets if not s.startswith("solver=") for x in ("--set", s)]
    out = {}
    for name, opt in configs.items():
        row = {}
        for shape, deg, mu in (("sphere", 20, 0.5), ("sphere", 20, 0.05), ("box", 35, 0.5)):
            got, want = te.incline_ratio(shape, deg, mu, opt)
            row[f"{shape} {deg} deg mu {mu}"] = got / want
        row["box 20 deg mu 0.5 (m)"] = te.incline_ratio("box", 20, 0.5, opt)[0]
        row["apex"] = te.apex_ratio(opt)
        va, vb = te.head_on(1.0, opt)
        row["elastic energy"] = (0.5 * va * va + 1.5 * vb * vb) / 3.5
        row["momentum error"] = abs(va + 3 * vb + 1)
        out[name] = row
        print(name, row, flush=True)
    with open(os.path.join(args.out, "exact.json"), "w") as f:
        json.dump(out, f, indent=1)


def costs(args):
    for count in args.cost_counts:
        steps = max(3, int(2e6 // count))
        for r in range(1, args.repeats + 1):
            for threads in (1, 2):
                for name, sets in args.plan.configs.items():
                    if args.cost_configs and name not in args.cost_configs:
                        continue
                    base = args.plan.dt
                    dt = next((float(s.split("=")[1]) for s in sets if s.startswith("scene.dt=")), base)
                    n = int(round(steps * base / dt))  # the same simulated time
                    report = os.path.join(args.out, "cost", f"{name}.n{count}.t{threads}.r{r}.json")
                    if os.path.exists(report) and not args.force:
                        continue
                    load = busy_cores()
                    parode_run(args, [f"catoms.count={count}"] + sets, report, ["--steps", str(n)], threads)
                    with open(report) as f:
                        rep = json.load(f)
                    rep["front"] = {"busy_cores_before": load, "disturbed": load > args.max_load, "config": name,
                                    "count": count, "threads": threads, "round": r}
                    with open(report, "w") as f:
                        json.dump(rep, f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "front"))
    ap.add_argument("--traj", default=None, help="trajectories (default OUT-traj)")
    ap.add_argument("--scene", default=os.path.join(ROOT, "jobs", "scenes", "tennis.toml"))
    ap.add_argument("--parode", default=os.path.join(ROOT, "build", "ci", "parode"))
    ap.add_argument("--count", type=int, default=1000)
    ap.add_argument("--duration", type=float, default=5.0)
    ap.add_argument("--horizon", type=float, default=2.0, help="simulated seconds of the short-horizon runs")
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--cost-counts", type=int, nargs="*", default=[64000])
    ap.add_argument("--cost-configs", nargs="*", help="time only these configurations")
    ap.add_argument("--configs", nargs="*", help="ensembles, horizons and exact invariants of only these configurations")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--max-load", type=float, default=0.3,
                    help="cores busy with other work (measured for 0.5 s before each timed run) that mark it disturbed")
    ap.add_argument("--timeout", type=float, default=3600)
    ap.add_argument("--only", choices=["ensembles", "horizons", "costs", "exact"], nargs="*")
    ap.add_argument("--force", action="store_true")
    args = ap.parse_args()
    args.traj = args.traj or args.out.rstrip("/") + "-traj"
    args.plan = Plan(args.scene)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "machine.json"), "w") as f:
        json.dump(machine(args.parode), f, indent=1)
    for part in args.only or ["ensembles", "horizons", "costs", "exact"]:
        {"ensembles": ensembles, "horizons": horizons, "costs": costs, "exact": exact}[part](args)


if __name__ == "__main__":
    main()
