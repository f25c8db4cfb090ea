#!/usr/bin/env python3
"""Speed-against-error tables and plots, with the Pareto front, from sweep reports.

Reads DIR/<scene>/*.json (written by jobs/sweep.py: `parode run --reference`
reports, several runs per configuration, the reference and the references
with other seeds) and DIR/machine.json, and writes, per scene, into OUT
(default results/analysis; `--out analysis/results` updates the committed
ones) speed_error_<scene>.csv, a Markdown table .md and a plot .png.
Cost: wall seconds per simulated second, the median of the runs, with their
minimum and maximum, over the runs the sweep did not mark disturbed (other
work on the cores before the run; `timed_runs` counts them, 0 where every
run was disturbed and all are used).
Error, per scene, the metric that stays meaningful:
- tennis (a chaotic collapse): |centre-of-mass height error| + |spread error|
  at the end (m), the long-horizon observables of the pile;
- magnetic-tennis (the prism holds): shape error at the end (m), RMS of the
  catom positions about the centroid against the reference's;
- buggy (few bodies on a closed track): largest position RMS over the run (m).
Noise floor of the error: the same metric for the reference run with other
seeds against the first seed, equally good runs; below it the order of the
configurations is noise. Errors <= 0 are drawn at a floor of the log axis,
marked as such. The table also lists the short-horizon position RMS at
t = 0.05 s, escaped catoms, max penetration and the largest energy gain.
Trade-off: one scalar error per scene makes a front; the other columns show
what it leaves out; the front uses the median cost, the bars show how much
of it is noise.

Usage: python3 analysis/speed_error.py DIR [--out results/analysis]
"""
import argparse
import csv
import glob
import json
import os
import statistics
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LABELS = {"tennis": "|com height err| + |spread err| at the end (m)",
          "magnetic-tennis": "shape error at the end (m)",
          "buggy": "largest position RMS over the run (m)"}


def fail(message):
    print(f"speed_error: {message}", file=sys.stderr)
    sys.exit(2)


def at_time(series, t):
    for time, rms in zip(series["time"], series["rms"]):
        if time >= t - 1e-9:
            return rms
    return float("nan")


def scene_error(scene, e):
    o = e["observables"]
    if scene == "magnetic-tennis":
        return o["shape_error"]
    if scene == "buggy":
        return max(e["series"]["rms"], default=0.0)
    return abs(o["com_height"]["diff"]) + abs(o["spread"]["diff"])


def load_scene(scene_dir):
    """{config: [reports by run]}, [noise-floor reports], failures {config: message}."""
    configs, noise, failed = {}, [], {}
    for path in sorted(glob.glob(os.path.join(scene_dir, "*.json"))):
        try:
            with open(path) as f:
                r = json.load(f)
        except ValueError as e:
            failed[os.path.basename(path)] = f"not a JSON report ({e})"
            continue
        sw = r.get("sweep", {"role": "config", "config": os.path.splitext(os.path.basename(path))[0], "run": 1})
        if "failed" in r:
            failed[sw.get("config", path)] = r["failed"].splitlines()[-1][:120] if r["failed"] else "failed"
        elif r.get("steps", 0) == 0:
            failed[sw.get("config", path)] = "no step in the duration (dt longer than the run)"
        elif sw.get("role") == "noise-floor" and "error" in r:
            noise.append(r)
        elif sw.get("role") == "config" and "error" in r:
            configs.setdefault(sw["config"], []).append(r)
    return configs, noise, failed


def row(scene, name, runs):
    first = runs[0]
    e, s = first["error"], first["solver"]
    quiet = [r for r in runs if not r.get("sweep", {}).get("disturbed", False)]  # timed on an idle machine
    costs = [r.get("steps_wall_s", r["wall_s"]) / (r["steps"] * r["dt"]) for r in (quiet or runs)]
    errors = [scene_error(scene, r["error"]) for r in runs]
    o = e["observables"]
    return {"config": name, "dt": first["dt"], "solver": first["backends"]["solve"], "iterations": s["iterations"],
            "sor_w": s["sor_w"], "erp": s["erp"], "cfm": s["cfm"], "threads": first["threads"],
            "collide": first["backends"]["collide"], "runs": len(runs), "timed_runs": len(quiet),
            "cost_s_per_sim_s": statistics.median(costs), "cost_min": min(costs), "cost_max": max(costs),
            "error": statistics.median(errors), "error_spread": max(errors) - min(errors),
            "matched_frames": e["matched_frames"],
            "same_state_hash": len({r["state_hash"] for r in runs}) == 1,
            "rms_0.05s": at_time(e["series"], 0.05), "final_rms": e["final"]["rms"],
            "com_height_err": o["com_height"]["diff"], "spread_err": o["spread"]["diff"],
            "escaped": o["escaped"]["run"], "escaped_ref": o["escaped"]["reference"],
            "max_penetration": e["penetration"]["max"], "energy_max_gain": e["energy"]["max_gain"]}


def pareto(rows):
    def dominates(b, a):
        return (b["cost_s_per_sim_s"] <= a["cost_s_per_sim_s"] and b["error"] <= a["error"] and
                (b["cost_s_per_sim_s"] < a["cost_s_per_sim_s"] or b["error"] < a["error"]))
    for a in rows:
        a["pareto"] = not any(dominates(b, a) for b in rows)
    return sorted((r for r in rows if r["pareto"]), key=lambda r: r["cost_s_per_sim_s"])


def describe(scene, example, machine, dates, runs):
    """Title lines: what ran, where and when."""
    size = f"N = {example['catoms']} catoms" if example.get("catoms") else f"{example['bodies']} bodies"
    sim = example["steps"] * example["dt"]
    where = f"{machine.get('host', '?')} ({machine.get('cpu', '?')}, {machine.get('cores', '?')} cores)"
    when = dates[0] if len(set(dates)) == 1 else f"{min(dates)} to {max(dates)}"
    return (f"{scene}: speed against error, {size}, {sim:g} s simulated",
            f"{where}, {when}, {runs} runs per configuration")


def write_tables(scene, rows, label, noise, out):
    keys = list(rows[0].keys())
    with open(os.path.join(out, f"speed_error_{scene}.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    cols = ["config", "dt", "solver", "iterations", "sor_w", "erp", "cfm", "threads", "timed_runs", "cost_s_per_sim_s",
            "cost_min", "cost_max", "error", "rms_0.05s", "escaped", "max_penetration", "energy_max_gain"]
    lines = [f"### {scene}: error = {label}", ""]
    if noise:
        lines += [f"Error noise floor (reference with other seeds against seed 1): "
                  + ", ".join(f"{x:.3g}" for x in noise) + " m", ""]
    lines += ["| " + " | ".join(cols + ["front"]) + " |", "|" + "---|" * (len(cols) + 1)]
    for r in sorted(rows, key=lambda r: r["cost_s_per_sim_s"]):
        cells = [f"{r[c]:.4g}" if isinstance(r[c], float) else str(r[c]) for c in cols]
        lines.append("| " + " | ".join(cells + ["*" if r["pareto"] else ""]) + " |")
    with open(os.path.join(out, f"speed_error_{scene}.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


def floor_of(rows, noise):
    """Where errors <= 0 are drawn on the log axis: a third of the smallest positive error."""
    positive = [r["error"] for r in rows if r["error"] > 0] + [x for x in noise if x > 0]
    return min(positive) / 3 if positive else 1e-9


def draw_points(ax, rows, floor):
    others = []
    for r in sorted(rows, key=lambda r: r["cost_s_per_sim_s"]):
        x, y = r["cost_s_per_sim_s"], max(r["error"], floor)
        default = r["config"] == "default"
        color = "C3" if default else "C0" if r["pareto"] else "0.55"
        marker = "v" if r["error"] <= 0 else "*" if default else "o"
        ax.errorbar(x, y, xerr=[[x - r["cost_min"]], [r["cost_max"] - x]], fmt=marker, color=color,
                    markersize=11 if default else 6, capsize=2, elinewidth=0.8, zorder=4 if r["pareto"] else 3)
        if not (r["pareto"] or default):
            others.append(r)
            ax.annotate(str(len(others)), (x, y), fontsize=7, color="0.35", xytext=(3, 3),
                        textcoords="offset points")
    return others


def label_front(ax, rows, front, floor):
    named = sorted(front + [r for r in rows if r["config"] == "default" and not r["pareto"]],
                   key=lambda r: r["cost_s_per_sim_s"])
    for i, r in enumerate(named):
        default = r["config"] == "default"
        offset = (-9, -15) if default else (7, 7 if i % 2 == 0 else -13)
        ax.annotate(r["config"], (r["cost_s_per_sim_s"], max(r["error"], floor)), fontsize=8, xytext=offset,
                    textcoords="offset points", ha="right" if default else "left",
                    color="C3" if default else "C0", fontweight="bold" if r["pareto"] else None)
    ax.plot([r["cost_s_per_sim_s"] for r in front], [max(r["error"], floor) for r in front], "C0-", lw=1,
            label="Pareto front (median cost)", zorder=2)


def caption(rows, front, noise, runs):
    spread = max(r["cost_max"] / r["cost_min"] for r in rows if r["cost_min"] > 0)
    timed = sum(r["timed_runs"] for r in rows)
    lines = [f"Bars: min to max cost of the timed runs ({runs} identical runs each; {timed} of "
             f"{sum(r['runs'] for r in rows)} started on an idle machine);",
             f"identical runs varied up to {100 * (spread - 1):.0f} % in wall time, so only larger cost differences count."]
    top = max(noise, default=0.0)
    if top > 0:
        lines.append(f"Shaded: error noise floor, the reference run with {len(noise)} other seed(s) against "
                     f"the first (up to {top:.2g} m); errors inside it are equally good.")
        inside = [r for r in front if r["error"] <= top]
        if all(r["error"] <= 2 * top for r in front):
            lines.append("Every point of the front is within 2x of the band's top (dashed: each seed): its order "
                         "is decided by chaotic noise, not by accuracy.")
        elif inside:
            lines.append("Where the front lies inside the band its order is decided by noise, not by accuracy.")
    elif noise:
        lines.append("The reference with other seeds gives the same result: no noise floor on this scene.")
    if any(r["error"] <= 0 for r in rows):
        lines.append("Triangles: error 0 (no difference from the reference at the matched frames), "
                     "drawn at the bottom of the log axis.")
    return "\n".join(lines)


def log_axes(ax):
    """Log axes labelled in plain numbers (1, 2, 5 per decade over short ranges), no minor labels."""
    for axis, scale, limits in ((ax.xaxis, ax.set_xscale, ax.get_xlim), (ax.yaxis, ax.set_yscale, ax.get_ylim)):
        scale("log")
        lo, hi = limits()
        subs = (1.0, 2.0, 5.0) if hi / max(lo, 1e-300) < 300 else (1.0,)
        axis.set_major_locator(LogLocator(base=10, subs=subs))
        axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
        axis.set_minor_formatter(NullFormatter())


def plot(scene, rows, front, noise, label, title, out):
    fig = plt.figure(figsize=(10, 5.8))
    ax = fig.add_axes([0.08, 0.24, 0.64, 0.66])
    floor = floor_of(rows, noise)
    if max(noise, default=0) > 0:
        ax.axhspan(floor / 2, max(noise), color="C1", alpha=0.15, lw=0, label="error noise floor (other seeds)")
        for x in noise:
            ax.axhline(max(x, floor), color="C1", lw=0.8, ls="--")
    others = draw_points(ax, rows, floor)
    label_front(ax, rows, front, floor)
    ax.plot([], [], "*", color="C3", markersize=11, label="default configuration")
    log_axes(ax)
    ax.margins(x=0.08, y=0.12)
    if max(noise, default=0) > 0 or any(r["error"] <= 0 for r in rows):
        ax.set_ylim(bottom=floor / 2)  # the band and the errors drawn at the floor stay in view
    ax.set_xlabel("cost: wall s per simulated s (1 thread unless the name says otherwise)")
    ax.set_ylabel(label)
    ax.set_title("\n".join(title), fontsize=10)
    ax.legend(fontsize=8, loc="best")
    runs = max(r["runs"] for r in rows)
    fig.text(0.08, 0.015, caption(rows, front, noise, runs), fontsize=7.5, va="bottom")
    listing = "\n".join(f"{i:>2}  {r['config']}" for i, r in enumerate(others, 1))
    fig.text(0.75, 0.89, "other configurations\n\n" + listing, fontsize=8, va="top", family="monospace")
    fig.savefig(os.path.join(out, f"speed_error_{scene}.png"), dpi=110)
    plt.close(fig)


def machine_info(directory):
    try:
        with open(os.path.join(directory, "machine.json")) as f:
            return json.load(f)
    except (OSError, ValueError):
        return {}


def scene_dirs(directory):
    if not os.path.isdir(directory):
        fail(f"no such folder: {directory} (run jobs/sweep.py first, or pass the committed "
             "analysis/results/<machine>/sweep)")
    dirs = sorted(glob.glob(os.path.join(directory, "*", "")))
    if not dirs:
        fail(f"{directory} has no scene folders (<scene>/*.json from jobs/sweep.py)")
    return dirs


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", help="sweep output (jobs/sweep.py --out)")
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "analysis"),
                    help="where the tables and plots go (default results/analysis; "
                         "analysis/results updates the committed ones)")
    args = ap.parse_args()
    machine = machine_info(args.dir)
    done = 0
    for scene_dir in scene_dirs(args.dir):
        scene = os.path.basename(os.path.dirname(scene_dir))
        configs, noise_reports, failed = load_scene(scene_dir)
        for name, why in failed.items():
            print(f"{scene}: {name} failed: {why}", file=sys.stderr)
        if not configs:
            print(f"{scene}: no configuration reports, skipped", file=sys.stderr)
            continue
        os.makedirs(args.out, exist_ok=True)
        rows = [row(scene, name, runs) for name, runs in sorted(configs.items())]
        noise = [scene_error(scene, r["error"]) for r in noise_reports]
        front = pareto(rows)
        label = LABELS.get(scene, LABELS["tennis"])
        example = configs.get("default", next(iter(configs.values())))[0]
        dates = [r.get("sweep", {}).get("date", machine.get("date", "?")) for runs in configs.values() for r in runs]
        title = describe(scene, example, machine, dates, max(r["runs"] for r in rows))
        write_tables(scene, rows, label, noise, args.out)
        plot(scene, rows, front, noise, label, title, args.out)
        done += 1
        print(f"{scene}: {len(rows)} configurations, front: " + ", ".join(r["config"] for r in front))
    if not done:
        fail(f"no configuration reports under {args.dir}")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
