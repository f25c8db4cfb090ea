#!/usr/bin/env python3
"""Distributed variants side by side: the tennis prism on RANKS processes x
THREADS threads, each variant a set of scene overrides and an injected
latency, every variant run once per turn (the order rotated from turn to
turn), REPEATS turns; the medians kept.

A variant is NAME=SPEC with SPEC a comma list of `latency=US` (the
PARODE_INJECT_LATENCY_US testing aid: every point-to-point exchange
completes no sooner than US microseconds after it began, as on a network of
that latency), `ranks=R`, `threads=T`, `parode=PATH` (another build, e.g.
the one before a change), `same=LABEL` (the computation the variant belongs
to; default "all") and `key=value` scene overrides, e.g.
    base=latency=0  lat20=latency=20  blocking20=latency=20,parallel.overlap=false
    total=parallel.balance="total"  one=ranks=0,threads=2
(ranks=0: one process, no launcher).

Per run it records from the JSON run report the ms per step over the steps
after the first (steps_wall_s minus first_step.wall_s; the first faults in
every buffer and distributes the bodies), the solve stage, the collide
stage over the steps after the first (max over ranks), the solver's
per-colour compute and wait (max over ranks), the colour imbalance, the
waits, the exchange's bytes, the edge cut, the partition's colour imbalance,
peak memory per rank and the state hash; writes OUT/variants_runs.csv and
OUT/variants.md (medians, ratios against the first variant) and checks that
the variants of one computation (one `same` label: all of them unless
labelled) gave one state hash (they must: no layout, latency or overlap may
change a bit); variants that compute different things on purpose (another
solver setting) carry different labels.
Trade-off: whole runs as separate processes, so each pays its start-up; only
the steps after the first are compared.

Usage: python3 jobs/rank_variants.py --catoms 20000 --steps 40 --ranks 2 --threads 1 \\
           --repeats 5 --out results/variants base=latency=0 lat20=latency=20 ...
"""
import argparse
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def parse_variant(text, ranks, threads):
    name, _, spec = text.partition("=")
    v = {"name": name, "latency": 0.0, "ranks": ranks, "threads": threads, "sets": [], "parode": None, "same": "all"}
    for item in filter(None, spec.split(",")):
        key, _, value = item.partition("=")
        if key in ("parode", "same"):
            v[key] = value
        elif key in ("latency", "ranks", "threads"):
            v[key] = float(value) if key == "latency" else int(value)
        else:
            v["sets"].append(item)
    return v


def later_ms(r, stage):
    """A stage's ms a step over the steps after the first, on the slowest rank."""
    total = r["stage_ranks"].get(stage, {}).get("max", r["stages"].get(stage, 0.0))
    first = (r.get("first_step") or {}).get("stages", {}).get(stage, 0.0)
    return 1e3 * (total - first) / max(r["steps"] - 1, 1)


def run(args, v):
    with tempfile.NamedTemporaryFile(suffix=".json") as f:
        cmd = [v["parode"] or args.parode, "run", args.scene, "--set", f"catoms.count={args.catoms}", "--steps", str(args.steps),
               "--threads", str(v["threads"]), "-q", "--report", f.name]
        for s in v["sets"]:
            cmd += ["--set", s]
        env = dict(os.environ, PARODE_INJECT_LATENCY_US=f"{v['latency']:g}", OMP_WAIT_POLICY="passive",
                   OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
        if v["ranks"] > 0:
            cmd = [args.mpiexec, "-n", str(v["ranks"]), "--oversubscribe", "-x", "PARODE_INJECT_LATENCY_US",
                   "-x", "OMP_WAIT_POLICY"] + cmd
        subprocess.run(cmd, check=True, env=env, cwd=ROOT)
        r = json.load(open(f.name))
    steps, first = r["steps"], (r.get("first_step") or {}).get("wall_s", 0.0)
    par = r.get("parallel") or {}
    colours = par.get("colours", [])
    row = {"variant": v["name"], "ranks": r["ranks"], "threads": r["threads"], "latency_us": v["latency"],
           "ms_later": 1e3 * (r["steps_wall_s"] - first) / (steps - 1), "ms_per_step": r["ms_per_step"],
           "solve_ms": 1e3 * r["stages"]["solve"] / steps, "hash": r["state_hash"],
           "collide_ms": 1e3 * (r["stage_ranks"]["collide"]["max"] - (r.get("first_step") or {}).get("stages", {}).get("collide", 0.0))
           / max(steps - 1, 1),
           "migrate_ms": later_ms(r, "migrate"), "exchange_ms": later_ms(r, "exchange"),
           "colour_imbalance": par.get("colour_imbalance", 1.0),
           "wait_ms_max": 1e3 * par.get("wait_seconds", {}).get("max", 0.0) / steps,
           "wait_ms_avg": 1e3 * par.get("wait_seconds", {}).get("avg", 0.0) / steps,
           "exchange_bytes_per_step": sum(par.get("colour_bytes", [0])) / steps,
           "edge_cut": par.get("edge_cut") if par.get("edge_cut") is not None else float("nan"), "partition_colour_imbalance": par.get("partition_colour_imbalance", 1.0),
           "ghost_fraction": par.get("ghost_fraction", 0.0),
           "rss_mb_max": r["memory"]["peak_rss_bytes"]["max"] / 2**20}
    for c, col in enumerate(colours):
        row[f"c{c}_compute_ms"] = 1e3 * col["compute_s"]["max"] / steps
        row[f"c{c}_compute_avg_ms"] = 1e3 * col["compute_s"]["avg"] / steps
        row[f"c{c}_wait_ms"] = 1e3 * col["wait_s"]["max"] / steps
    return row


def hash_lines(med, groups):
    """One line per computation: its hash, or its variants' hashes when they
    differ; and whether every computation gave one hash."""
    lines, same = [], True
    for label, members in groups.items():
        hashes = sorted({h for n in members for h in med[n]["hashes"]})
        who = "" if len(groups) == 1 else f"{label} ({', '.join(members)}): "
        if len(hashes) == 1:
            lines.append(f"state hash: {who}{hashes[0]} (one for every variant)")
        else:
            same = False
            each = "; ".join(f"{n} {', '.join(med[n]['hashes'])}" for n in members)
            lines.append(f"state hash: {who}VARIANTS DIFFER: {each}")
    return lines, same


def summary(rows, names, groups):
    keys = ["ms_later", "ms_per_step", "solve_ms", "collide_ms", "migrate_ms", "exchange_ms", "colour_imbalance", "wait_ms_max", "wait_ms_avg",
            "exchange_bytes_per_step", "edge_cut", "partition_colour_imbalance", "rss_mb_max"]
    med = {}
    for n in names:
        mine = [r for r in rows if r["variant"] == n]
        med[n] = {k: statistics.median(float(r[k]) for r in mine) for k in keys}
        med[n]["runs"] = [round(float(r["ms_later"]), 2) for r in mine]
        med[n]["hashes"] = sorted({r["hash"] for r in mine})
    base = med[names[0]]["ms_later"]
    lines = ["| variant | ms/step (later steps, median) | x first | solve | collide (later) | migrate (later) | "
             "exchange (later) | colour imbalance | wait max | bytes/step | edge cut | partition colour imb. | MB/rank | runs |",
             "|" + "---|" * 14]
    for n in names:
        m = med[n]
        lines.append(f"| {n} | {m['ms_later']:.2f} | {m['ms_later'] / base:.3f} | {m['solve_ms']:.2f} | {m['collide_ms']:.2f} | "
                     f"{m['migrate_ms']:.2f} | {m['exchange_ms']:.2f} | "
                     f"{m['colour_imbalance']:.3f} | {m['wait_ms_max']:.2f} | {m['exchange_bytes_per_step']:.0f} | "
                     f"{m['edge_cut']:.0f} | {m['partition_colour_imbalance']:.3f} | {m['rss_mb_max']:.0f} | "
                     f"{m['runs']} |")
    hl, same = hash_lines(med, groups)
    lines.append("")
    lines += hl
    return "\n".join(lines) + "\n", same


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("variants", nargs="+", metavar="NAME=SPEC")
    ap.add_argument("--parode", default=os.path.join(ROOT, "build/ci/parode"))
    ap.add_argument("--mpiexec", default="mpiexec")
    ap.add_argument("--scene", default="jobs/scenes/tennis.toml")
    ap.add_argument("--catoms", type=int, default=20000)
    ap.add_argument("--steps", type=int, default=40)
    ap.add_argument("--ranks", type=int, default=2)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--out", default=os.path.join(ROOT, "results/variants"))
    a = ap.parse_args()
    variants = [parse_variant(t, a.ranks, a.threads) for t in a.variants]
    names = [v["name"] for v in variants]
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for turn in range(a.repeats):
        k = turn % len(variants)
        for v in variants[k:] + variants[:k]:
            rows.append(run(a, v))
            print(f"turn {turn + 1}: {v['name']}: {rows[-1]['ms_later']:.2f} ms/step", flush=True)
    fields = sorted({k for r in rows for k in r}, key=lambda k: (k not in rows[0], k))
    with open(os.path.join(a.out, "variants_runs.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    groups = {}
    for v in variants:
        groups.setdefault(v["same"], []).append(v["name"])
    text, same = summary(rows, names, groups)
    layouts = ", ".join(f"{v['name']} {v['ranks'] or 'one process'} x {v['threads']}" for v in variants)
    header = (f"{a.catoms} catoms, {a.steps} steps, {a.repeats} turns; ranks x threads: {layouts}\n\n")
    with open(os.path.join(a.out, "variants.md"), "w") as f:
        f.write(header + text)
    print(header + text)
    sys.exit(0 if same else 1)


if __name__ == "__main__":
    main()
