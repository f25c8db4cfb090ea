"""Before against after, interleaved: the per-step milliseconds of the solve's
build and integrate, the sweeps, the forces and the observation (every
`--observe-every` steps), and the whole step, over the steps after the
first; medians of `--turns` turns, every run's value beside. Usage
(repository root):
  python3 bench.py --before PATH --scene jobs/scenes/tennis.toml --catoms 200000 --threads 1 --steps 10 \
      --observe-every 1 --turns 5"""
import argparse
import json
import statistics
import subprocess
import tempfile

ap = argparse.ArgumentParser()
ap.add_argument("--before", required=True)
ap.add_argument("--after", default="build/ci/parode")
ap.add_argument("--scene", default="jobs/scenes/tennis.toml")
ap.add_argument("--catoms", type=int, default=200000)
ap.add_argument("--threads", type=int, default=1)
ap.add_argument("--steps", type=int, default=10)
ap.add_argument("--observe-every", type=int, default=1)
ap.add_argument("--turns", type=int, default=5)
a = ap.parse_args()
builds = {"before": a.before, "after": a.after}
runs = {k: [] for k in builds}
hashes = set()
for turn in range(a.turns):
    for name, parode in builds.items():
        with tempfile.NamedTemporaryFile(suffix=".json") as f:
            subprocess.run([parode, "run", a.scene, "--set", f"catoms.count={a.catoms}", "--set",
                            f"scene.observe_every={a.observe_every}", "--steps", str(a.steps), "--threads",
                            str(a.threads), "-q", "--report", f.name], check=True)
            j = json.load(open(f.name))
        first, later = j["first_step"], a.steps - 1
        solve = {k: (v - first["substages"]["solve"].get(k, 0)) / later * 1e3 for k, v in j["substages"]["solve"].items()}
        stage = {k: (v - first["stages"].get(k, 0)) / later * 1e3 for k, v in j["stages"].items()}
        runs[name].append({"build": solve["build"], "integrate": solve["integrate"], "sweeps": solve["sweeps"],
                           "forces": stage["forces"], "observe": stage["observe"],
                           "step": (j["steps_wall_s"] - first["wall_s"]) / later * 1e3})
        hashes.add(j["state_hash"])
print(f"{a.scene}, {a.catoms} catoms, {a.threads} thread(s), {a.steps} steps, observe every {a.observe_every}, "
      f"{a.turns} turns; state hash {', '.join(sorted(hashes))}")
print("| ms a step | before | after | after / before | before, every turn | after, every turn |")
print("|---|---|---|---|---|---|")
for k in ("build", "integrate", "sweeps", "forces", "observe", "step"):
    b = statistics.median(r[k] for r in runs["before"])
    x = statistics.median(r[k] for r in runs["after"])
    ratio = f"{x / b:.3f}" if b > 0 else "-"
    print(f"| {k} | {b:.2f} | {x:.2f} | {ratio} | {[round(r[k], 1) for r in runs['before']]} | "
          f"{[round(r[k], 1) for r in runs['after']]} |")
