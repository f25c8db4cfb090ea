#!/usr/bin/env python3
"""Speed-up and parallel efficiency over MPI ranks x OpenMP threads.

Reads the JSON run reports that jobs/rank_scaling.sh writes (one per run,
repeats allowed; the mode, strong, weak or threads, from the file name) and,
per (mode, catoms, ranks, threads), takes the median ms/step and per-stage
time over repeats. Strong and thread scaling (the same catoms for every run):
speed-up = t(1 rank, 1 thread) / t and efficiency = speed-up / (ranks x
threads). Weak scaling (catoms per rank fixed): efficiency = t(1 rank) / t at
the same thread count. Also reports ghost fraction, communication share,
messages per step, peak memory per rank, and whether every run of one size
gave the same state hash.

Writes OUT/rank_scaling.md, OUT/rank_scaling.csv and OUT/rank_scaling.png
(speed-up and efficiency against cores = ranks x threads, one line per series
with the ideal drawn, and time per stage per run as stacked bars).
Trade-off: medians hide the spread; the CSV keeps min and max for that, and
the plots draw it as error bars.

Usage: python3 analysis/rank_scaling.py DIR [DIR ...] [--out OUT] [--title TEXT]
       (OUT defaults to the first DIR)
"""
import argparse
import glob
import json
import os
import sys

import pandas as pd

STAGES = ["migrate", "exchange", "forces", "collide", "joints", "solve", "observe", "output"]
MODES = ("strong", "weak", "threads")


def load(directory):
    rows = []
    for path in sorted(glob.glob(os.path.join(directory, "*.json"))):
        try:
            with open(path) as f:
                r = json.load(f)
        except (OSError, json.JSONDecodeError) as e:
            print(f"{path}: skipped ({e})", file=sys.stderr)
            continue
        if "ms_per_step" not in r or not r.get("steps"):
            continue
        name = os.path.basename(path)
        mode = name.split("-")[0] if name.split("-")[0] in MODES else "strong"
        steps = r["steps"]
        par = r.get("parallel") or {}
        colours = par.get("colours", [])
        row = {"mode": mode, "catoms": r["bodies"], "ranks": r.get("ranks", 1), "threads": r["threads"],
               "ms": r["ms_per_step"], "hash": r["state_hash"],
               "ghost_fraction": par.get("ghost_fraction", 0.0),
               "comm_s": par.get("comm_seconds", {}).get("max", 0.0) if isinstance(par.get("comm_seconds"), dict) else 0.0,
               "messages": par.get("messages_per_step", 0.0),
               "rss_mb": r.get("memory", {}).get("peak_rss_bytes", {}).get("max", 0.0) / 2**20,
               # the solver's colours: compute (slowest rank, mean rank) and waits, ms a step
               "colour_max_ms": 1e3 * sum(c["compute_s"]["max"] for c in colours) / steps,
               "colour_avg_ms": 1e3 * sum(c["compute_s"]["avg"] for c in colours) / steps,
               "wait_ms": 1e3 * par.get("wait_seconds", {}).get("max", 0.0) / steps,
               "colour_imbalance": par.get("colour_imbalance", 1.0),
               "wall": r.get("steps_wall_s", r["wall_s"])}
        for s in STAGES:
            row[s] = 1e3 * r["stages"].get(s, 0.0) / steps
        rows.append(row)
    return pd.DataFrame(rows)


def summarise(df):
    keys = ["mode", "catoms", "ranks", "threads"]
    g = df.groupby(keys)
    out = g[["ms"] + STAGES + ["ghost_fraction", "comm_s", "messages", "rss_mb", "wall", "colour_max_ms",
                               "colour_avg_ms", "wait_ms", "colour_imbalance"]].median()
    out["ms_min"] = g["ms"].min()
    out["ms_max"] = g["ms"].max()
    out["runs"] = g["ms"].count()
    out = out.reset_index()
    out["comm_share"] = out["comm_s"] / out["wall"].where(out["wall"] > 0, 1)
    for mode, part in out.groupby("mode"):
        idx = part.index
        if mode in ("strong", "threads"):
            for n, same in part.groupby("catoms"):
                base = same[(same.ranks == 1) & (same.threads == 1)]
                if base.empty:
                    continue
                t1 = base["ms"].iloc[0]
                out.loc[same.index, "speedup"] = t1 / same["ms"]
                out.loc[same.index, "efficiency"] = t1 / same["ms"] / (same.ranks * same.threads)
        else:
            per_rank = part.catoms // part.ranks
            for _, same in part.groupby([part.threads, per_rank]):
                base = same[same.ranks == 1]
                if base.empty:
                    continue
                out.loc[same.index, "efficiency"] = base["ms"].iloc[0] / same["ms"]
        del idx
    return out


def hashes_agree(df):
    bad = []
    for (mode, n), part in df.groupby(["mode", "catoms"]):
        if part["hash"].nunique() > 1:
            bad.append(f"{mode} {n}: {sorted(part['hash'].unique())}")
    return bad


def markdown(out, bad):
    lines = ["| mode | catoms | ranks | threads | ms/step (min-max) | speed-up | efficiency | collide | solve | "
             "migrate+exchange | ghosts | comm share | msgs/step | colour imb. | solver waits | peak MB/rank |",
             "|" + "---|" * 16]
    for _, r in out.iterrows():
        sp = f"{r['speedup']:.2f}" if "speedup" in r and pd.notna(r.get("speedup")) else "-"
        ef = f"{r['efficiency']:.2f}" if pd.notna(r.get("efficiency")) else "-"
        lines.append(f"| {r['mode']} | {r['catoms']} | {r['ranks']} | {r['threads']} | {r['ms']:.1f} "
                     f"({r['ms_min']:.1f}-{r['ms_max']:.1f}) | {sp} | {ef} | {r['collide']:.1f} | {r['solve']:.1f} | "
                     f"{r['migrate'] + r['exchange']:.1f} | {100 * r['ghost_fraction']:.1f} % | "
                     f"{100 * r['comm_share']:.1f} % | {r['messages']:.0f} | {r['colour_imbalance']:.3f} | "
                     f"{r['wait_ms']:.1f} | {r['rss_mb']:.0f} |")
    lines.append("")
    lines.append("state hash identical for every rank and thread count of each size" if not bad
                 else "STATE HASHES DIFFER: " + "; ".join(bad))
    return "\n".join(lines) + "\n"


def series(out):
    """(label, rows sorted by cores) per line of the speed-up and efficiency plots."""
    out = out.assign(cores=out.ranks * out.threads, size=out.catoms)
    weak = out["mode"] == "weak"
    out.loc[weak, "size"] = out.catoms[weak] // out.ranks[weak]  # weak: catoms per rank
    for (mode, n), part in out.groupby(["mode", "size"]):
        fixed, free = ("ranks", "threads") if mode == "threads" else ("threads", "ranks")
        size = f"{n} catoms per rank" if mode == "weak" else f"{n} catoms"
        for v, line in part.groupby(fixed):
            yield f"{mode}, {size}, {v} {fixed[:-1] if v == 1 else fixed}", mode, line.sort_values("cores"), free


def plot(out, path, title=""):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 4, figsize=(21, 4.8), gridspec_kw={"width_ratios": [1, 1, 1.4, 1.2]})
    top = 1
    for label, mode, line, free in series(out):
        cores = line.ranks * line.threads
        top = max(top, cores.max())
        if mode != "weak" and "speedup" in line:  # no 1 x 1 run: no speed-up to draw
            spread = [line.speedup - line.speedup * line.ms / line.ms_max, line.speedup * line.ms / line.ms_min - line.speedup]
            axes[0].errorbar(cores, line.speedup, yerr=spread, fmt="o-", capsize=3, label=f"{label} (over {free})")
        if "efficiency" in line:
            axes[1].plot(cores, line.efficiency, "o-", label=f"{label} (over {free})")
    axes[0].plot([1, top], [1, top], "k:", label="ideal")
    axes[1].axhline(1, color="k", ls=":", label="ideal")
    axes[0].set(xlabel="cores (ranks x threads)", ylabel="speed-up vs 1 rank x 1 thread", title="speed-up")
    axes[1].set(xlabel="cores (ranks x threads)", ylabel="efficiency", title="parallel efficiency", ylim=(0, 1.2))
    labels = [f"{r.mode}\nn={r.catoms}\n{r.ranks}r x {r.threads}t" for r in out.itertuples()]
    bottom = [0.0] * len(out)
    for stage in STAGES:
        vals = list(out[stage])
        if sum(vals) == 0:
            continue
        axes[2].bar(range(len(out)), vals, bottom=bottom, label=stage)
        bottom = [b + v for b, v in zip(bottom, vals)]
    axes[2].set_xticks(range(len(out)), labels, fontsize=7)
    axes[2].set(ylabel="ms per step (slowest rank, median run)", title="time per stage")
    # The solver's colours on distributed runs: each colour waits for its
    # slowest rank; the gap between the slowest and the mean rank's compute
    # is the colours' imbalance, the waits add the messages.
    dist = out[out.ranks > 1].reset_index(drop=True)
    x = range(len(dist))
    axes[3].bar([i - 0.27 for i in x], dist.colour_avg_ms, width=0.27, label="compute, mean rank")
    axes[3].bar(list(x), dist.colour_max_ms, width=0.27, label="compute, slowest rank")
    axes[3].bar([i + 0.27 for i in x], dist.wait_ms, width=0.27, label="waits, slowest rank")
    axes[3].set_xticks(list(x), [f"n={r.catoms}\n{r.ranks}r x {r.threads}t\nimb {r.colour_imbalance:.3f}"
                                 for r in dist.itertuples()], fontsize=7)
    axes[3].set(ylabel="ms per step", title="solver colours (distributed runs)")
    for ax in axes:
        ax.legend(fontsize=7)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("dirs", nargs="+", metavar="DIR", help="folders of run reports")
    ap.add_argument("--out", help="where the tables and the plot go (default: the first DIR)")
    ap.add_argument("--title", default="", help="title of the plot (the machine, say)")
    a = ap.parse_args()
    frames = []
    for d in a.dirs:
        if not os.path.isdir(d):
            print(f"rank_scaling: {d}: no such folder", file=sys.stderr)
            sys.exit(2)
        frames.append(load(d))
    df = pd.concat(frames, ignore_index=True)
    if df.empty:
        print(f"rank_scaling: {', '.join(a.dirs)}: no run reports", file=sys.stderr)
        sys.exit(2)
    out_dir = a.out or a.dirs[0]
    os.makedirs(out_dir, exist_ok=True)
    out = summarise(df)
    bad = hashes_agree(df)
    text = markdown(out, bad)
    print(text)
    with open(os.path.join(out_dir, "rank_scaling.md"), "w") as f:
        f.write(text)
    out.to_csv(os.path.join(out_dir, "rank_scaling.csv"), index=False)
    plot(out, os.path.join(out_dir, "rank_scaling.png"), a.title)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
