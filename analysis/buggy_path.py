#!/usr/bin/env python3
"""Path of the buggy's chassis seen from above, from a `parode run --snapshot` CSV.

Draws the chassis path (coloured by time), its start, the footprint of every
static box of the scene above the floor (the ramp), and the points where the driver's schedule
ends each half figure eight (the crossing and the end of the eight), and prints
the chassis' distance from its start at each of them.
The schedule is the one of src/forces/controller.cpp, recomputed here from the
scene's [controller] table: track distance
wheel_radius * (mid t + amp P / 2 pi (1 - cos(2 pi t / P))), an eight every
4 pi radius metres.
Trade-off: reads the scene file as written; a run with --set overrides of the
scene, the controller or dt needs the same values passed here (--dt) or a copy
of the scene with them.

Usage: python3 analysis/buggy_path.py SNAPSHOT.csv [--scene jobs/scenes/buggy.toml]
                                      [--body 0] [--dt S] [--out buggy_path.png]
"""
import argparse
import math
import os
import sys
import tomllib

import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def rotation(spec):
    """3x3 matrix of a scene `rotation = {axis, angle}` (Rodrigues)."""
    if not spec:
        return np.eye(3)
    a = np.asarray(spec["axis"], float)
    a /= np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    t = spec["angle"]
    return np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * k @ k


def cross(o, a, b):
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])


def hull(points):
    """Convex hull of 2-D points (monotone chain), anticlockwise."""
    pts = sorted(map(tuple, points))

    def half(seq):
        out = []
        for p in seq:
            while len(out) >= 2 and cross(out[-2], out[-1], p) <= 0:
                out.pop()
            out.append(p)
        return out[:-1]
    return np.array(half(pts) + half(pts[::-1]))


def above_floor(corners):
    """Vertices of a box's part above the floor z = 0: corners above it and edge crossings."""
    out = [p for p in corners if p[2] >= 0]
    for i in range(8):
        for j in range(i + 1, 8):
            a, b = corners[i], corners[j]
            if bin(i ^ j).count("1") == 1 and (a[2] < 0) != (b[2] < 0):  # an edge crossing the floor
                out.append(a + (b - a) * (a[2] / (a[2] - b[2])))
    return np.array(out)


def box_footprints(scene):
    """(name, polygon) of every static box's part above the floor, seen from above."""
    out = []
    for s in scene.get("statics", []):
        if s.get("shape") != "box":
            continue
        half = np.asarray(s["size"], float) / 2
        corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
        world = above_floor(corners @ rotation(s.get("rotation")).T + np.asarray(s.get("position", [0, 0, 0]), float))
        if len(world) >= 3:
            out.append((s.get("name", "static"), hull(world[:, :2])))
    return out


def schedule_distance(c, t):
    """Track metres the controller's speed schedule covers in t seconds."""
    lo, hi, period = c.get("speed_min", 5.0), c.get("speed_max", 15.0), c.get("speed_period", 20.0)
    mid, amp = (lo + hi) / 2, (hi - lo) / 2
    return c.get("wheel_radius", 0.18) * (mid * t + amp * period / (2 * math.pi) * (1 - np.cos(2 * math.pi * t / period)))


def half_eight_times(c, t_end):
    """Times at which the schedule ends each half figure eight, up to t_end."""
    if c.get("type", "figure-eight") != "figure-eight":
        return []
    half = 2 * math.pi * c.get("radius", 2.0)
    t = np.linspace(0, t_end, 200001)
    s = schedule_distance(c, t)
    return [float(t[np.searchsorted(s, k * half)]) for k in range(1, int(s[-1] // half) + 1)]


def fail(message):
    print(f"buggy_path: {message}", file=sys.stderr)
    sys.exit(2)


def load_path(csv, body):
    if not os.path.isfile(csv):
        fail(f"no such file: {csv}")
    d = np.genfromtxt(csv, delimiter=",", names=True)
    if d.size == 0 or d.dtype.names is None or not {"step", "body", "x", "y"} <= set(d.dtype.names):
        fail(f"{csv} is not a parode snapshot CSV (columns step,body,x,y,z,qw,qx,qy,qz)")
    d = np.atleast_1d(d)
    c = d[d["body"] == body]
    if c.size == 0:
        fail(f"{csv} has no rows for body {body}")
    return c


def plot(path, scene, args, marks, start):
    fig, ax = plt.subplots(figsize=(6.5, 7))
    for name, poly in box_footprints(scene):
        ax.fill(poly[:, 0], poly[:, 1], color="0.85", edgecolor="0.4", zorder=1)
        ax.annotate(name, poly.mean(axis=0), ha="center", va="center", fontsize=8, color="0.3")
    t = path["step"] * args.dt
    sc = ax.scatter(path["x"], path["y"], c=t, s=2, cmap="viridis", zorder=2)
    fig.colorbar(sc, ax=ax, label="time (s)", shrink=0.7)
    ax.plot(*start, "r*", markersize=14, zorder=4, label="start")
    if marks:
        ax.plot([m[1] for m in marks], [m[2] for m in marks], "kx", zorder=5,
                label="end of each half eight (schedule)")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    name = scene.get("scene", {}).get("name", "?")
    worst = max((m[3] for m in marks), default=float("nan"))
    ax.set_title(f"{name}: chassis path from above, {t[-1]:.0f} s\n"
                 f"{len(marks) // 2} figure eights, back within {worst:.2f} m of the start after each half",
                 fontsize=10)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.09), ncol=2, fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv", help="snapshot CSV of the run (parode run ... --snapshot FILE --snapshot-every K)")
    ap.add_argument("--scene", default=os.path.join(ROOT, "jobs", "scenes", "buggy.toml"))
    ap.add_argument("--body", type=int, default=0, help="body id of the chassis (default 0)")
    ap.add_argument("--dt", type=float, default=0, help="time step of the run (default: the scene's)")
    ap.add_argument("--out", default="buggy_path.png")
    args = ap.parse_args()
    try:
        scene = tomllib.load(open(args.scene, "rb"))
    except (OSError, tomllib.TOMLDecodeError) as e:
        fail(f"cannot read scene {args.scene}: {e}")
    args.dt = args.dt or scene.get("scene", {}).get("dt", 0.005)
    path = load_path(args.csv, args.body)
    bodies = scene.get("bodies", [])
    start = bodies[args.body].get("position", [0, 0, 0])[:2] if args.body < len(bodies) else (path["x"][0], path["y"][0])
    marks = []
    steps = path["step"]
    for k, tk in enumerate(half_eight_times(scene.get("controller", {}), steps[-1] * args.dt), 1):
        i = int(np.argmin(np.abs(steps * args.dt - tk)))
        dist = math.hypot(path["x"][i] - start[0], path["y"][i] - start[1])
        marks.append((k, path["x"][i], path["y"][i], dist))
        print(f"half eight {k}: t = {tk:.2f} s, chassis {dist:.3f} m from its start")
    print(f"largest distance from the start: {np.hypot(path['x'] - start[0], path['y'] - start[1]).max():.2f} m")
    plot(path, scene, args, marks, start)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
