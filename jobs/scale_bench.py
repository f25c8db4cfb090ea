#!/usr/bin/env python3
"""Scaling benchmark: tennis at 8,000 / 64,000 / 100,000 / 1,000,000 catoms,
grid collision and the parallel solver, the first STEPS steps, on 1 and 2
threads, this build side by side with a baseline build (the same command line
on an older parode), runs interleaved (new, baseline; 1 thread, 2 threads;
the order rotated from one repeat to the next, so that no variant always
follows another's freed memory) and repeated, medians kept.

Per run it records from the JSON run report: ms per step, the stages collide,
solve and observe and their substages (build, warm_start, sweeps, integrate;
refresh, broadphase, narrowphase, merge) in ms per step, the same for the
first step alone and for the later steps (the first pays one-time costs: the
first touch of every per-step buffer, which on a virtual machine that hands
freed memory back to its host runs at a fraction of memory speed), peak memory per catom,
contacts per step and the state hash; and from the operating system the CPU
seconds the run used (wall time on a shared machine counts other people's
work; CPU time does not) and the load average when it started.

Before and after the runs it measures the machine (`parode memory`: triad
bandwidth on 1 and 2 threads, first-touch rate of fresh memory) into
scale_machine.json: on a shared virtual machine these move from day to day and
decide how the figures read.

Writes analysis/results/scale_runs.csv (every run) and scale.csv (medians per
size, threads and build, with ns per catom per core, the ratio against the
baseline and the speed-up from 1 to 2 threads), and prints the table. Checks
that every run of one size gives one state hash per build (threads never
change a result).
Trade-off: separate processes per run (peak memory is per process, and a
baseline build cannot be linked in), so each run pays its setup; only the
steps are timed.

Usage: python3 jobs/scale_bench.py --baseline /tmp/perf-baseline/build/omp/parode
           [--parode build/ci/parode] [--collide grid] [--baseline-collide grid] [--sizes 8000,64000,100000,1000000]
           [--threads 1,2] [--steps 5] [--repeats 3] [--out analysis/results]
"""
import argparse
import csv
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
STAGES = ["collide", "solve", "observe"]
SUBSTAGES = {"solve": ["build", "warm_start", "sweeps", "integrate"],
             "collide": ["refresh", "broadphase", "narrowphase", "merge"]}


def child_cpu():
    u = resource.getrusage(resource.RUSAGE_CHILDREN)
    return u.ru_utime + u.ru_stime


def run(binary, scene, n, threads, steps, collide="grid"):
    with tempfile.NamedTemporaryFile(suffix=".json") as f:
        load = os.getloadavg()[0]
        cpu0, t0 = child_cpu(), time.time()
        subprocess.run([binary, "run", scene, "--set", f"catoms.count={n}", "--collide", collide, "--solver",
                        "parallel", "--threads", str(threads), "--steps", str(steps), "-q", "--report", f.name],
                       check=True)
        cpu, elapsed = child_cpu() - cpu0, time.time() - t0
        r = json.load(open(f.name))
    row = {"catoms": n, "threads": threads, "ms_per_step": r["ms_per_step"],
           "bytes_per_catom": r["memory"]["bytes_per_body"], "contacts_per_step": r["contacts_per_step"],
           "state_hash": r["state_hash"], "process_cpu_s": cpu, "process_s": elapsed, "load": load}
    for s in STAGES:
        row[f"{s}_ms"] = 1e3 * r["stages"][s] / r["steps"]
    for s, subs in SUBSTAGES.items():
        for sub in subs:
            row[f"{s}.{sub}_ms"] = 1e3 * r.get("substages", {}).get(s, {}).get(sub, float("nan")) / r["steps"]
    row.update(later_steps(r))
    return row


def later_steps(r):
    """ms per step of the first step and of the later ones (reports that have
    "first_step" and more than one step; others give nothing)."""
    first, steps = r.get("first_step"), r["steps"]
    if not first or steps < 2:
        return {}
    wall = r.get("steps_wall_s", r["wall_s"])
    row = {"first_ms": 1e3 * first["wall_s"], "later_ms_per_step": 1e3 * (wall - first["wall_s"]) / (steps - 1)}
    for s in STAGES:
        row[f"first.{s}_ms"] = 1e3 * first["stages"][s]
        row[f"later.{s}_ms"] = 1e3 * (r["stages"][s] - first["stages"][s]) / (steps - 1)
    for s, subs in SUBSTAGES.items():
        for sub in subs:
            total = r.get("substages", {}).get(s, {}).get(sub)
            if total is not None:
                row[f"later.{s}.{sub}_ms"] = 1e3 * (total - first["substages"][s][sub]) / (steps - 1)
    return row


def probe_machine(binary, threads):
    """`parode memory` on up to `threads` threads, printed and returned."""
    with tempfile.NamedTemporaryFile(suffix=".json") as f:
        subprocess.run([binary, "memory", "--threads", str(threads), "--json", f.name], check=True)
        return json.load(open(f.name))


def summarise(rows, sizes, threads):
    out = []
    med = lambda xs, k: statistics.median(x[k] for x in xs)
    for n in sizes:
        for t in threads:
            for build in ("new", "baseline"):
                xs = [r for r in rows if r["catoms"] == n and r["threads"] == t and r["build"] == build]
                if not xs:
                    continue
                keys = [k for k in xs[0] if k.endswith("_ms") or k in (
                    "ms_per_step", "later_ms_per_step", "bytes_per_catom", "process_cpu_s", "contacts_per_step")]
                s = {"catoms": n, "threads": t, "build": build, "runs": len(xs)}
                s.update({k: med(xs, k) for k in keys})
                s["step_ns_per_catom_core"] = 1e6 * s["ms_per_step"] * t / n
                s["collide_ns_per_catom_core"] = 1e6 * s["collide_ms"] * t / n
                if "later.collide_ms" in s:
                    s["later_collide_ns_per_catom_core"] = 1e6 * s["later.collide_ms"] * t / n
                s["hashes"] = " ".join(sorted({x["state_hash"] for x in xs}))
                out.append(s)
    for s in out:  # ratios: against the baseline, and 1 -> 2 threads
        base = next((b for b in out if b["catoms"] == s["catoms"] and b["threads"] == s["threads"]
                     and b["build"] == "baseline"), None)
        one = next((b for b in out if b["catoms"] == s["catoms"] and b["threads"] == 1 and b["build"] == s["build"]), None)
        for k in ["ms_per_step"] + [f"{x}_ms" for x in STAGES] + ["later_ms_per_step"] + [f"later.{x}_ms" for x in STAGES]:
            if k not in s:
                continue
            s[f"{k}_baseline_over_new"] = base[k] / s[k] if base and k in base and s["build"] == "new" and s[k] > 0 else ""
            s[f"{k}_speedup_vs_1t"] = one[k] / s[k] if one and s[k] > 0 else ""
        s["memory_baseline_over_new"] = base["bytes_per_catom"] / s["bytes_per_catom"] if base and s["build"] == "new" else ""
    return out


def write_csv(path, rows):
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})


def fmt(v, spec):
    return format(v, spec) if isinstance(v, float) else str(v)


def print_table(summary):
    print(f"{'catoms':>8} {'thr':>3} {'build':>8} {'ms/step':>9} {'collide':>8} {'solve':>8} {'observe':>8} "
          f"{'ns/cat/core':>11} {'coll ns':>8} {'B/catom':>8} {'x base':>7} {'x 1t':>6}")
    for s in summary:
        print(f"{s['catoms']:>8} {s['threads']:>3} {s['build']:>8} {s['ms_per_step']:>9.1f} {s['collide_ms']:>8.1f} "
              f"{s['solve_ms']:>8.1f} {s['observe_ms']:>8.1f} {s['step_ns_per_catom_core']:>11.0f} "
              f"{s['collide_ns_per_catom_core']:>8.0f} {s['bytes_per_catom']:>8.0f} "
              f"{fmt(s['ms_per_step_baseline_over_new'], '7.2f'):>7} {fmt(s['ms_per_step_speedup_vs_1t'], '6.2f'):>6}")
        if s["build"] == "new":
            for st, subs in SUBSTAGES.items():
                print(" " * 21 + f"{st}: " + ", ".join(f"{x} {s[f'{st}.{x}_ms']:.1f}" for x in subs))
        if "later_ms_per_step" in s:
            print(" " * 21 + f"first step {s['first_ms']:.1f} ms (collide {s['first.collide_ms']:.1f}); later steps "
                  f"{s['later_ms_per_step']:.1f} ms/step: collide {s['later.collide_ms']:.1f}, solve "
                  f"{s['later.solve_ms']:.1f}, observe {s['later.observe_ms']:.1f}; collide "
                  f"{s['later_collide_ns_per_catom_core']:.0f} ns/catom/core; x 1t "
                  f"{fmt(s['later_ms_per_step_speedup_vs_1t'], '.2f')}")


def read_runs(path):
    """scale_runs.csv back into rows (numbers as numbers, missing fields dropped)."""
    rows = []
    with open(path) as f:
        for r in csv.DictReader(f):
            row = {}
            for k, v in r.items():
                if v == "":
                    continue
                try:
                    row[k] = int(v) if k in ("catoms", "threads", "repeat") else float(v)
                except ValueError:
                    row[k] = v
            rows.append(row)
    return rows


def write_summary(rows, out, sizes, threads):
    """scale.csv from the runs, the table and the hash check printed."""
    summary = summarise(rows, sizes, threads)
    write_csv(os.path.join(out, "scale.csv"), summary)
    print_table(summary)
    print_hashes(rows)


def summarise_runs(out):
    path = os.path.join(out, "scale_runs.csv")
    if not os.path.isfile(path):
        print(f"scale_bench: {path}: no such file (--summarise-only reads the runs a previous call wrote there)",
              file=sys.stderr)
        sys.exit(2)
    rows = read_runs(path)
    write_summary(rows, out, sorted({r["catoms"] for r in rows}), sorted({r["threads"] for r in rows}))


def print_hashes(rows):
    """One state hash per size and build, whatever the thread count."""
    for n in sorted({r["catoms"] for r in rows}):
        for name in dict.fromkeys(r["build"] for r in rows):
            hashes = {r["state_hash"] for r in rows if r["catoms"] == n and r["build"] == name}
            print(f"{name} {n} catoms: state hash {'identical on every thread count' if len(hashes) == 1 else 'DIFFERS'}"
                  f" ({' '.join(sorted(hashes))})")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parode", default=os.path.join(ROOT, "build/ci/parode"))
    ap.add_argument("--baseline", help="an older parode to compare with (omitted: this build only)")
    ap.add_argument("--collide", default="grid", help="collision backend of this build's runs")
    ap.add_argument("--baseline-collide", default="grid",
                    help="collision backend of the baseline's runs (with --baseline build/ci/parode: two "
                         "backends of one build side by side, e.g. grid against grid-nolist)")
    ap.add_argument("--scene", default=os.path.join(ROOT, "jobs/scenes/tennis.toml"))
    ap.add_argument("--sizes", default="8000,64000,100000,1000000")
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--steps", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--out", default=os.path.join(ROOT, "analysis/results"))
    ap.add_argument("--summarise-only", action="store_true",
                    help="no runs: summarise OUT/scale_runs.csv again (after changing the summary)")
    a = ap.parse_args()
    if a.summarise_only:
        return summarise_runs(a.out)
    sizes = [int(x) for x in a.sizes.split(",")]
    threads = [int(x) for x in a.threads.split(",")]
    builds = [("new", a.parode, a.collide)] + ([("baseline", a.baseline, a.baseline_collide)] if a.baseline else [])
    os.makedirs(a.out, exist_ok=True)
    machine = {"before": probe_machine(a.parode, max(threads))}
    rows = []
    combos = [(t, name, binary, collide) for t in threads for name, binary, collide in builds]
    for n in sizes:
        for rep in range(a.repeats):
            for t, name, binary, collide in combos[rep % len(combos):] + combos[:rep % len(combos)]:
                r = run(binary, a.scene, n, t, a.steps, collide)
                r["build"], r["repeat"] = name, rep
                rows.append(r)
                print(f"  {name:8} {n:>8} catoms {t} thread(s): {r['ms_per_step']:.1f} ms/step "
                      f"(load {r['load']:.2f})", flush=True)
    machine["after"] = probe_machine(a.parode, max(threads))
    with open(os.path.join(a.out, "scale_machine.json"), "w") as f:
        json.dump(machine, f, indent=1)
    write_csv(os.path.join(a.out, "scale_runs.csv"), rows)
    write_summary(rows, a.out, sizes, threads)


if __name__ == "__main__":
    main()
