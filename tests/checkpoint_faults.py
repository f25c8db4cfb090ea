"""Checkpoints under SIGKILL, run by ctest (tests/CMakeLists.txt).

A run writes a checkpoint every step and is killed with SIGKILL (the whole
session: every MPI process at once, as a node failure or a wall-time kill)
after a random, seeded delay (half the time, a random moment after a
checkpoint's temporary file appeared: during the write). What it left is then restarted as a user
would: the checkpoint FILE and the kept FILE.prev must restart and reach the
uninterrupted run's state hash; a half-written FILE.tmp must either do the
same or be refused with exit 8 and the damage message. Anything else (FILE
missing once a checkpoint was complete, a crash, another exit code, another
hash) fails the test.
Usage: checkpoint_faults.py --parode BIN --source DIR [--mpiexec BIN --ranks N]
       [--kills K] [--seed S] [--catoms N] [--steps T]
Trade-off: whole processes and real kills (seconds a trial) rather than a
simulated crash inside the writer: the test sees the files a user would.
"""
import argparse
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_WAIT_POLICY="passive",
           OMPI_MCA_rmaps_base_oversubscribe="1", OMP_NUM_THREADS="1")


def parse():
    ap = argparse.ArgumentParser()
    ap.add_argument("--parode", required=True)
    ap.add_argument("--source", required=True)
    ap.add_argument("--mpiexec", default="")
    ap.add_argument("--ranks", type=int, default=0)
    ap.add_argument("--kills", type=int, default=10)
    ap.add_argument("--seed", type=int, default=39)
    ap.add_argument("--catoms", type=int, default=30000)
    ap.add_argument("--steps", type=int, default=30)
    return ap.parse_args()


class Runner:
    def __init__(self, a):
        self.a = a
        a.parode, a.source = os.path.abspath(a.parode), os.path.abspath(a.source)
        self.scene = [os.path.join(a.source, "jobs/scenes/tennis.toml"), "--set", f"catoms.count={a.catoms}", "-q"]
        self.launcher = [a.mpiexec, "-n", str(a.ranks), "--oversubscribe"] if a.ranks else []

    def command(self, args):
        return self.launcher + [self.a.parode, "run"] + self.scene + args

    def run(self, args, cwd):
        return subprocess.run(self.command(args), cwd=cwd, env=ENV, capture_output=True, text=True, timeout=600)

    def start(self, args, cwd):
        return subprocess.Popen(self.command(args), cwd=cwd, env=ENV, stdout=subprocess.DEVNULL,
                                stderr=subprocess.DEVNULL, start_new_session=True)


def kill_session(sid):
    """SIGKILL to every process of session `sid` (mpiexec and its ranks)."""
    for pid in os.listdir("/proc"):
        if not pid.isdigit():
            continue
        try:
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            if int(fields[3]) == sid:  # field 6 of stat: the session
                os.kill(int(pid), signal.SIGKILL)
        except (OSError, IndexError, ValueError):
            pass


def checkpoint_step(path):
    """The step in a checkpoint's header, or None when the header cannot be read."""
    try:
        with open(path, "rb") as f:
            f.readline()
            return int(json.loads(f.readline().decode())["step"])
    except (OSError, ValueError, KeyError, UnicodeDecodeError):
        return None


def restart(runner, path, steps, work, reference):
    """'exact', 'refused' or what went wrong, restarting from `path` up to `steps`."""
    k = checkpoint_step(path)
    r = runner.run(["--restart", path, "--steps", str(steps - k if k is not None else 1), "--report", "rest.json"],
                   work)
    if r.returncode == 8 and ("damaged checkpoint" in r.stderr or "not a parode checkpoint" in r.stderr):
        return "refused"
    if r.returncode != 0:
        return f"exit {r.returncode}: {r.stderr.strip()[-300:]}"
    with open(os.path.join(work, "rest.json")) as f:
        got = json.load(f)["state_hash"]
    return "exact" if k is not None and got == reference else f"ran on from step {k} to hash {got}, not {reference}"


def writing(work, full):
    """Whether a checkpoint is being written in `work`: its temporary file, or
    (a writer in place) a checkpoint shorter than half a complete one."""
    for name in ("c.ckpt.tmp", "c.ckpt"):
        try:
            if os.path.getsize(os.path.join(work, name)) < full // 2 or name == "c.ckpt.tmp":
                return True
        except OSError:
            pass
    return False


def trial(runner, a, rng, span, full, reference, base):
    """One kill; the outcomes of restarting from each file it left."""
    work = tempfile.mkdtemp(dir=base)
    p = runner.start(["--steps", str(a.steps), "--checkpoint", "c.ckpt", "--checkpoint-every", "1"], work)
    time.sleep(rng.uniform(0.3 * span, 0.9 * span))
    if rng.random() < 0.5:  # half the kills land while a checkpoint is being written
        until = time.monotonic() + span
        while not writing(work, full) and p.poll() is None and time.monotonic() < until:
            time.sleep(0.0002)
        time.sleep(rng.uniform(0, 0.004))
    kill_session(p.pid)
    p.wait()
    out = {}
    files = {name: os.path.join(work, name) for name in ("c.ckpt", "c.ckpt.prev", "c.ckpt.tmp")}
    present = {n for n, f in files.items() if os.path.exists(f)}
    if "c.ckpt.prev" in present and "c.ckpt" not in present:
        out["c.ckpt"] = "missing while c.ckpt.prev exists"
    for name in sorted(present):
        shutil.copy(files[name], os.path.join(work, "try.ckpt"))  # the restart must not touch what it reads
        out[name] = restart(runner, os.path.join(work, "try.ckpt"), a.steps, work, reference)
    shutil.rmtree(work)
    return out


def main():
    a = parse()
    runner = Runner(a)
    base = tempfile.mkdtemp(prefix="parode_faults_")
    t0 = time.monotonic()
    r = runner.run(["--steps", str(a.steps), "--checkpoint", "c.ckpt", "--checkpoint-every", "1", "--report", "full.json"],
                   base)
    span = time.monotonic() - t0
    if r.returncode != 0:
        sys.exit(f"the uninterrupted run exited {r.returncode}: {r.stderr}")
    with open(os.path.join(base, "full.json")) as f:
        reference = json.load(f)["state_hash"]
    rng = random.Random(a.seed)
    bad, tally = [], {}
    for i in range(a.kills):
        for name, outcome in trial(runner, a, rng, span, os.path.getsize(os.path.join(base, 'c.ckpt')), reference, base).items():
            ok = outcome == "exact" or (outcome == "refused" and name == "c.ckpt.tmp")
            tally[(name, outcome if ok else "FAILED")] = tally.get((name, outcome if ok else "FAILED"), 0) + 1
            if not ok:
                bad.append(f"kill {i}: {name}: {outcome}")
    shutil.rmtree(base)
    print(f"{a.kills} kills of a {a.catoms}-catom run on {a.ranks or 1} process(es), {span:.2f} s uninterrupted:")
    for (name, outcome), n in sorted(tally.items()):
        print(f"  {name:12s} {outcome:8s} {n}")
    if bad:
        sys.exit("\n".join(bad))


if __name__ == "__main__":
    main()
