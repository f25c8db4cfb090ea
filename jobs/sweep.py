#!/usr/bin/env python3
"""Speed-against-error sweep of the classic scenes (tennis, magnetic-tennis, buggy).

For each scene: a reference run (high accuracy: dt/4 and 100 QuickStep
iterations, or dWorldStep at dt/4 for the buggy; one thread) writes its
trajectory; then every configuration runs for the same simulated time with
`parode run --reference`, which puts the error metrics into its report under
`error`. Configurations vary one setting at a time around the scene's defaults
(dt, QuickStep iterations, SOR w, stepper, ERP, CFM, threads with the grid
backend, the parallel contact solver), plus a few combinations along the
expected front. Each configuration runs --repeats times, the repeats
interleaved (run 1 of every configuration, then run 2, ...) so that a change
in the machine's load spreads over all of them: the analysis draws the spread
of the wall times. The reference is also run with --seeds other seeds and
compared with the first: the error between equally good runs, the noise floor
of the error (large on the chaotic tennis collapse).

Output: OUT/machine.json (host, CPU, cores, date, commit, parode binary) and
OUT/<scene>/<config>.run<i>.json, reference.json, reference-seed<k>.json:
compact JSON run reports, each with a `sweep` block (configuration, run, the
settings and the key it was made with). Trajectories go to TRAJ (not meant
to be committed). A report is reused only if its key matches: the key hashes
the scene file's content, the duration, every --set and option, the
reference's key and the parode binary, so a changed scene, duration, dt,
iteration count or build reruns the reference and everything compared with it.
Trade-off: one-at-a-time variation (about 20 configurations per scene)
instead of a full grid (hundreds), so that repeats fit a small machine;
analysis/speed_error.py draws the front from whatever reports exist.
Costs need an idle machine: before each run the cores busy with other work
are measured for 0.5 s (/proc/stat) and a run started above --max-load is
marked `disturbed` in its sweep block; the analysis times only the runs that
are not (and says so where every run of a configuration was disturbed).

Usage: python3 jobs/sweep.py [--out results/sweep] [--traj results/sweep-traj]
                             [--scenes tennis,buggy] [--count 1000] [--duration S]
                             [--repeats 3] [--seeds 3] [--parode build/ci/parode]
Run it niced on a shared machine: nice -n 10 python3 jobs/sweep.py ...
"""
import argparse
import datetime
import hashlib
import json
import os
import platform
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# scene -> (file, duration s, dt, reference overrides)
SCENES = {
    "tennis": ("jobs/scenes/tennis.toml", 5.0, 0.005, ["solver.iterations=100"]),
    "magnetic-tennis": ("jobs/scenes/magnetic-tennis.toml", 5.0, 0.005, ["solver.iterations=100"]),
    "buggy": ("jobs/scenes/buggy.toml", 42.0, 0.01, ["solver.stepper=world"]),
}


# The reference runs ODE's own path whatever the scene's [run] table chooses.
REFERENCE = ["--solver", "ode", "--collide", "ode-hash"]
# Configurations that vary a QuickStep setting run ODE's stepper.
QUICK = ["@--solver", "@ode"]


def configs(scene, dt):
    """Configuration name -> [--set value, or @option]."""
    c = {"default": []}
    for f in (0.5, 2, 4):
        c[f"dt{dt * f:g}"] = [f"scene.dt={dt * f:g}"]
    if scene != "buggy":
        for it in (5, 10, 40, 80):
            c[f"it{it}"] = [f"solver.iterations={it}"]
        for w in (1.0, 1.6):
            c[f"w{w:g}"] = QUICK + [f"solver.sor_w={w:g}"]
        c[f"dt{dt * 2:g}-it40"] = [f"scene.dt={dt * 2:g}", "solver.iterations=40"]
        c[f"dt{dt * 0.5:g}-it10"] = [f"scene.dt={dt * 0.5:g}", "solver.iterations=10"]
        c["grid-2threads"] = ["@--collide", "@grid", "@--threads", "@2"]
        # The project contact solver (--solver parallel), alone and with fewer iterations.
        par = ["@--collide", "@grid", "@--solver", "@parallel"]
        c["parallel-1thread"] = par + ["@--threads", "@1"]
        c["parallel-2threads"] = par + ["@--threads", "@2"]
        for it in (5, 10):
            c[f"parallel-it{it}"] = par + ["@--threads", "@2", f"solver.iterations={it}"]
    else:
        c["quick-it20"] = QUICK + ["solver.stepper=quick", "solver.iterations=20"]
        c["quick-it50"] = QUICK + ["solver.stepper=quick", "solver.iterations=50"]
        c["quick-it100"] = QUICK + ["solver.stepper=quick", "solver.iterations=100"]
    for erp in (0.1, 0.5):
        c[f"erp{erp:g}"] = [f"solver.erp={erp:g}"]
    for cfm in (1e-6, 1e-4):
        c[f"cfm{cfm:g}"] = [f"solver.cfm={cfm:g}"]
    return c


def file_hash(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def key_of(**parts):
    return hashlib.sha256(json.dumps(parts, sort_keys=True).encode()).hexdigest()[:16]


def git_commit():
    try:
        head = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
        dirty = subprocess.run(["git", "-C", ROOT, "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True)
        return head.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")
    except OSError:
        return "unknown"


def machine(parode):
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((line.split(":", 1)[1].strip() for line in f if line.startswith("model name")), cpu)
    except OSError:
        pass
    return {"host": platform.node(), "cpu": cpu, "cores": os.cpu_count(),
            "date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d"),
            "commit": git_commit(), "parode_sha256": file_hash(parode)[:16]}


def needed(args, report, key):
    """Whether to run: not done in this invocation, and no report with this key (or --force)."""
    if key in args.done:
        return False
    if args.force:
        return True
    try:
        with open(report) as f:
            return json.load(f).get("sweep", {}).get("key") != key
    except (OSError, ValueError):
        return True


def busy_cores(seconds=0.5):
    """Cores busy with other work while this script waits (from /proc/stat)."""
    def sample():
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
        return sum(v) - v[3] - v[4], sum(v)  # busy (all but idle and iowait), total
    b0, t0 = sample()
    time.sleep(seconds)
    b1, t1 = sample()
    return (b1 - b0) / max(t1 - t0, 1) * os.cpu_count()


def run(args, scene_file, duration, sets, options, report, sweep):
    """One parode run; writes its report (or the failure) compactly with the sweep block."""
    args.done.add(sweep["key"])
    load = busy_cores()
    timeout = args.timeout
    cmd = [args.parode, "run", scene_file, "--duration", f"{duration:g}", "-q", "--report", rel(report)]
    for s in sets:
        cmd += ["--set", s]
    cmd += options
    print(" ".join(cmd[2:]), flush=True)
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, cwd=ROOT)
        r = json.load(open(report)) if p.returncode in (0, 5) else {"failed": p.stderr.strip(), "rc": p.returncode}
    except subprocess.TimeoutExpired:
        r = {"failed": f"timed out after {timeout} s"}
    r["sweep"] = dict(sweep, sets=sets, options=options, host=args.machine["host"], date=args.machine["date"],
                      busy_cores_before=round(load, 3), disturbed=load > args.max_load)
    with open(report, "w") as f:
        json.dump(r, f, separators=(",", ":"))


def rel(path):
    """A path as parode is given it (it runs in the repository root): relative when inside it."""
    path = os.path.abspath(path)
    return os.path.relpath(path, ROOT) if path.startswith(ROOT + os.sep) else path


def split(sets):
    """[--set values], [options] of a configuration; one thread unless it says otherwise."""
    options = [s[1:] for s in sets if s.startswith("@")]
    plain = [s for s in sets if not s.startswith("@")]
    return plain, options + ([] if "--threads" in options else ["--threads", "1"])


def references(args, name, base):
    """Runs (or reuses) the reference and the other seeds' references; returns the reference trajectory."""
    scene_file, _, dt, ref_sets = SCENES[name]
    out, traj = os.path.join(args.out, name), os.path.join(args.traj, name)
    sets = base["size"] + [f"scene.dt={dt / 4:g}"] + ref_sets
    ref_key = key_of(base=base["key"], sets=sets)
    ref_traj = rel(os.path.join(traj, f"reference-{ref_key}.traj"))
    report = os.path.join(out, "reference.json")
    if needed(args, report, ref_key) or (ref_key not in args.done and not os.path.exists(os.path.join(ROOT, ref_traj))):
        run(args, scene_file, base["duration"], sets, REFERENCE + ["--threads", "1", "--trajectory", ref_traj], report,
            {"role": "reference", "key": ref_key, "config": "reference", "run": 1})
    if not os.path.exists(os.path.join(ROOT, ref_traj)):
        sys.exit(f"sweep: the {name} reference failed, see {report}")
    for seed in range(2, args.seeds + 1):
        report = os.path.join(out, f"reference-seed{seed}.json")
        seed_sets = sets + [f"scene.seed={seed}"]
        key = key_of(base=base["key"], sets=seed_sets, reference=ref_key)
        if needed(args, report, key):
            run(args, scene_file, base["duration"], seed_sets, REFERENCE + ["--threads", "1", "--reference", ref_traj],
                report,
                {"role": "noise-floor", "key": key, "reference_key": ref_key, "config": f"reference-seed{seed}",
                 "run": 1})
    return ref_traj, ref_key


def sweep_scene(args, name, run_index):
    scene_file, duration, dt, _ = SCENES[name]
    duration = args.duration or duration
    os.makedirs(os.path.join(args.out, name), exist_ok=True)
    os.makedirs(os.path.join(args.traj, name), exist_ok=True)
    size = [] if name == "buggy" else [f"catoms.count={args.count}"]
    base = {"size": size, "duration": duration,
            "key": key_of(scene=file_hash(os.path.join(ROOT, scene_file)), duration=duration, size=size,
                          parode=args.machine["parode_sha256"])}
    ref_traj, ref_key = references(args, name, base)
    for cname, cfg in configs(name, dt).items():
        sets, options = split(cfg)
        sets = size + sets
        key = key_of(base=base["key"], sets=sets, options=options, reference=ref_key, run=run_index)
        report = os.path.join(args.out, name, f"{cname}.run{run_index}.json")
        if needed(args, report, key):
            run(args, scene_file, duration, sets, options + ["--reference", ref_traj], report,
                {"role": "config", "key": key, "reference_key": ref_key, "config": cname, "run": run_index})


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "results", "sweep"), help="reports (default results/sweep)")
    ap.add_argument("--traj", default=os.path.join(ROOT, "results", "sweep-traj"),
                    help="reference trajectories (default results/sweep-traj)")
    ap.add_argument("--scenes", default="tennis,magnetic-tennis,buggy")
    ap.add_argument("--count", type=int, default=1000, help="catoms in tennis and magnetic-tennis")
    ap.add_argument("--duration", type=float, default=0, help="simulated seconds (default: per scene)")
    ap.add_argument("--repeats", type=int, default=3, help="runs of each configuration (wall-time spread)")
    ap.add_argument("--seeds", type=int, default=3, help="reference seeds (error noise floor); 1 = none")
    ap.add_argument("--parode", default=os.path.join(ROOT, "build", "ci", "parode"))
    ap.add_argument("--timeout", type=int, default=900)
    ap.add_argument("--max-load", type=float, default=0.3,
                    help="cores busy with other work before a run that mark it disturbed (default 0.3)")
    ap.add_argument("--force", action="store_true", help="rerun even where a report with the same key exists")
    args = ap.parse_args()
    scenes = args.scenes.split(",")
    for name in scenes:
        if name not in SCENES:
            sys.exit(f"sweep: unknown scene '{name}' (expected one of {', '.join(SCENES)})")
    args.parode = os.path.abspath(args.parode)
    if not os.access(args.parode, os.X_OK):
        sys.exit(f"sweep: no parode binary at {args.parode} (build it: cmake --build --preset ci)")
    if args.repeats < 1 or args.seeds < 1:
        sys.exit("sweep: --repeats and --seeds must be at least 1")
    args.machine = machine(args.parode)
    args.done = set()
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "machine.json"), "w") as f:
        json.dump(args.machine, f, indent=1)
    for i in range(1, args.repeats + 1):
        for name in scenes:
            sweep_scene(args, name, i)


if __name__ == "__main__":
    main()
