#!/usr/bin/env python3
"""Expected state hashes of the classic scenes (tests/data/expected_hashes.json).

Runs each case of the file with the parode binary and compares the state hash
of its run report with the committed one, on every thread count the case
lists (or, with --mpiexec, every rank count), so that a change that moves
a classic scene's outcome is noticed and explained in the commit that moves
it, as Box2D and Jolt do with their own expected hashes.

  expected_hashes.py PARODE [--case NAME]                       compare, per thread count
  expected_hashes.py PARODE --mpiexec MPIEXEC                   compare, per rank count
  expected_hashes.py PARODE --update                            rewrite the file

A hash belongs to a build: ODE 0.16.2 as Debian builds it, GCC on x86-64 and
this project's flags (-ffp-contract=off in the core). Another compiler or ODE
may round differently; then --update and commit the new hashes with the
reason. Exit 0: every hash matched; 1: a mismatch (each one printed); 2: a
run failed.
Trade-off: whole runs of the parode binary (the command line a user types)
rather than library calls, so the defaults and the scene reader are covered
too; the cases are kept small so the test takes seconds.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
DATA = os.path.join(HERE, "data", "expected_hashes.json")


def run_hash(parode, case, threads, ranks, mpiexec):
    with tempfile.TemporaryDirectory() as tmp:
        report = os.path.join(tmp, "r.json")
        cmd = [parode, "run", os.path.join(ROOT, case["scene"]), "--steps", str(case["steps"]),
               "--threads", str(threads), "-q", "--report", report] + case.get("args", [])
        for kv in case.get("set", []):
            cmd += ["--set", kv]
        if ranks > 1:
            cmd = [mpiexec, "-n", str(ranks), "--oversubscribe"] + cmd
        env = dict(os.environ, OMP_WAIT_POLICY="passive")
        p = subprocess.run(cmd, env=env, capture_output=True, text=True)
        if p.returncode != 0:
            print(f"{case['name']}: {' '.join(cmd)} exited {p.returncode}:\n{p.stderr}", file=sys.stderr)
            sys.exit(2)
        with open(report) as f:
            return json.load(f)["state_hash"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("parode")
    ap.add_argument("--case", help="only this case")
    ap.add_argument("--mpiexec", help="run the cases' rank counts (not their thread counts) through this launcher")
    ap.add_argument("--update", action="store_true", help="rewrite the expected hashes (one thread, one rank)")
    a = ap.parse_args()
    with open(DATA) as f:
        data = json.load(f)
    bad = 0
    for case in data["cases"]:
        if a.case and case["name"] != a.case:
            continue
        if a.update:
            case["hash"] = run_hash(a.parode, case, 1, 1, None)
            print(f"{case['name']}: {case['hash']}")
            continue
        if a.mpiexec:
            runs = [(1, r) for r in case.get("ranks", []) if r > 1]
        else:
            runs = [(t, 1) for t in case.get("threads", [1])]
        for threads, ranks in runs:
            got = run_hash(a.parode, case, threads, ranks, a.mpiexec)
            ok = got == case["hash"]
            bad += not ok
            print(f"{case['name']} ({threads} threads, {ranks} ranks): {got} "
                  f"{'ok' if ok else 'expected ' + case['hash']}")
    if a.update:
        with open(DATA, "w") as f:
            json.dump(data, f, indent=2)
            f.write("\n")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
