#!/usr/bin/env python3
"""Weak-scaling projection of distributed parode runs to 1,000+ ranks.

Calibrated from measurements on this machine: a one-rank run report and a
two-rank run report of the same scene and size (jobs/rank_scaling.sh strong),
and `parode latency --json` under mpiexec -n 2. It projects the time of a step
with n catoms per rank on R ranks in a cubic block decomposition and prints the
weak-scaling efficiency T(1) / T(R) for this machine's latency and for an
assumed cluster network.

The model (one step, the slowest rank):
  T(R) = imbalance * c * (n + phi * ghosts(n, R))         compute
       + rounds * (alpha + neighbours(R) * o)              solver exchanges
       + bytes(n, R) / beta                                boundary traffic
       + 3 * (alpha * log2 R + neighbours(R) * o)          migrate, ghosts, forces (NBX)
       + (1 + k_obs / observe_every) * 2 alpha log2 R      reductions (guard; diagnostics)
  c       ns per catom per step, from the one-rank run (all stages)
  ghosts  catoms within one cell (2 catoms deep) of a face, per face; faces(R)
          from the decomposition (1 at R = 2, up to 6 for an interior rank);
          calibrated so that ghosts(n, 2) is the measured two-rank count
  phi     cost of a ghost relative to an owned catom, from the two-rank run:
          (compute time of a rank - c * owned) / (c * ghosts)
  rounds  8 colours x (iterations + 1 warm-start sweep), one message to
          every neighbour each (measured messages per step confirm it)
  alpha   latency of an exchange round; o the cost of one more partner in it
  bytes   measured two-rank bytes per rank per step, scaled by faces(R) and by
          (n / n_measured)^(2/3) (surface traffic)
  neighbours(R)  ranks sharing a face, edge or corner: up to 26 in 3D
Assumptions (stated in the output): catoms uniformly dense, as in the prism;
the partition as good as a cubic block decomposition (METIS measured within
3 % of balance); network latency independent of distance; no overlap of
communication with computation (the current design); the cluster figures use
--alpha (default 1.5 us, a typical InfiniBand MPI latency) and --beta
(default 10 GB/s).

Usage: python3 analysis/scaling_model.py --one R1.json --two R2.json
           [--latency LAT.json] [--alpha 1.5e-6] [--overhead 0.3e-6] [--beta 1e10]
           [--per-rank 100000,1000000] [--out FILE.md]
Trade-off: a closed-form model of the slowest rank, honest about what it does
not model (contention, topology, jitter); it says where the design runs out
of computation to hide its ~170 synchronisations a step.
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


class Model:
    def __init__(self, one, two, lat, args):
        steps1, steps2 = one["steps"], two["steps"]
        self.n1 = one["bodies"]
        self.c = one.get("steps_wall_s", one["wall_s"]) / steps1 / self.n1                  # s per catom per step
        par = two["parallel"]
        self.ghosts2 = par["ghost_fraction"] * two["bodies"] / 2   # per rank, one face
        comm2 = par["comm_seconds"]["max"] / steps2
        compute2 = two.get("steps_wall_s", two["wall_s"]) / steps2 - comm2
        owned2 = two["bodies"] / 2
        self.phi = max(0.0, (compute2 / self.c - owned2) / max(self.ghosts2, 1.0))
        self.bytes2 = par["comm_bytes"] / steps2 / 2               # per rank per step
        self.rounds = 8 * (one["solver"]["iterations"] + 1)
        self.messages2 = par["messages_per_step"]
        self.imbalance = max(1.0, par.get("partition_imbalance", 1.0))
        self.observe_every = 10
        self.local_alpha = lat["exchange_round_s"][0] if lat else 5e-6
        self.alpha, self.o, self.beta = args.alpha, args.overhead, args.beta

    def ghosts(self, n, r):
        return self.ghosts2 * faces(r) * (n / (self.n1 / 2)) ** (2 / 3) if r > 1 else 0.0

    def step(self, n, r, alpha, o, beta):
        if r == 1:
            return self.c * n, 0.0
        compute = self.imbalance * self.c * (n + self.phi * self.ghosts(n, r))
        nb, lg = neighbours(r), math.log2(r)
        comm = self.rounds * (alpha + nb * o)
        comm += self.bytes2 * faces(r) * (n / (self.n1 / 2)) ** (2 / 3) / beta
        comm += 3 * (alpha * lg + nb * o)
        comm += (1 + 12 / self.observe_every) * 2 * alpha * lg
        return compute + comm, comm

    def table(self, per_rank):
        lines = []
        for label, alpha, o, beta in (("this machine (shared memory)", self.local_alpha, 0.1e-6, 5e9),
                                      (f"cluster (alpha {self.alpha * 1e6:.1f} us, {self.o * 1e6:.1f} us per partner, "
                                       f"{self.beta / 1e9:.0f} GB/s)", self.alpha, self.o, self.beta)):
            lines += [f"\n### {label}\n", "| catoms/rank | " + " | ".join(f"R={r}" for r in RANKS) + " |",
                      "|---|" + "---|" * len(RANKS)]
            for n in per_rank:
                t1, _ = self.step(n, 1, alpha, o, beta)
                cells = []
                for r in RANKS:
                    t, comm = self.step(n, r, alpha, o, beta)
                    cells.append(f"{t1 / t:.2f} ({100 * comm / t:.0f} % comm)")
                lines.append(f"| {n:,} | " + " | ".join(cells) + " |")
            lines.append("")
            lines.append(self.limit(alpha, o, beta))
        return "\n".join(lines)

    def limit(self, alpha, o, beta):
        """Smallest catoms per rank at which communication stays under 20 % at R = 4096."""
        n = 1000
        while n < 1e9:
            t, comm = self.step(n, 4096, alpha, o, beta)
            if comm / t < 0.2:
                return (f"Below about {n:,} catoms per rank (R = 4096) the ~{self.rounds} synchronisations a step "
                        "take more than 20 % of the step: there the design needs fewer of them (overlap interior "
                        "cells with the boundary exchange, or exchange once per sweep with a boundary-first order).")
            n = int(n * 1.25)
        return "communication dominates at every size"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--one", required=True, help="run report of 1 rank")
    ap.add_argument("--two", required=True, help="run report of 2 ranks, same scene and size")
    ap.add_argument("--latency", help="JSON of `parode latency --json` (mpiexec -n 2)")
    ap.add_argument("--alpha", type=float, default=1.5e-6, help="cluster latency of an exchange round (s)")
    ap.add_argument("--overhead", type=float, default=0.3e-6, help="cluster cost per extra partner (s)")
    ap.add_argument("--beta", type=float, default=1e10, help="cluster bandwidth (bytes/s)")
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
            f"- compute: {m.c * 1e9:.0f} ns per catom per step (1 rank x {one['threads']} thread(s)); "
            f"a ghost costs {m.phi:.2f} of an owned catom",
            f"- two ranks: {m.ghosts2:,.0f} ghosts per rank (one face), {m.bytes2 / 1e6:.2f} MB sent per rank per step, "
            f"{m.messages2:.0f} messages per rank per step ({m.rounds} solver rounds expected)",
            f"- exchange round on this machine: {m.local_alpha * 1e6:.2f} us"
            + (f"; ping-pong {lat['ping_pong_s'][0] * 1e6:.2f} us one way" if lat else " (assumed: no --latency)"),
            "- efficiency = T(1) / T(R) with the same catoms per rank; in brackets the share of the step spent "
            "communicating",
            "- assumes a cubic block decomposition, uniform density, no overlap of communication and computation"]
    text = "\n".join(head) + "\n" + m.table([int(x) for x in a.per_rank.split(",")]) + "\n"
    print(text)
    if a.out:
        with open(a.out, "w") as f:
            f.write(text)


if __name__ == "__main__":
    main()
