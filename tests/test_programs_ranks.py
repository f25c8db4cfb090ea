#!/usr/bin/env python3
"""Catom programs on several MPI processes (`mpiexec -n N parode run`): the
same bits as one process.

- gradient on the collapsing tennis prism (catoms migrate between processes
  with their program state, messages cross processes every step): the same
  state hash, values, message and event counts on 1, 2 and 3 processes, and
  the same program values in the H5MD file, and hardly more listings of
  candidate neighbours than one process (arrivals are patched in);
- sculpt on the magnetic prism (magnet switches reach the processes that hold
  the catoms as ghosts): the same hash and values on 1 and 2 processes;
- a checkpoint written by 2 processes restarts on 3 and on 1 exactly, also
  at 20,000 catoms, whose programs' section is made in pieces and read in
  windows (and has the same bytes from 3 processes as from 1);
- a program that fails ends the run on 3 processes with exit 9 and the
  message one process gives.

Usage: test_programs_ranks.py --parode BIN --source DIR --mpiexec BIN [unittest args]
Trade-off: small scenes (2,000 catoms, 200 steps) on an oversubscribed
2-core machine; enough to move a thousand catoms between processes.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import unittest

_ap = argparse.ArgumentParser(add_help=False)
_ap.add_argument("--parode", required=True)
_ap.add_argument("--source", required=True)
_ap.add_argument("--mpiexec", required=True)
ARGS, REST = _ap.parse_known_args()
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OMP_WAIT_POLICY="passive",
           OMPI_MCA_rmaps_base_oversubscribe="1")
# reach 1.0: the neighbour range (2 r + reach = 2 m) is the whole ghost halo
# (a cell of 4 r), so catoms arriving at its edge are at once candidates of
# catoms inside it (the patched candidates must list them both ways)
GRADIENT = '[program]\nname = "gradient"\nmax_messages = 100\nreach = 1.0\n[program.params]\nseed = 7\n'
SCULPT = '[program]\nname = "sculpt"\n[program.params]\ncx = 0.0\ncy = 0.0\ncz = 0.5\nradius = 4.0\n'


def scene(d, base, program):
    with open(os.path.join(ARGS.source, "jobs", "scenes", base)) as f:
        text = f.read()
    path = os.path.join(d, base.replace(".toml", "-program.toml"))
    with open(path, "w") as f:
        f.write(text + "\n" + program)
    return path


def run(path, d, ranks, *options, tag="r", expect=0):
    report = os.path.join(d, f"{tag}{ranks}.json")
    launcher = [ARGS.mpiexec, "-n", str(ranks), "--oversubscribe"] if ranks > 1 else []
    cmd = launcher + [ARGS.parode, "run", path, "-q", "--threads", "1", "--report", report] + list(options)
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=600, env=ENV)
    if p.returncode != expect:
        raise AssertionError(f"{' '.join(cmd)}: exit {p.returncode}, expected {expect}: {p.stderr[-2000:]}")
    if expect:
        return p.stderr
    with open(report) as f:
        return json.load(f)


def same_program(test, a, b):
    test.assertEqual(a["state_hash"], b["state_hash"])
    for key in ("messages", "events", "values"):
        test.assertEqual(a["program"][key], b["program"][key], key)


class ProgramsOnRanks(unittest.TestCase):
    def test_gradient_with_migrations_on_one_two_three(self):
        import h5py
        with tempfile.TemporaryDirectory() as d:
            path = scene(d, "tennis.toml", GRADIENT)
            common = ("--set", "catoms.count=2000", "--steps", "200", "--snapshot-every", "100")
            reps, hops = {}, {}
            for n in (1, 2, 3):
                snap = os.path.join(d, f"s{n}.h5")
                reps[n] = run(path, d, n, *common, "--snapshot", snap)
                with h5py.File(snap, "r") as f:
                    hops[n] = f["particles/all/program_hops/value"][:].tolist()
            self.assertGreater(reps[1]["program"]["messages"], 10000)
            self.assertGreater(reps[2]["parallel"]["migrations"], 100)
            self.assertGreater(reps[3]["parallel"]["migrations"], 100)
            for n in (2, 3):
                same_program(self, reps[1], reps[n])
                self.assertEqual(hops[1], hops[n])
                # catoms arriving from another process are patched into the
                # candidates, not a reason to list them all afresh
                listings = reps[n]["program"]["neighbour_listings"]
                self.assertLess(listings, 2 * reps[1]["program"]["neighbour_listings"] + 5)

    def test_sculpt_switches_magnets_on_ghosts(self):
        with tempfile.TemporaryDirectory() as d:
            path = scene(d, "magnetic-tennis.toml", SCULPT)
            one = run(path, d, 1, "--set", "catoms.count=1000", "--steps", "150")
            two = run(path, d, 2, "--set", "catoms.count=1000", "--steps", "150")
            self.assertIn(0.0, one["program"]["values"]["inside"])  # some catoms let go
            same_program(self, one, two)

    def restarts_exactly(self, d, catoms, steps):
        """A checkpoint of 2 processes at `steps` restarts on 3 and on 1 to the hash and
        program values of 2 x `steps` straight; the scene's path."""
        path = scene(d, "tennis.toml", GRADIENT)
        common = ("--set", f"catoms.count={catoms}")
        full = run(path, d, 1, *common, "--steps", str(2 * steps), tag="full")
        ckpt = os.path.join(d, "c.ckpt")
        run(path, d, 2, *common, "--steps", str(steps), "--checkpoint", ckpt, tag="half")
        self.assertGreater(os.path.getsize(ckpt), catoms * 100)  # the programs' section: about 115 bytes a catom
        for n in (3, 1):
            again = run(path, d, n, *common, "--steps", str(steps), "--restart", ckpt, tag="again")
            same_program(self, full, again)
            self.assertTrue(again["restart"]["checked"]["program_state"])
        return path

    def test_checkpoint_of_two_restarts_on_three_and_one(self):
        with tempfile.TemporaryDirectory() as d:
            self.restarts_exactly(d, 2000, 80)

    def test_large_checkpoint_in_pieces(self):
        """20,000 catoms: the section is made in 3 pieces of 8,192 catoms and read back in
        windows of 64 kB (a record cut by a window's end is read again); a checkpoint of 2
        processes restarts on 3 and 1 exactly, and the section of 3 processes has the bytes of 1's."""
        with tempfile.TemporaryDirectory() as d:
            path = self.restarts_exactly(d, 20000, 4)
            common = ("--set", "catoms.count=20000")
            files = []
            for n in (1, 3):
                files.append(os.path.join(d, f"c{n}.ckpt"))
                run(path, d, n, *common, "--steps", "4", "--checkpoint", files[-1], tag="bytes")
            sections = []
            for f in files:
                with open(f, "rb") as c:  # the head's JSON line, then the section at the file's end
                    c.readline()
                    extra = json.loads(c.readline())["extra"]
                    c.seek(-extra["bytes"], os.SEEK_END)
                    sections.append(c.read())
            self.assertTrue(sections[0] == sections[1], "the programs' section depends on the number of processes")

    def test_failure_ends_every_process(self):
        with tempfile.TemporaryDirectory() as d:
            path = scene(d, "tennis.toml", GRADIENT.replace("max_messages = 100", "max_messages = 8"))
            one = run(path, d, 1, "--set", "catoms.count=4000", "--steps", "200", expect=9)
            three = run(path, d, 3, "--set", "catoms.count=4000", "--steps", "200", expect=9)
            said = [sorted({l for l in err.splitlines() if l.startswith("parode: catom program failed")})
                    for err in (one, three)]
            self.assertEqual(len(said[0]), 1, one)
            self.assertEqual(said[0], said[1])  # every process says the same, as one process does
            self.assertIn("more than program.max_messages = 8 messages in one step", said[0][0])


if __name__ == "__main__":
    unittest.main(argv=[sys.argv[0]] + REST)
