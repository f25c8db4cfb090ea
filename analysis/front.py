#!/usr/bin/env python3
"""The speed-against-error front of the contact solver's settings, from the
runs of jobs/front.py: error measures that rank configurations on a chaotic
collapse, against the cost of the solve stage.

- Ensemble bias: per configuration, the mean over seeds of the centre-of-mass
  height, horizontal spread, contacts per catom (the frames' contact count over
  the catoms) and shape drift (the RMS change of the catoms' positions about
  their centroid since the start: the settled shape of a magnetic prism) at
  the end, and the kinetic energy at KE_TIMES, minus the mean
  of the converged reference ensemble on the same seeds; with its 95 %
  confidence interval (Welch's t, the two ensembles' standard errors). A bias
  is significant when the interval excludes 0.
- Short horizons: the pile's divergence time (when the RMS position distance
  of two fine references started 1e-9 m apart first exceeds 1 % of the catom
  radius), and each configuration's RMS position error against the fine
  reference at a quarter and half of it; the converged reference's own error
  is the floor two references agree to.
- Cost: the median solve-stage milliseconds per simulated 5 ms (a step of
  the default dt) over the steps after the first and over the rounds, 1 and 2
  threads, disturbed runs (other work on the cores) left out and counted; its
  ratio to the default's.

Writes OUT/front.md (tables) and OUT/front.png (bias and horizon error
against cost); the ensemble observables go to RESULTS/ensemble_observables.json,
which is read instead when the trajectories are gone.
Usage: python3 analysis/front.py RESULTS [--traj DIR] [--out DIR]
Trade-off: 8 seeds give confidence intervals of about a standard deviation;
only end-of-run observables and a few horizons, not whole time series.
"""
import argparse
import glob
import json
import math
import os
import re
import statistics

import numpy as np

KE_TIMES = (0.5, 1.0, 2.0)
RADIUS = 0.5
HEADER = 16


def read_traj(path):
    with open(path, "rb") as f:
        line = f.readline()
        meta = json.loads(line.split(b" ", 2)[2])
        data = np.frombuffer(f.read(), dtype="<f8")
    n = meta["bodies"]
    frames = data.reshape(-1, HEADER + 3 * n)
    return meta, frames


def observables(path):
    _, fr = read_traj(path)
    last = fr[-1]
    n = (fr.shape[1] - HEADER) // 3
    pos = last[HEADER:].reshape(n, 3)
    c = pos[:, :2].mean(axis=0)
    start = fr[0][HEADER:].reshape(n, 3)
    moved = (pos - pos.mean(axis=0)) - (start - start.mean(axis=0))
    out = {"com_height": last[10], "spread": math.sqrt(((pos[:, :2] - c) ** 2).sum(axis=1).mean()),
           "contacts_per_catom": last[13] / n, "shape_drift": math.sqrt((moved ** 2).sum(axis=1).mean())}
    times = fr[:, 1]
    for t in KE_TIMES:
        out[f"ke_{t:g}s"] = fr[int(np.argmin(abs(times - t))), 2]
    return out


def t95(df):
    table = {1: 12.71, 2: 4.30, 3: 3.18, 4: 2.78, 5: 2.57, 6: 2.45, 7: 2.36, 8: 2.31, 10: 2.23, 12: 2.18, 14: 2.14,
             16: 2.12, 20: 2.09, 30: 2.04}
    return table[min(table, key=lambda k: abs(k - df))]


def bias(xs, ref):
    """Mean difference, 95 % half-width (Welch), and whether it excludes 0."""
    a, b = statistics.mean(xs), statistics.mean(ref)
    va, vb = statistics.variance(xs) / len(xs), statistics.variance(ref) / len(ref)
    se = math.sqrt(va + vb)
    df = (va + vb) ** 2 / (va ** 2 / (len(xs) - 1) + vb ** 2 / (len(ref) - 1)) if se > 0 else 1
    half = t95(df) * se
    return a - b, half, abs(a - b) > half


def ensembles(traj, results):
    """config -> seed -> observables, from the trajectories when they are there
    (and then kept in RESULTS/ensemble_observables.json), else from that file."""
    kept = os.path.join(results, "ensemble_observables.json")
    paths = sorted(glob.glob(os.path.join(traj, "*.seed*.traj")))
    if not paths:
        with open(kept) as f:
            return {name: {int(k): v for k, v in seeds.items()} for name, seeds in json.load(f).items()}
    runs = {}
    for p in paths:
        name, seed = re.match(r"(.+)\.seed(\d+)\.traj$", os.path.basename(p)).groups()
        runs.setdefault(name, {})[int(seed)] = {k: float(v) for k, v in observables(p).items()}
    with open(kept, "w") as f:
        json.dump(runs, f, indent=0, sort_keys=True)
    return runs


def divergence(results):
    with open(os.path.join(results, "horizon", "fine-nudged.json")) as f:
        s = json.load(f)["error"]["series"]
    for t, r in zip(s["time"], s["rms"]):
        if r > 0.01 * RADIUS:
            return t
    return s["time"][-1]


def horizon_errors(results, at):
    out = {}
    for p in glob.glob(os.path.join(results, "horizon", "*.json")):
        name = os.path.basename(p)[:-5]
        if name in ("fine", "fine-nudged"):
            continue
        with open(p) as f:
            s = json.load(f)["error"]["series"]
        out[name] = [float(np.interp(t, s["time"], s["rms"])) for t in at]
    return out


def costs(results):
    rows = {}
    for p in glob.glob(os.path.join(results, "cost", "*.json")):
        with open(p) as f:
            r = json.load(f)
        fr = r["front"]
        key = (fr["config"], fr["count"], fr["threads"])
        e = rows.setdefault(key, {"solve": [], "step": [], "disturbed": 0})
        if fr["disturbed"]:
            e["disturbed"] += 1
            continue
        per = 0.005 / r["dt"]  # steps per 5 ms of simulated time
        first = r["first_step"]  # it faults in every buffer: left out
        n = r["steps"] - 1
        e["solve"].append(1e3 * (r["stages"]["solve"] - first["stages"]["solve"]) / n * per)
        e["step"].append(1e3 * (r["steps_wall_s"] - first["wall_s"]) / n * per)
    return rows


def exact_table(results):
    """RESULTS/exact.json (jobs/front.py --only exact) as a table, if there."""
    try:
        with open(os.path.join(results, "exact.json")) as f:
            ex = json.load(f)
    except OSError:
        return []
    keys = list(next(iter(ex.values())).keys())
    lines = ["", "Exact invariants (tests/test_exact.py): measured over analytic, 1 is exact; the box at 20 deg must "
             "stick (metres moved); the momentum error of the head-on collision in kg m/s.", "",
             "| configuration | " + " | ".join(keys) + " |", "|---" * (len(keys) + 1) + "|"]
    for name, row in ex.items():
        lines.append(f"| {name} | " + " | ".join(f"{row[k]:.4g}" for k in keys) + " |")
    return lines


def write(out, runs, div, herr, at, cost, results):
    ref = runs["converged"]
    seeds = sorted(ref)
    keys = list(next(iter(ref.values())).keys())
    lines = ["# Speed against error of the contact solver's settings", "",
             f"Ensembles: {len(seeds)} seeds; bias = configuration mean - converged mean (dt 1.25 ms, 100 iterations), "
             "95 % interval; * marks a bias whose interval excludes 0.", "",
             "| configuration | " + " | ".join(keys) + " |", "|---" * (len(keys) + 1) + "|"]
    lines.append("| converged (mean) | " + " | ".join(f"{statistics.mean(ref[s][k] for s in seeds):.4g}" for k in keys) + " |")
    for name in sorted(runs, key=lambda n: (n != "default", n)):
        if name == "converged":
            continue
        cells = []
        for k in keys:
            d, h, sig = bias([runs[name][s][k] for s in seeds if s in runs[name]], [ref[s][k] for s in seeds])
            cells.append(f"{d:+.3g} ± {h:.2g}{' *' if sig else ''}")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", f"Divergence time of the pile (two fine references 1e-9 m apart, RMS > 1 % of the radius): "
              f"**{div:.3g} s**. RMS position error (m) against the fine reference (dt 0.625 ms, 200 iterations):", "",
              "| configuration | " + " | ".join(f"t = {t:.3g} s" for t in at) + " |", "|---" * (len(at) + 1) + "|"]
    for name in sorted(herr, key=lambda n: (n != "converged", n)):
        lines.append(f"| {name} | " + " | ".join(f"{e:.3g}" for e in herr[name]) + " |")
    if cost:
        lines += ["", "Cost: median solve-stage ms per 5 ms of simulated time (median ms of the whole step), "
                  "ratio to the default; disturbed runs left out.", "",
                  "| configuration | catoms | threads | solve ms | step ms | solve / default | runs (disturbed) |",
                  "|---|---|---|---|---|---|---|"]
        for (name, count, th), e in sorted(cost.items(), key=lambda kv: (kv[0][1], kv[0][2], kv[0][0])):
            if not e["solve"]:
                continue
            base = cost.get(("default", count, th), {}).get("solve") or [float("nan")]
            s = statistics.median(e["solve"])
            lines.append(f"| {name} | {count} | {th} | {s:.1f} | {statistics.median(e['step']):.1f} | "
                         f"{s / statistics.median(base):.3f} | {len(e['solve'])} ({e['disturbed']}) |")
    lines += exact_table(results)
    with open(os.path.join(out, "front.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))


def plot(out, runs, herr, cost, at):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    ref = runs["converged"]
    seeds = sorted(ref)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for name in runs:
        c = cost.get((name, min(k[1] for k in cost), 2)) if cost else None
        if name == "converged" or not c or not c["solve"]:
            continue
        x = statistics.median(c["solve"])
        d, h, _ = bias([runs[name][s]["com_height"] for s in seeds], [ref[s]["com_height"] for s in seeds])
        axes[0].errorbar(x, 1e3 * d, yerr=1e3 * h, fmt="o", capsize=3)
        axes[0].annotate(name, (x, 1e3 * d), fontsize=7)
        if name in herr:
            axes[1].plot(x, herr[name][-1], "o")
            axes[1].annotate(name, (x, herr[name][-1]), fontsize=7)
    axes[0].axhline(0, color="grey", lw=0.5)
    axes[0].set(xlabel="solve ms per 5 ms simulated (2 threads)", ylabel="com height bias (mm), 95 % CI",
                title="ensemble bias against the converged reference")
    axes[1].set(xlabel="solve ms per 5 ms simulated (2 threads)", ylabel=f"RMS position error at {at[-1]:.2g} s (m)",
                yscale="log", title="short-horizon error against the fine reference")
    if "converged" in herr:
        axes[1].axhline(herr["converged"][-1], color="grey", lw=0.5, ls="--")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "front.png"), dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("results")
    ap.add_argument("--traj", default=None)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    traj = a.traj or a.results.rstrip("/") + "-traj"
    out = a.out or a.results
    os.makedirs(out, exist_ok=True)
    runs = ensembles(traj, a.results)
    div = divergence(a.results)
    at = (div / 4, div / 2)
    herr = horizon_errors(a.results, at)
    cost = costs(a.results)
    write(out, runs, div, herr, at, cost, a.results)
    plot(out, runs, herr, cost, at)


if __name__ == "__main__":
    main()
