#!/usr/bin/env python3
"""Pictures of a run's spheres at chosen steps, one panel per step.

Reads body positions from a snapshot CSV (`parode run --snapshot FILE.csv
--snapshot-every K`: step,body,x,y,z,qw,qx,qy,qz) or a trajectory file
(`--trajectory FILE`, which also holds step 0 and every observed step), and
draws each chosen step as spheres in 3D, seen from the side and slightly from
above, coloured by height, on equal axes shared by every panel (so a collapse
reads as one picture). --save-frames writes the chosen steps as a compact CSV
(step,body,x,y,z) that this script reads again, so a committed picture is
rebuilt from a small committed file.

Usage:
  python3 analysis/scene_pictures.py RUN.traj|SNAP.csv --steps 0,500,1000 --out tennis.png
          [--radius 0.5] [--title TEXT] [--save-frames FRAMES.csv]
  --steps last: the last step in the file.
Trade-off: spheres are drawn as scatter markers scaled to the radius at the
panel's scale, depth-sorted but not shaded: exact enough to see a prism hold
or fall, cheap enough for 10^5 bodies; box, capsule and wheel shapes are drawn
as spheres of --radius too (the buggy has buggy_path.py).
"""
import argparse
import json
import os
import sys

import numpy as np

TRAJECTORY_MAGIC = b"parode-trajectory 1 "
FRAME_HEADER = 16  # doubles before the positions of a trajectory frame


def read_trajectory(path):
    """{step: (n, 3) positions} of every frame of a trajectory file."""
    with open(path, "rb") as f:
        line = f.readline()
        if not line.startswith(TRAJECTORY_MAGIC):
            raise ValueError(f"{path}: not a parode trajectory file")
        meta = json.loads(line[len(TRAJECTORY_MAGIC):])
        data = np.fromfile(f, dtype="<f8")
    n = len(meta.get("catom_mask", ""))
    size = FRAME_HEADER + 3 * n
    if n == 0 or data.size % size:
        raise ValueError(f"{path}: {data.size} doubles are not whole frames of {n} bodies")
    frames = data.reshape(-1, size)
    return {int(fr[0]): fr[FRAME_HEADER:].reshape(n, 3) for fr in frames}


def read_csv(path):
    """{step: (n, 3) positions} of a snapshot CSV or a --save-frames CSV."""
    table = np.genfromtxt(path, delimiter=",", names=True)
    if table.size == 0 or not {"step", "body", "x", "y", "z"} <= set(table.dtype.names):
        raise ValueError(f"{path}: expected columns step,body,x,y,z")
    out = {}
    for step in np.unique(table["step"]):
        rows = table[table["step"] == step]
        rows = rows[np.argsort(rows["body"])]
        out[int(step)] = np.column_stack([rows["x"], rows["y"], rows["z"]])
    return out


def read_frames(path):
    with open(path, "rb") as f:
        head = f.read(len(TRAJECTORY_MAGIC))
    return read_trajectory(path) if head == TRAJECTORY_MAGIC else read_csv(path)


def choose(frames, spec):
    if spec == "last":
        return [max(frames)]
    steps = [int(s) for s in spec.split(",")]
    missing = [s for s in steps if s not in frames]
    if missing:
        shown = sorted(frames)
        listing = f"{shown[:5]} ... {shown[-3:]}" if len(shown) > 8 else f"{shown}"
        raise ValueError(f"steps {missing} are not in the file (it has {len(shown)} steps: {listing})")
    return steps


def save_frames(path, frames, steps):
    with open(path, "w") as f:
        f.write("step,body,x,y,z\n")
        for s in steps:
            for b, (x, y, z) in enumerate(frames[s]):
                f.write(f"{s},{b},{x:.6g},{y:.6g},{z:.6g}\n")


AZIM, ELEV = -60, 22  # the view: from the front left, a little above


def marker_area(fig, ax, centre, radius):
    """Scatter marker area (points^2) of a sphere of `radius` at `centre`: the
    screen distance between two points a diameter apart across the view."""
    from mpl_toolkits.mplot3d import proj3d
    fig.canvas.draw()  # fixes the panel's projection
    across = np.array([-np.sin(np.radians(AZIM)), np.cos(np.radians(AZIM)), 0.0])
    ends = []
    for sign in (-1, 1):
        x, y, _ = proj3d.proj_transform(*(centre + sign * radius * across), ax.get_proj())
        ends.append(ax.transData.transform((x, y)))
    return (np.linalg.norm(ends[1] - ends[0]) * 72 / fig.dpi) ** 2


def draw(frames, steps, radius, dt, title, out):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator
    allpos = np.vstack([frames[s] for s in steps])
    lo, hi = allpos.min(axis=0) - radius, allpos.max(axis=0) + radius
    lo[2] = min(lo[2], 0.0)
    flat = float(max(hi[0] - lo[0], hi[1] - lo[1]))  # x and y share one span; z keeps its own
    tall = float(hi[2] - lo[2])
    centre = (lo + hi) / 2
    fig = plt.figure(figsize=(4.6 * len(steps), 3.8))
    axes = [fig.add_subplot(1, len(steps), k + 1, projection="3d") for k in range(len(steps))]
    for ax, s in zip(axes, steps):
        ax.set_xlim(centre[0] - flat / 2, centre[0] + flat / 2)
        ax.set_ylim(centre[1] - flat / 2, centre[1] + flat / 2)
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect((flat, flat, tall), zoom=1.2)
        ax.zaxis.set_major_locator(MaxNLocator(3))
        ax.view_init(elev=ELEV, azim=AZIM)
        when = f", t = {s * dt:g} s" if dt else ""
        ax.set(title=f"step {s}{when}", xlabel="x (m)", ylabel="y (m)", zlabel="z (m)")
    if title:
        fig.suptitle(title, fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.95) if title else None)  # before the marker sizes are measured
    a, e = np.radians(AZIM), np.radians(ELEV)
    eye = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    for ax, s in zip(axes, steps):
        p = frames[s]
        order = np.argsort(p @ eye)  # far spheres first, near ones drawn over them
        ax.scatter(p[order, 0], p[order, 1], p[order, 2], c=p[order, 2], cmap="viridis",
                   s=marker_area(fig, ax, centre, radius), vmin=lo[2], vmax=hi[2], depthshade=False,
                   edgecolors="k", linewidths=0.2)
    fig.savefig(out, dpi=110)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("input", help="trajectory file, snapshot CSV or --save-frames CSV")
    ap.add_argument("--steps", default="last", help="comma-separated steps, or 'last' (default)")
    ap.add_argument("--out", required=True, help="picture file (.png)")
    ap.add_argument("--radius", type=float, default=0.5, help="sphere radius (m), default 0.5")
    ap.add_argument("--dt", type=float, default=0.0, help="time step (s), to label panels with the time")
    ap.add_argument("--title", default="")
    ap.add_argument("--save-frames", help="also write the chosen steps as CSV (step,body,x,y,z)")
    a = ap.parse_args()
    try:
        frames = read_frames(a.input)
        steps = choose(frames, a.steps)
    except (OSError, ValueError) as e:
        print(f"scene_pictures: {e}", file=sys.stderr)
        sys.exit(2)
    if a.save_frames:
        save_frames(a.save_frames, frames, steps)
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    draw(frames, steps, a.radius, a.dt, a.title, a.out)
    print(f"scene_pictures: steps {steps} of {a.input} -> {a.out}")


if __name__ == "__main__":
    main()
