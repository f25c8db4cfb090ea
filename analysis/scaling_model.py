#!/usr/bin/env python3
"""Weak-scaling projection of distributed parode runs to 1,000+ ranks.

Calibrated from measurements on this machine: a one-rank run report and a
two-rank run report of the same scene and size (jobs/rank_scaling.sh strong
or jobs/rank_variants.py), and optionally `parode latency --json` under
mpiexec -n 2. It projects the time of a step with n catoms per rank on R
ranks in a cubic block decomposition, keeping apart what the slowest rank
computes, what its ghosts add, and what it waits for, and prints the
weak-scaling efficiency T(1) / T(R) for this machine's network and for a
stated cluster network.

The model (one step after the first, the slowest rank):
  T(R) = c * n                                              owned catoms
       + c * phi * ghosts(n, R)                             ghost work
       + (imb - 1) * s * n                                  colour imbalance
       + rounds * exposed(n, R)                             solver exchanges
       + jitter * s * n * log2(nb(R) + 1)                   waiting for the slowest neighbour
       + 3 * (alpha * log2 R + nb(R) * o) + G(n, R) / beta  migrate, ghosts, forces
       + (1 + 12 / observe_every) * 2 * alpha * log2 R      reductions
  c       s per catom per step, from the one-rank run (steps after the first)
  s       the solver's colour work per catom per step (the two-rank run's
          per-colour compute, mean over ranks, per owned catom)
  imb     the colour imbalance (the slowest rank's compute summed over
          colours over the mean's): the two-rank run's at R = 2, and the
          partition's per-colour tolerance (--colour-imbalance, 1.06) beyond
  ghosts  catoms within one cell of a face, per face; faces(R) from the
          decomposition (1 at R = 2, up to 6 inside); two-rank calibrated
  phi     a ghost's cost over an owned catom's: (the two-rank run's step,
          less its time in MPI, less c * owned) / (c * ghosts)
  rounds  8 colours x (iterations + 1 warm start); each posts its boundary
          corrections and relaxes its interior cells while they travel:
  exposed = max(0, alpha + nb(R) * o + B(n, R) / beta - window(n, R)),
          window = s * interior(n, R) / rounds, the interior cells' share of a
          round's work; B the bytes of a round (the two-rank run's
          colour_bytes scaled by faces and by (n / n2)^(2/3): surface traffic)
  jitter  what the two-rank run waited beyond its imbalance, as a share of its
          colour work ((waits - (imb - 1) * s * n2) / (s * n2)): a neighbour
          late by chance, in proportion to the work of a round; the slowest
          of nb neighbours is later, by log2(nb + 1) (a bound above the
          sqrt(2 ln nb) of independent Gaussian delays)
  G       the ghost states and migrations of a step (comm_bytes less the
          solver's), scaled alike
  nb(R)   ranks sharing a face, edge or corner: up to 26 in 3D
  alpha, o, beta: latency of an exchange, its cost per partner, bandwidth:
          this machine's from --latency (else 5 us), the cluster's from
          --alpha (1.5 us, InfiniBand MPI), --overhead (0.3 us), --beta
          (10 GB/s)
Assumptions (stated in the output): catoms uniformly dense, as in the prism;
a partition as good as a cubic block decomposition (colour imbalance as at 2
ranks); latency independent of distance; no contention, topology or jitter.

Usage: python3 analysis/scaling_model.py --one R1.json --two R2.json
           [--latency LAT.json] [--alpha 1.5e-6] [--overhead 0.3e-6] [--beta 1e10]
           [--per-rank 100000,1000000] [--out FILE.md]
Trade-off: a closed form of the slowest rank, honest about what it leaves
out; it says at which size per rank the ~170 rounds a step stop hiding
behind the interior cells.
"""
import argparse
import json
import math
import sys

RANKS = [1, 2, 8, 64, 512, 1000, 4096, 32768]


def load(path):
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, json.JSONDecodeError) as e:
        sys.exit(f"scaling_model: {path}: {e}")


def cube_dims(r):
    """The most cubic factorisation of r into three factors."""
    best = (r, 1, 1)
    for a in range(1, round(r ** (1 / 3)) + 2):
        if r % a:
            continue
        for b in range(a, int(math.isqrt(r // a)) + 1):
            if (r // a) % b == 0:
                dims = (a, b, r // a // b)
                if max(dims) < max(best):
                    best = dims
    return best


def faces(r):
    """Faces of the most interior rank of a cubic decomposition of r ranks."""
    return sum(0 if k == 1 else 1 if k == 2 else 2 for k in cube_dims(r))


def neighbours(r):
    """Ranks sharing a face, edge or corner with the most interior rank."""
    span = [1 if k == 1 else 2 if k == 2 else 3 for k in cube_dims(r)]
    return span[0] * span[1] * span[2] - 1


def later_step(r):
    """Seconds a step over the steps after the first (the first faults in every buffer)."""
    first = (r.get("first_step") or {}).get("wall_s", 0.0)
    steps = r["steps"]
    wall = r.get("steps_wall_s", r["wall_s"])
    return (wall - first) / (steps - 1) if first and steps > 1 else wall / steps


class Model:
    def __init__(self, one, two, lat, args):
        steps2 = two["steps"]
        self.n1 = one["bodies"]
        self.n2 = two["bodies"] / 2                                   # owned per rank
        self.c = later_step(one) / self.n1
        par = two["parallel"]
        colours = par.get("colours") or []
        self.s = sum(c["compute_s"]["avg"] for c in colours) / steps2 / self.n2 if colours else 0.7 * self.c
        self.imb = max(1.0, par.get("colour_imbalance", par.get("partition_imbalance", 1.0)))
        self.ghosts2 = par["ghost_fraction"] * two["bodies"] / 2      # per rank, one face
        comm2 = par["comm_seconds"]["max"] / steps2
        compute2 = later_step(two) - comm2
        self.phi = max(0.0, (compute2 / self.c - self.n2) / max(self.ghosts2, 1.0))
        solver_bytes = sum(par.get("colour_bytes", [])) / steps2 / 2    # per rank per step
        self.rounds = 8 * (one["solver"]["iterations"] + 1)
        self.round_bytes2 = solver_bytes / self.rounds
        self.other_bytes2 = max(0.0, par["comm_bytes"] / steps2 / 2 - solver_bytes)
        self.wait2 = par.get("wait_seconds", {}).get("max", 0.0) / steps2
        self.jitter = max(0.0, self.wait2 - (self.imb - 1) * self.s * self.n2) / max(self.s * self.n2, 1e-30)
        self.imb_many = max(self.imb, args.colour_imbalance)
        self.observe_every = 10
        self.local_alpha = lat["exchange_round_s"][0] if lat else 5e-6
        self.alpha, self.o, self.beta = args.alpha, args.overhead, args.beta

    def surface(self, n, r):
        return faces(r) * (n / self.n2) ** (2 / 3) if r > 1 else 0.0

    def parts(self, n, r, alpha, o, beta):
        """compute, ghost work, imbalance, waiting (s a step)."""
        if r == 1:
            return self.c * n, 0.0, 0.0, 0.0
        ghosts = self.ghosts2 * self.surface(n, r)
        nb, lg = neighbours(r), math.log2(r)
        window = self.s * max(0.0, n - ghosts) / self.rounds
        exposed = max(0.0, alpha + nb * o + self.round_bytes2 * self.surface(n, r) / beta - window)
        waiting = self.rounds * exposed + self.jitter * self.s * n * math.log2(nb + 1)
        waiting += 3 * (alpha * lg + nb * o) + self.other_bytes2 * self.surface(n, r) / beta
        waiting += (1 + 12 / self.observe_every) * 2 * alpha * lg
        imb = self.imb if r == 2 else self.imb_many
        return self.c * n, self.c * self.phi * ghosts, (imb - 1) * self.s * n, waiting

    def table(self, per_rank):
        lines = []
        for label, alpha, o, beta in (("this machine (shared memory)", self.local_alpha, 0.1e-6, 5e9),
                                      (f"cluster (alpha {self.alpha * 1e6:.1f} us, {self.o * 1e6:.1f} us per partner, "
                                       f"{self.beta / 1e9:.0f} GB/s)", self.alpha, self.o, self.beta)):
            lines += [f"\n### {label}\n", "efficiency (ghost work / imbalance / waiting, % of the step)\n",
                      "| catoms/rank | " + " | ".join(f"R={r}" for r in RANKS) + " |", "|---|" + "---|" * len(RANKS)]
            for n in per_rank:
                t1 = sum(self.parts(n, 1, alpha, o, beta))
                cells = []
                for r in RANKS:
                    p = self.parts(n, r, alpha, o, beta)
                    t = sum(p)
                    cells.append(f"{t1 / t:.2f} ({100 * p[1] / t:.0f}/{100 * p[2] / t:.0f}/{100 * p[3] / t:.0f})")
                lines.append(f"| {n:,} | " + " | ".join(cells) + " |")
            lines.append("")
            lines.append(self.limit(alpha, o, beta))
        return "\n".join(lines)

    def limit(self, alpha, o, beta):
        """Smallest catoms per rank at which waiting stays under 10 % at R = 4096."""
        n = 1000
        while n < 1e9:
            p = self.parts(n, 4096, alpha, o, beta)
            if p[3] / sum(p) < 0.1:
                return (f"From about {n:,} catoms per rank (R = 4096) the interior cells hide the ~{self.rounds} "
                        "exchanges a step: waiting stays under 10 % of the step; below, each round's latency shows.")
            n = int(n * 1.25)
        return "waiting dominates at every size"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--one", required=True, help="run report of 1 rank")
    ap.add_argument("--two", required=True, help="run report of 2 ranks, same scene and size")
    ap.add_argument("--latency", help="JSON of `parode latency --json` (mpiexec -n 2)")
    ap.add_argument("--alpha", type=float, default=1.5e-6, help="cluster latency of an exchange round (s)")
    ap.add_argument("--overhead", type=float, default=0.3e-6, help="cluster cost per extra partner (s)")
    ap.add_argument("--beta", type=float, default=1e10, help="cluster bandwidth (bytes/s)")
    ap.add_argument("--colour-imbalance", type=float, default=1.06,
                    help="colour imbalance beyond 2 ranks (the partition's per-colour tolerance)")
    ap.add_argument("--per-rank", default="100000,1000000")
    ap.add_argument("--out")
    a = ap.parse_args()
    one, two = load(a.one), load(a.two)
    if two.get("ranks") != 2 or one.get("ranks", 1) != 1 or one["bodies"] != two["bodies"]:
        sys.exit("scaling_model: --one must be a 1-rank report and --two a 2-rank report of the same size")
    lat = load(a.latency) if a.latency else None
    m = Model(one, two, lat, a)
    head = [f"# Weak-scaling projection: {one['scene']}, calibrated at {one['bodies']:,} catoms",
            "",
            f"- compute: {m.c * 1e9:.0f} ns per catom per step (1 rank x {one['threads']} thread(s), steps after "
            f"the first); the solver's colours {m.s * 1e9:.0f} of them; a ghost costs {m.phi:.2f} of an owned catom",
            f"- two ranks: {m.ghosts2:,.0f} ghosts per rank (one face), colour imbalance {m.imb:.3f}, "
            f"{m.round_bytes2 / 1e3:.1f} kB per solver round and {m.other_bytes2 / 1e6:.2f} MB of other traffic per "
            f"rank per step, waits {m.wait2 * 1e3:.1f} ms a step measured ({100 * m.jitter:.1f} % of the colour work "
            f"beyond the imbalance); colour imbalance {m.imb_many:.2f} assumed beyond 2 ranks",
            f"- exchange round on this machine: {m.local_alpha * 1e6:.2f} us"
            + (f"; ping-pong {lat['ping_pong_s'][0] * 1e6:.2f} us one way" if lat else " (assumed: no --latency)"),
            "- efficiency = T(1) / T(R) with the same catoms per rank; in brackets the shares of the step spent on "
            "ghost work, colour imbalance and waiting",
            "- assumes a cubic block decomposition, uniform density, each round's exchange hidden behind the interior "
            "cells up to their work, the wait for the slowest neighbour growing as log2(neighbours + 1)"]
    text = "\n".join(head) + "\n" + m.table([int(x) for x in a.per_rank.split(",")]) + "\n"
    print(text)
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
