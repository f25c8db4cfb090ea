#!/usr/bin/env python3
"""Speed-against-error table and Pareto front from sweep reports.

Reads DIR/<scene>/*.json (written by jobs/sweep.py: `parode run --reference`
reports) and writes, per scene, analysis/results/speed_error_<scene>.csv, a
Markdown table speed_error_<scene>.md and a plot speed_error_<scene>.png
(cost against error, Pareto front drawn and starred in the table).
Cost: wall seconds per simulated second (configurations with different dt
simulate the same time). Error, per scene, the metric that stays meaningful:
- tennis (a chaotic collapse): |centre-of-mass height error| + |spread error|
  at the end (m), the long-horizon observables of the pile;
- magnetic-tennis (the prism holds): shape error at the end (m), RMS of the
  catom positions about the centroid against the reference's;
- buggy (few bodies, smooth until contacts diverge): RMS position error at
  t = 2 s (m).
The table also lists the short-horizon position RMS at t = 0.05 s, escaped
catoms, max penetration and the largest energy gain.
Trade-off: one scalar error per scene makes a front; the other columns show
what it leaves out.

Usage: python3 analysis/speed_error.py DIR [--out analysis/results]
"""
import argparse
import csv
import glob
import json
import os

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def at_time(series, t):
    for time, rms in zip(series["time"], series["rms"]):
        if time >= t - 1e-9:
            return rms
    return float("nan")


def scene_error(scene, e):
    o = e["observables"]
    if scene == "magnetic-tennis":
        return o["shape_error"], "shape error at the end (m)"
    if scene == "buggy":
        return at_time(e["series"], 2.0), "position RMS at t = 2 s (m)"
    return abs(o["com_height"]["diff"]) + abs(o["spread"]["diff"]), "|com height err| + |spread err| at the end (m)"


def row(scene, name, r):
    e = r["error"]
    err, label = scene_error(scene, e)
    sim_s = r["steps"] * r["dt"]
    s = r["solver"]
    return {"config": name, "dt": r["dt"], "solver": r["backends"]["solve"], "iterations": s["iterations"],
            "sor_w": s["sor_w"], "erp": s["erp"], "cfm": s["cfm"], "threads": r["threads"],
            "collide": r["backends"]["collide"], "cost_s_per_sim_s": r["wall_s"] / sim_s, "error": err,
            "rms_0.05s": at_time(e["series"], 0.05), "final_rms": e["final"]["rms"],
            "com_height_err": e["observables"]["com_height"]["diff"], "spread_err": e["observables"]["spread"]["diff"],
            "escaped": e["observables"]["escaped"]["run"], "escaped_ref": e["observables"]["escaped"]["reference"],
            "max_penetration": e["penetration"]["max"], "energy_max_gain": e["energy"]["max_gain"]}, label


def pareto(rows):
    front = []
    for a in rows:
        dominated = any(b["cost_s_per_sim_s"] <= a["cost_s_per_sim_s"] and b["error"] <= a["error"] and
                        (b["cost_s_per_sim_s"] < a["cost_s_per_sim_s"] or b["error"] < a["error"]) for b in rows)
        a["pareto"] = not dominated
        if not dominated:
            front.append(a)
    return sorted(front, key=lambda r: r["cost_s_per_sim_s"])


def write_tables(scene, rows, label, out):
    keys = list(rows[0].keys())
    with open(os.path.join(out, f"speed_error_{scene}.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    cols = ["config", "dt", "solver", "iterations", "sor_w", "erp", "cfm", "threads", "cost_s_per_sim_s", "error",
            "rms_0.05s", "escaped", "max_penetration", "energy_max_gain"]
    lines = [f"### {scene}: error = {label}", "", "| " + " | ".join(cols + ["front"]) + " |",
             "|" + "---|" * (len(cols) + 1)]
    for r in sorted(rows, key=lambda r: r["cost_s_per_sim_s"]):
        cells = [f"{r[c]:.4g}" if isinstance(r[c], float) else str(r[c]) for c in cols]
        lines.append("| " + " | ".join(cells + ["*" if r["pareto"] else ""]) + " |")
    open(os.path.join(out, f"speed_error_{scene}.md"), "w").write("\n".join(lines) + "\n")


def plot(scene, rows, front, label, out):
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for r in rows:
        ax.scatter(r["cost_s_per_sim_s"], r["error"], color="C0" if r["pareto"] else "0.6", zorder=3)
        ax.annotate(r["config"], (r["cost_s_per_sim_s"], r["error"]), fontsize=7, xytext=(3, 3),
                    textcoords="offset points")
    ax.plot([r["cost_s_per_sim_s"] for r in front], [r["error"] for r in front], "C0-", label="Pareto front")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("cost: wall s per simulated s (1 thread unless noted)")
    ax.set_ylabel(label)
    ax.set_title(f"{scene}: speed against error")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(out, f"speed_error_{scene}.png"), dpi=110)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", help="sweep output (jobs/sweep.py --out)")
    ap.add_argument("--out", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "results"))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    for scene_dir in sorted(glob.glob(os.path.join(args.dir, "*", ""))):
        scene = os.path.basename(os.path.dirname(scene_dir))
        rows, label = [], ""
        for path in sorted(glob.glob(os.path.join(scene_dir, "*.json"))):
            r = json.load(open(path))
            if "error" not in r:
                continue  # the reference itself, or a failed run
            one, label = row(scene, os.path.splitext(os.path.basename(path))[0], r)
            rows.append(one)
        if not rows:
            continue
        front = pareto(rows)
        write_tables(scene, rows, label, args.out)
        plot(scene, rows, front, label, args.out)
        print(f"{scene}: {len(rows)} configurations, front: " + ", ".join(r["config"] for r in front))


if __name__ == "__main__":
    main()
