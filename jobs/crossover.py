#!/usr/bin/env python3
"""Where threads start to pay: the collide and solve stages of tennis at small
sizes, on one thread and on two threads forced on at every size
(PARODE_MIN_PARALLEL=0), runs interleaved and repeated, medians kept. Prints
per size the ms per step of each stage on 1 and 2 threads and their ratio, and
writes the table as CSV. The crossover of a stage is the smallest size from
which two threads are faster; omp/ keeps a stage on one thread below it
(grid_collide.cpp kCollideCrossover in geoms, parallel_solver.hpp
kSweepCrossover in contacts, loop_runner.hpp kLoopCrossover in items).
Trade-off: whole runs of the real scene rather than isolated kernels, so the
figures include every parallel region a step opens; a shared machine makes
them noisy, hence the repeats (check `uptime` first).

Usage: python3 jobs/crossover.py [--parode build/ci/parode] [--repeats 5]
                                 [--csv analysis/results/crossover.csv]
"""
import argparse
import json
import os
import statistics
import subprocess
import tempfile

SIZES = [8, 27, 64, 125, 343, 729, 1000, 2197, 4096, 8000]
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(parode, n, threads, forced, steps):
    env = dict(os.environ, OMP_WAIT_POLICY=os.environ.get("OMP_WAIT_POLICY", "passive"))
    if forced:
        env["PARODE_MIN_PARALLEL"] = "0"
    with tempfile.NamedTemporaryFile(suffix=".json") as f:
        subprocess.run([parode, "run", os.path.join(ROOT, "jobs/scenes/tennis.toml"), "--set", f"catoms.count={n}",
                        "--collide", "grid", "--solver", "parallel", "--threads", str(threads), "--steps",
                        str(steps), "-q", "--report", f.name], check=True, env=env)
        r = json.load(open(f.name))
    return {s: 1e3 * r["stages"][s] / r["steps"] for s in ("collide", "solve")} | {
        "contacts": r["contacts_per_step"]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parode", default=os.path.join(ROOT, "build/ci/parode"))
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--csv", default=os.path.join(ROOT, "analysis/results/crossover.csv"))
    a = ap.parse_args()
    rows = []
    print(f"{'catoms':>7} {'contacts':>9} {'collide 1t':>11} {'2t':>8} {'1t/2t':>6} {'solve 1t':>9} {'2t':>8} {'1t/2t':>6}")
    for n in SIZES:
        one, two = [], []
        for _ in range(a.repeats):  # interleaved: both see the same machine
            one.append(run(a.parode, n, 1, False, a.steps))
            two.append(run(a.parode, n, 2, True, a.steps))
        med = lambda xs, k: statistics.median(x[k] for x in xs)
        row = {"catoms": n, "contacts": med(one, "contacts")}
        for s in ("collide", "solve"):
            row[f"{s}_ms_1t"], row[f"{s}_ms_2t"] = med(one, s), med(two, s)
            row[f"{s}_speedup"] = row[f"{s}_ms_1t"] / row[f"{s}_ms_2t"] if row[f"{s}_ms_2t"] > 0 else 0
        rows.append(row)
        print(f"{n:>7} {row['contacts']:>9.0f} {row['collide_ms_1t']:>11.3f} {row['collide_ms_2t']:>8.3f} "
              f"{row['collide_speedup']:>6.2f} {row['solve_ms_1t']:>9.3f} {row['solve_ms_2t']:>8.3f} "
              f"{row['solve_speedup']:>6.2f}", flush=True)
    os.makedirs(os.path.dirname(a.csv), exist_ok=True)
    with open(a.csv, "w") as f:
        f.write(",".join(rows[0]) + "\n")
        for r in rows:
            f.write(",".join(f"{v:.6g}" if isinstance(v, float) else str(v) for v in r.values()) + "\n")
    print(f"wrote {a.csv}; load: {os.getloadavg()}")


if __name__ == "__main__":
    main()
