#!/usr/bin/env python3
"""Physical invariants with exact answers, for every solver configuration the
speed-against-error front compares: parode's solver as it is (20 iterations),
with substeps (4 substeps of 3 iterations; 4 of one, not over-relaxed), and
ODE's QuickStep.

- A sphere on an incline of angle theta rolls without slipping when
  mu >= 2/7 tan(theta), at a = 5/7 g sin(theta); below it slides at
  a = g (sin(theta) - mu cos(theta)).
- A box on an incline sticks when tan(theta) < mu and slides above at
  a = g (sin(theta) - mu cos(theta)) (the friction cone's edge).
- A sphere dropped from h onto a floor with restitution e rises to e^2 h
  (within 8 %: the bounce target is the closing speed at the start of the
  step of the impact, after the contact has sunk in).
- Two spheres meeting head on without gravity or friction keep their momentum
  exactly; with e = 1 the kinetic energy within 4 %; seen in a mirror (the
  bodies trading places in the contact's rows) the result is the mirrored one.
Each prints what it measured (the front's table of exact errors).
Each runs the scene from a TOML text through `parode run` and reads the
final state from a CSV snapshot. Usage: test_exact.py PARODE [unittest args]
"""
import csv
import math
import os
import subprocess
import sys
import tempfile
import unittest

PARODE = sys.argv[1] if len(sys.argv) > 1 else "build/ci/parode"
REST = sys.argv[2:]
G = 9.81
CONFIGS = {
    "parallel": ["--solver", "parallel"],
    "substeps": ["--solver", "parallel", "--set", "solver.substeps=4", "--set", "solver.iterations=3"],
    "substeps-w1": ["--solver", "parallel", "--set", "solver.substeps=4", "--set", "solver.iterations=1",
                    "--set", "solver.sor_w=1"],
    "quickstep": ["--solver", "ode"],
}

HEAD = """[scene]
name = "exact"
dt = {dt}
gravity = [0.0, 0.0, {gz}]
observe_every = 1
[solver]
iterations = 20
erp = 0.2
cfm = 1e-5
contact_surface_layer = 0.0
[[materials]]
name = "m"
mu = {mu}
bounce = {bounce}
bounce_vel = 0.01
"""


def run(scene, steps, options):
    """Final rows of the CSV snapshot: body -> (x, y, z), and the velocities from the report."""
    with tempfile.TemporaryDirectory(prefix="parode_exact_") as d:
        path = os.path.join(d, "s.toml")
        with open(path, "w") as f:
            f.write(scene)
        snap = os.path.join(d, "s.csv")
        cmd = [PARODE, "run", path, "--steps", str(steps), "-q", "--snapshot", snap, "--snapshot-every", str(steps),
               "--threads", "1"] + options
        subprocess.run(cmd, check=True, capture_output=True, timeout=120)
        with open(snap) as f:
            rows = [r for r in csv.DictReader(f) if int(r["step"]) == steps]
        return {int(r["body"]): tuple(float(r[k]) for k in "xyz") for r in rows}


def incline(shape, theta, mu, dt=0.005):
    s, c = math.sin(theta), math.cos(theta)
    n = (s, 0.0, c)
    body = ('shape = "sphere"\nradius = 0.5' if shape == "sphere" else 'shape = "box"\nsize = [1.0, 1.0, 1.0]')
    pos = [0.5 * x for x in n]
    text = HEAD.format(dt=dt, gz=-G, mu=mu, bounce=0.0) + f"""
[[planes]]
normal = [{n[0]!r}, 0.0, {n[2]!r}]
material = "m"
[[bodies]]
name = "b"
{body}
mass = 1.0
position = [{pos[0]!r}, 0.0, {pos[2]!r}]
material = "m"
rotation = {{ axis = [0.0, 1.0, 0.0], angle = {theta!r} }}
"""
    return text, (c, 0.0, -s), pos


# The measurements, each for one configuration's options (what jobs/front.py tabulates).
INCLINE_T, INCLINE_DT = 1.0, 0.005


def incline_ratio(shape, deg, mu, options):
    """Distance slid or rolled down the incline in INCLINE_T over the analytic
    a T^2 / 2 (x (1 + 1/steps): the explicit update's sum), and the analytic distance."""
    th = math.radians(deg)
    rolls = shape == "sphere" and mu >= 2 / 7 * math.tan(th)
    if rolls:
        a = 5 / 7 * G * math.sin(th)
    elif shape == "box" and math.tan(th) < mu:
        a = 0.0
    else:
        a = G * (math.sin(th) - mu * math.cos(th))
    text, d, start = incline(shape, th, mu, INCLINE_DT)
    steps = int(round(INCLINE_T / INCLINE_DT))
    want = 0.5 * a * INCLINE_T ** 2 * (1 + 1 / steps)
    got = sum((run(text, steps, options)[0][i] - start[i]) * d[i] for i in range(3))
    return got, want


def apex_ratio(options, e=0.5, h=2.0):
    text = HEAD.format(dt=0.001, gz=-G, mu=0.0, bounce=e) + f"""
[[planes]]
normal = [0.0, 0.0, 1.0]
material = "m"
[[bodies]]
name = "b"
shape = "sphere"
radius = 0.5
mass = 1.0
position = [0.0, 0.0, {0.5 + h!r}]
material = "m"
"""
    fall = math.sqrt(2 * h / G)
    rise = e * math.sqrt(2 * G * h) / G
    steps = int(round((fall + rise) / 0.001))
    return (run(text, steps, options)[0][2] - 0.5) / (e * e * h)


def head_on(e, options, mirrored=False):
    """Velocities (m/s) of a 1 kg sphere at 2 m/s and a 3 kg one at -1 m/s after
    they meet, from their displacement over the last 0.1 s of 1 s. Mirrored:
    the same collision seen in a mirror (x -> -x), the 3 kg sphere first, so
    that each body takes the other's place in the contact's rows."""
    a, b = ((3.0, 1.0), (1.0, -2.0)) if mirrored else ((1.0, 2.0), (3.0, -1.0))  # (mass, velocity)
    text = HEAD.format(dt=0.001, gz=0.0, mu=0.0, bounce=e) + f"""
[[bodies]]
name = "a"
shape = "sphere"
radius = 0.5
mass = {a[0]!r}
position = [-1.0, 0.0, 0.0]
velocity = [{a[1]!r}, 0.0, 0.0]
material = "m"
[[bodies]]
name = "b"
shape = "sphere"
radius = 0.5
mass = {b[0]!r}
position = [1.0, 0.0, 0.0]
velocity = [{b[1]!r}, 0.0, 0.0]
material = "m"
"""
    p, q = run(text, 1000, options), run(text, 900, options)
    return [(p[b][0] - q[b][0]) / 0.1 for b in (0, 1)]


class Incline(unittest.TestCase):
    def slide(self, shape, deg, mu, tolerance):
        for name, opt in CONFIGS.items():
            with self.subTest(config=name):
                got, want = incline_ratio(shape, deg, mu, opt)
                print(f"  {name}: {shape} at {deg} deg, mu {mu}: {got:.5f} m against {want:.5f} m")
                if want == 0:
                    self.assertLess(abs(got), tolerance, f"{name}: the {shape} moved {got:.4g} m; it must stick")
                else:
                    self.assertAlmostEqual(got / want, 1.0, delta=tolerance, msg=f"{name}: {got:.5g} m, analytic {want:.5g} m")

    def test_sphere_rolls(self):
        self.slide("sphere", 20, 0.5, 0.02)

    def test_sphere_slides_below_the_rolling_bound(self):
        self.slide("sphere", 20, 0.05, 0.02)  # 2/7 tan(20 deg) = 0.104 > mu

    def test_box_sticks_inside_the_cone(self):
        self.slide("box", 20, 0.5, 0.01)  # tan 20 deg = 0.36 < 0.5: within 1 cm

    def test_box_slides_outside_the_cone(self):
        self.slide("box", 35, 0.5, 0.03)  # tan 35 deg = 0.70 > 0.5


class Restitution(unittest.TestCase):
    def test_apex_after_one_bounce(self):
        for name, opt in CONFIGS.items():
            with self.subTest(config=name):
                r = apex_ratio(opt)
                print(f"  {name}: apex / e^2 h {r:.4f}")
                self.assertAlmostEqual(r, 1.0, delta=0.08, msg=f"{name}: apex ratio {r:.4g}")


class HeadOn(unittest.TestCase):
    def test_elastic_keeps_momentum_and_energy(self):
        for name, opt in CONFIGS.items():
            with self.subTest(config=name):
                va, vb = head_on(1.0, opt)
                self.assertAlmostEqual(1.0 * va + 3.0 * vb, 2.0 - 3.0, delta=1e-6, msg=f"{name}: momentum")
                ke = 0.5 * va * va + 1.5 * vb * vb
                print(f"  {name}: kinetic energy after / before {ke / 3.5:.4f}")
                self.assertAlmostEqual(ke / (0.5 * 4 + 1.5 * 1), 1.0, delta=0.04, msg=f"{name}: energy {ke:.5g} J")

    def test_plastic_keeps_momentum(self):
        # Not the common velocity -0.25 m/s: the depth reached in the step of the
        # impact (up to 3 mm) is pushed out by ERP, which parts the spheres again.
        for name, opt in CONFIGS.items():
            with self.subTest(config=name):
                va, vb = head_on(0.0, opt)
                self.assertAlmostEqual(1.0 * va + 3.0 * vb, 2.0 - 3.0, delta=1e-6, msg=f"{name}: momentum")

    def test_mirror_gives_the_mirrored_result(self):
        # Plastic, so that the depth's correction (both bodies' displacements
        # over the substeps) sets the velocities after the impact: seen in a
        # mirror, the bodies trade places in the contact's rows.
        for name, opt in CONFIGS.items():
            with self.subTest(config=name):
                va, vb = head_on(0.0, opt)
                ma, mb = head_on(0.0, opt, mirrored=True)  # ma: the 3 kg sphere
                print(f"  {name}: 1 kg sphere {va:.9f} m/s, mirrored {-mb:.9f}")
                self.assertAlmostEqual(va, -mb, delta=1e-9, msg=f"{name}: the 1 kg sphere")
                self.assertAlmostEqual(vb, -ma, delta=1e-9, msg=f"{name}: the 3 kg sphere")


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]] + REST, verbosity=2)
