#!/usr/bin/env python3
"""The contact solver on a shared machine: tennis (grid collision, parallel
solver) on 2 threads while another process keeps one core busy (a shell loop
this script starts and stops), against 1 thread without that process. Runs
alternate and repeat; prints the solve stage's ms per step of each, the
median ratio (target: at most 1.3), and the same for a baseline build if
given. Writes analysis/results/shared_cores.csv.
Trade-off: the busy loop competes with whatever else runs on the machine, so
the one-thread figure is only as idle as the machine is: the script prints the
load average before each run.

Usage: python3 jobs/shared_cores.py [--parode build/ci/parode] [--baseline OLD]
                                    [--catoms 100000] [--steps 20] [--repeats 3]
"""
import argparse
import json
import os
import statistics
import subprocess
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def solve_ms(binary, catoms, threads, steps):
    with tempfile.NamedTemporaryFile(suffix=".json") as f:
        subprocess.run([binary, "run", os.path.join(ROOT, "jobs/scenes/tennis.toml"), "--set",
                        f"catoms.count={catoms}", "--collide", "grid", "--solver", "parallel", "--threads",
                        str(threads), "--steps", str(steps), "-q", "--report", f.name], check=True)
        r = json.load(open(f.name))
    return 1e3 * r["stages"]["solve"] / r["steps"], 1e3 * r.get("steps_wall_s", r["wall_s"]) / r["steps"]


def busy_core():
    hog = subprocess.Popen(["sh", "-c", "while :; do :; done"])
    time.sleep(0.5)
    return hog


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parode", default=os.path.join(ROOT, "build/ci/parode"))
    ap.add_argument("--baseline")
    ap.add_argument("--catoms", type=int, default=100000)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--csv", default=os.path.join(ROOT, "analysis/results/shared_cores.csv"))
    a = ap.parse_args()
    builds = [("new", a.parode)] + ([("baseline", a.baseline)] if a.baseline else [])
    rows = []
    for rep in range(a.repeats):
        for name, binary in builds:
            load = os.getloadavg()[0]
            alone, alone_wall = solve_ms(binary, a.catoms, 1, a.steps)
            hog = busy_core()
            try:
                shared, shared_wall = solve_ms(binary, a.catoms, 2, a.steps)
            finally:
                hog.terminate()
                hog.wait()
            rows.append({"build": name, "repeat": rep, "catoms": a.catoms, "load_before": load,
                         "solve_ms_1t": alone, "solve_ms_2t_shared": shared, "ratio": shared / alone,
                         "step_ms_1t": alone_wall, "step_ms_2t_shared": shared_wall})
            print(f"{name:8} 1 thread {alone:8.1f} ms/step solve; 2 threads, one core busy {shared:8.1f}: "
                  f"x{shared / alone:.2f} (load {load:.2f})", flush=True)
    for name, _ in builds:
        r = [x["ratio"] for x in rows if x["build"] == name]
        print(f"{name}: median ratio {statistics.median(r):.2f} (2 threads on a shared core / 1 thread)")
    os.makedirs(os.path.dirname(a.csv), exist_ok=True)
    with open(a.csv, "w") as f:
        f.write(",".join(rows[0]) + "\n")
        for r in rows:
            f.write(",".join(f"{v:.6g}" if isinstance(v, float) else str(v) for v in r.values()) + "\n")


if __name__ == "__main__":
    main()
