#!/usr/bin/env python3
"""Restitution apex and elastic energy (tests/test_exact.py's scenes) of
substeps x sweeps at SOR w = 1 and, where parode accepts it (3 sweeps a
substep or more), at the default w = 1.3. Usage (from the repository root):
python3 .../exact-w.py build/ci/parode > .../exact-w.txt
Trade-off: two invariants only, the two a bounce's overshoot moves."""
import os
import subprocess
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), *[".."] * 4))
sys.path.insert(0, os.path.join(ROOT, "tests"))
sys.argv = sys.argv[:2]
import test_exact as te  # noqa: E402  (the tests' scenes and measurements)


def energy(options):
    va, vb = te.head_on(1.0, options)
    return (0.5 * 1.0 * va ** 2 + 0.5 * 3.0 * vb ** 2) / (0.5 * 1.0 * 4.0 + 0.5 * 3.0 * 1.0)


print("substeps x sweeps | w | apex / e^2 h | elastic energy after / before")
for s, i in [(1, 20), (4, 1), (4, 2), (5, 2), (8, 1), (4, 3), (6, 3)]:
    for w in ("1", "1.3"):
        opt = ["--solver", "parallel", "--set", f"solver.substeps={s}", "--set", f"solver.iterations={i}",
               "--set", f"solver.sor_w={w}"]
        try:
            print(f"{s} x {i} | {w} | {te.apex_ratio(opt):.4f} | {energy(opt):.4f}")
        except subprocess.CalledProcessError as e:
            print(f"{s} x {i} | {w} | refused: {e.stderr.decode().strip().splitlines()[-1][-90:]}")
