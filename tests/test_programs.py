#!/usr/bin/env python3
"""Catom programs end to end (`parode run` with a [program] table), each
against an independent answer computed here from the run's own positions:

- gradient: every catom's hop count equals a breadth-first search of the
  neighbour graph (centres within 2 r + reach) from the seed;
- wave: every catom records the step the wave reached it (its BFS distance),
  and the messages number between |V| - 1 and 2 |E| (the algorithm's bound);
- sculpt: starting from the magnetic prism, the catoms outside a sphere switch
  their magnets off and fall away (at least 80 % of them move more than 0.25 m)
  while those inside keep their shape (RMS change of their distances to their
  centroid below 5 cm, the tolerance of a held cluster settling);
- the same state hash on 1 and 2 threads, and another one than without the
  program (its state is hashed);
- bad programs: an unknown name, a library that does not load or lacks the
  entry point, a handler that throws, a message to a catom that is not a
  neighbour (from a library built here), a sender past its budget: exit 9
  with the catom, the event and the reason.
Usage: test_programs.py PARODE SOURCE [unittest args]
"""
import collections
import csv
import json
import math
import os
import subprocess
import sys
import tempfile
import unittest

PARODE = sys.argv[1] if len(sys.argv) > 1 else "build/ci/parode"
SOURCE = sys.argv[2] if len(sys.argv) > 2 else "."
REST = sys.argv[3:]
PRISM = os.path.join(SOURCE, "jobs", "scenes", "magnetic-tennis.toml")
REACH = 0.25  # magnetic-tennis: magnets.cutoff, the program's default reach
RADIUS = 0.5


def scene_with(program, d, extra=""):
    with open(PRISM) as f:
        text = f.read()
    path = os.path.join(d, "scene.toml")
    with open(path, "w") as f:
        f.write(text + "\n" + program + "\n" + extra)
    return path


def run(scene, d, *options, expect=0):
    report = os.path.join(d, "r.json")
    snap = os.path.join(d, "s.csv")
    cmd = [PARODE, "run", scene, "-q", "--report", report, "--snapshot", snap] + list(options)
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    if p.returncode != expect:
        raise AssertionError(f"exit {p.returncode}, expected {expect}: {p.stderr}")
    if expect:
        return p.stderr
    with open(report) as f:
        rep = json.load(f)
    frames = collections.defaultdict(dict)
    with open(snap) as f:
        for r in csv.DictReader(f):
            frames[int(r["step"])][int(r["body"])] = tuple(float(r[k]) for k in "xyz")
    return rep, frames


def bfs(pos, seed):
    ids = sorted(pos)
    cell = collections.defaultdict(list)
    edge = 2 * RADIUS + REACH
    for i in ids:
        cell[tuple(math.floor(c / edge) for c in pos[i])].append(i)
    nbrs = {i: [] for i in ids}
    for i in ids:
        c = tuple(math.floor(v / edge) for v in pos[i])
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    for j in cell[(c[0] + dx, c[1] + dy, c[2] + dz)]:
                        if j != i and math.dist(pos[i], pos[j]) <= 2 * RADIUS + REACH:
                            nbrs[i].append(j)
    dist = {seed: 0}
    queue = collections.deque([seed])
    while queue:
        i = queue.popleft()
        for j in nbrs[i]:
            if j not in dist:
                dist[j] = dist[i] + 1
                queue.append(j)
    return dist, sum(len(v) for v in nbrs.values()) // 2


class Programs(unittest.TestCase):
    def test_gradient_is_the_breadth_first_search(self):
        with tempfile.TemporaryDirectory() as d:
            scene = scene_with('[program]\nname = "gradient"\n[program.params]\nseed = 0', d)
            rep, frames = run(scene, d, "--steps", "60", "--snapshot-every", "60")
            p = rep["program"]
            dist, _ = bfs(frames[60], 0)
            hops = dict(zip(p["ids"], p["values"]["hops"]))
            self.assertEqual(len(hops), 1000)
            wrong = [(i, hops[i], dist.get(i, -1)) for i in hops if hops[i] != dist.get(i, -1)]
            self.assertFalse(wrong, f"hop counts differ from the BFS at {len(wrong)} catoms: {wrong[:5]}")
            self.assertEqual(max(hops.values()), 27)  # the far corner of a 10 x 10 x 10 prism

    def test_wave_reaches_every_catom_within_its_message_bound(self):
        with tempfile.TemporaryDirectory() as d:
            scene = scene_with('[program]\nname = "wave"\n[program.params]\nseed = 555', d)
            rep, frames = run(scene, d, "--steps", "40", "--snapshot-every", "40")
            p = rep["program"]
            dist, edges = bfs(frames[40], 555)
            reached = dict(zip(p["ids"], p["values"]["step"]))
            self.assertEqual({i: reached[i] for i in reached}, {i: float(dist[i]) for i in reached})
            self.assertGreaterEqual(p["messages"], 1000 - 1)
            self.assertLessEqual(p["messages"], 2 * edges)

    def test_sculpt_keeps_the_catoms_inside_the_sphere(self):
        with tempfile.TemporaryDirectory() as d:
            program = '[program]\nname = "sculpt"\n[program.params]\ncx = 0.0\ncy = 0.0\ncz = 0.5\nradius = 4.0'
            rep, frames = run(scene_with(program, d), d, "--steps", "400", "--snapshot-every", "400")
            inside = dict(zip(rep["program"]["ids"], rep["program"]["values"]["inside"]))
            start, end = frames[0], frames[400]
            geometric = {i: float(math.dist(start[i], (0.0, 0.0, 0.5)) <= 4.0) for i in start}
            self.assertEqual(inside, geometric)
            kept = [i for i in start if geometric[i]]
            gone = [i for i in start if not geometric[i]]
            self.assertGreater(len(kept), 50)
            self.assertGreater(len(gone), 300)

            def centred(f):
                c = [sum(f[i][k] for i in kept) / len(kept) for k in range(3)]
                return {i: math.dist(f[i], c) for i in kept}
            a, b = centred(start), centred(end)
            rms = math.sqrt(sum((a[i] - b[i]) ** 2 for i in kept) / len(kept))
            self.assertLess(rms, 0.05, "the catoms inside lost their shape")
            moved = sum(math.dist(start[i], end[i]) > 0.25 for i in gone) / len(gone)
            self.assertGreater(moved, 0.8, f"only {moved:.0%} of the catoms outside fell away")

    def test_values_in_the_h5md_snapshot_and_its_xdmf(self):
        try:
            import h5py
        except ImportError:
            self.skipTest("h5py is not installed")
        with tempfile.TemporaryDirectory() as d:
            scene = scene_with('[program]\nname = "gradient"\n[program.params]\nseed = 0', d)
            h5 = os.path.join(d, "g.h5")
            rep = run(scene, d, "--steps", "40", "--set", "catoms.count=512")[0]
            subprocess.run([PARODE, "run", scene, "-q", "--steps", "40", "--set", "catoms.count=512", "--snapshot", h5,
                            "--snapshot-every", "20"], check=True, timeout=300)
            with h5py.File(h5, "r") as f:
                v = f["particles/all/program_hops/value"]
                self.assertEqual(v.shape, (3, 512))
                self.assertEqual(list(f["particles/all/program_hops/step"]), [0, 20, 40])
                self.assertEqual(list(v[-1]), rep["program"]["values"]["hops"])
                self.assertTrue(all(x == 0 for x in v[0]))  # step 0: before any handler ran
            with open(os.path.join(d, "g.xdmf")) as f:
                self.assertIn('Attribute Name="program_hops"', f.read())

    def test_checkpoint_restarts_the_programs_exactly(self):
        for name, params in (("gradient", "seed = 0"), ("wave", "seed = 100")):
            with self.subTest(program=name), tempfile.TemporaryDirectory() as d:
                scene = scene_with(f'[program]\nname = "{name}"\n[program.params]\n{params}', d)
                common = ["--set", "catoms.count=512"]
                full = run(scene, d, "--steps", "30", *common)[0]
                ckpt = os.path.join(d, "c.ckpt")
                run(scene, d, "--steps", "12", "--checkpoint", ckpt, *common)
                again = run(scene, d, "--steps", "18", "--restart", ckpt, *common)[0]
                self.assertEqual(again["state_hash"], full["state_hash"])
                self.assertEqual(again["program"]["values"], full["program"]["values"])
                self.assertEqual(again["program"]["messages"], full["program"]["messages"])
                self.assertTrue(again["restart"]["checked"]["program_state"])
                with open(ckpt, "r+b") as f:  # the programs' state is the file's last section
                    f.seek(-3, os.SEEK_END)
                    byte = f.read(1)
                    f.seek(-3, os.SEEK_END)
                    f.write(bytes([byte[0] ^ 0x10]))
                err = run(scene, d, "--steps", "1", "--restart", ckpt, *common, expect=8)
                self.assertIn("the catom programs' state", err)

    def test_same_hash_on_any_thread_count_and_hashed_state(self):
        with tempfile.TemporaryDirectory() as d:
            plain = run(PRISM, d, "--steps", "30", "--set", "catoms.count=512")[0]["state_hash"]
            scene = scene_with('[program]\nname = "gradient"\n[program.params]\nseed = 7', d)
            one = run(scene, d, "--steps", "30", "--set", "catoms.count=512", "--threads", "1")[0]
            two = run(scene, d, "--steps", "30", "--set", "catoms.count=512", "--threads", "2")[0]
            self.assertEqual(one["state_hash"], two["state_hash"])
            self.assertEqual(one["program"]["values"], two["program"]["values"])
            self.assertNotEqual(one["state_hash"], plain)


SHY = """#include <programs/program.hpp>
namespace {
class Shy final : public parode::CatomProgram {
public:
    void on_neighbour_gained(parode::CatomContext& c, std::uint32_t id) override {
        if (c.id() == 0 && c.param("off", 0) != 0) c.set_magnets_toward(id, false);
        c.set_value(0, c.magnets_toward(id) ? 1 : 0);
    }
};
}
PARODE_PROGRAM_ENTRY {
    static const parode::ProgramSpec s{"shy", {"toward"}, [] { return std::make_unique<Shy>(); }};
    return &s;
}
"""

TWO_CATOMS = """[scene]
name = "two-catoms"
dt = 0.005
gravity = [0.0, 0.0, 0.0]
[[materials]]
name = "catom"
[[bodies]]
name = "a"
radius = 0.5
mass = 1.0
position = [0.0, 0.0, 5.0]
catom = true
[[bodies]]
name = "b"
radius = 0.5
mass = 1.0
position = [1.1, 0.0, 5.0]
catom = true
[magnets]
layout = "axes6"
cutoff = 0.25
[program]
name = "{lib}"
[program.params]
off = {off}
"""


def build_library(d, name, source):
    cpp, lib = os.path.join(d, name + ".cpp"), os.path.join(d, name + ".so")
    with open(cpp, "w") as f:
        f.write(source)
    cxx = os.environ.get("CXX", "c++")
    subprocess.run([cxx, "-std=c++17", "-shared", "-fPIC", "-fvisibility=hidden", "-I",
                    os.path.join(SOURCE, "src"), "-o", lib, cpp], check=True, timeout=120)
    return lib


class Poles(unittest.TestCase):
    def test_the_pole_toward_a_neighbour(self):
        """Two catoms 0.1 m apart without gravity: only catom 0's +x pole and
        catom 1's -x pole are within the cutoff, so they pull together; with
        catom 0's pole toward catom 1 switched off no force acts and neither
        moves by a bit."""
        with tempfile.TemporaryDirectory() as d:
            lib = build_library(d, "shy", SHY)
            runs = {}
            for off in (0, 1):
                path = os.path.join(d, f"two{off}.toml")
                with open(path, "w") as f:
                    f.write(TWO_CATOMS.format(lib=lib, off=off))
                runs[off] = run(path, d, "--steps", "100", "--snapshot-every", "100")
            (on, moved), (off, still) = runs[0], runs[1]
            self.assertGreater(moved[100][0][0], 0.04)  # pulled to contact: 0.05 each
            self.assertLess(moved[100][1][0], 1.06)
            self.assertEqual(still[100][0], (0.0, 0.0, 5.0))
            self.assertEqual(still[100][1], (1.1, 0.0, 5.0))
            self.assertEqual(on["program"]["values"]["toward"], [1.0, 1.0])
            self.assertEqual(off["program"]["values"]["toward"], [0.0, 1.0])  # catom 1's own pole stays on
            self.assertNotEqual(on["state_hash"], off["state_hash"])


class ProgramOption(unittest.TestCase):
    def test_program_option_runs_as_the_table(self):
        """`--program wave` (with its params from --set) runs what the
        [program] table does: the same hash, values and message count."""
        with tempfile.TemporaryDirectory() as d:
            table = run(scene_with('[program]\nname = "wave"\n[program.params]\nseed = 0', d), d, "--steps", "60")[0]
            option = run(PRISM, d, "--steps", "60", "--program", "wave", "--set", "program.params.seed=0")[0]
            self.assertEqual(option["program"]["name"], "wave")
            self.assertEqual(option["state_hash"], table["state_hash"])
            self.assertEqual(option["program"]["values"], table["program"]["values"])
            self.assertEqual(option["program"]["messages"], table["program"]["messages"])
            self.assertGreater(option["program"]["messages"], 0)


class CandidateNeighbours(unittest.TestCase):
    def test_skin_gives_the_full_search(self):
        """Gradient on the collapsing tennis prism (catoms move fast, messages
        every step): candidates listed with the default skin give the bits of
        a search every step (skin 0), and the candidates were kept for most
        steps."""
        with tempfile.TemporaryDirectory() as d:
            with open(os.path.join(SOURCE, "jobs", "scenes", "tennis.toml")) as f:
                text = f.read()
            path = os.path.join(d, "tennis-gradient.toml")
            with open(path, "w") as f:
                f.write(text + '\n[program]\nname = "gradient"\nmax_messages = 30\nreach = 0.25\n'
                        '[program.params]\nseed = 7\n')
            common = ("--steps", "200", "--set", "catoms.count=1000")
            skin = run(path, d, *common)[0]
            os.environ["PARODE_PROGRAM_SKIN"] = "0"
            try:
                full = run(path, d, *common)[0]
            finally:
                del os.environ["PARODE_PROGRAM_SKIN"]
            self.assertEqual(skin["state_hash"], full["state_hash"])
            self.assertEqual(skin["program"]["values"], full["program"]["values"])
            self.assertGreater(full["program"]["neighbour_listings"], 150)
            self.assertLess(skin["program"]["neighbour_listings"], 100)


class BadPrograms(unittest.TestCase):
    def failure(self, program, extra=""):
        with tempfile.TemporaryDirectory() as d:
            return run(scene_with(program, d, extra), d, "--steps", "5", expect=9)

    def test_unknown_name(self):
        err = self.failure('[program]\nname = "gradiant"')
        self.assertIn("unknown program 'gradiant'", err)
        self.assertIn("gradient, sculpt, wave", err)

    def test_library_that_does_not_load(self):
        self.assertIn("cannot load the program library /nonexistent/p.so", self.failure('[program]\nname = "/nonexistent/p.so"'))

    def test_library_without_the_entry_point(self):
        with tempfile.TemporaryDirectory() as d:
            lib = os.path.join(d, "libm.so")
            os.symlink("/lib/x86_64-linux-gnu/libm.so.6", lib)
            err = self.failure(f'[program]\nname = "{lib}"')
            self.assertIn("has no entry point parode_program", err)

    def test_handler_that_throws_names_catom_and_event(self):
        err = self.failure('[program]\nname = "sculpt"')
        self.assertIn("catom 0, event start: program.params.radius must be a positive number", err)

    def test_message_to_a_non_neighbour(self):
        # A program library built here, as a user would, that writes to a catom far away.
        source = """#include <programs/program.hpp>
namespace {
class Far final : public parode::CatomProgram {
public:
    void on_start(parode::CatomContext& c) override { if (c.id() == 3) c.send(500, {7, 0, 0, 0}); }
};
}
PARODE_PROGRAM_ENTRY {
    static const parode::ProgramSpec s{"far", {}, [] { return std::make_unique<Far>(); }};
    return &s;
}
"""
        with tempfile.TemporaryDirectory() as d:
            cpp, lib = os.path.join(d, "far.cpp"), os.path.join(d, "far.so")
            with open(cpp, "w") as f:
                f.write(source)
            cxx = os.environ.get("CXX", "c++")
            subprocess.run([cxx, "-std=c++17", "-shared", "-fPIC", "-fvisibility=hidden", "-I",
                            os.path.join(SOURCE, "src"), "-o", lib, cpp], check=True, timeout=120)
            err = self.failure(f'[program]\nname = "{lib}"')
            self.assertIn("catom 3, event start: a message to catom 500, not a neighbour", err)

    def test_sender_past_its_budget(self):
        err = self.failure('[program]\nname = "gradient"\nmax_messages = 1\n[program.params]\nseed = 0')
        self.assertIn("catom 0, event timer: more than program.max_messages = 1 messages in one step", err)


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]] + REST, verbosity=2)
