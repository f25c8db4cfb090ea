#!/usr/bin/env python3
"""The table of this series from its reports (DIR/run1, run2, ...: the same
runs repeated, interleaved): per configuration the state hash (the same in
every repetition, or the table says so), and medians over the repetitions of
ms a step, the program pass's ms a step and share of the step (whole run, and
the steps after the first), memory and the pass's parts; messages a step and
listings (the same in every repetition).
Usage: table.py DIR"""
import json
import os
import statistics
import sys


def load(d, f):
    p = os.path.join(d, f)
    return json.load(open(p)) if os.path.exists(p) else None


def bytes_a_catom(r, catoms):
    m = r["memory"]["peak_rss_bytes"]
    return m["avg"] * r.get("ranks", 1) / catoms  # every process's memory


def one(d, prog, n, lay):
    r = load(d, f"{prog}-{n}-{lay}.json")
    if not r:
        return None
    base = load(d, f"none-{n}-{lay}.json") or load(d, f"none-{n}-1x2.json")
    p = r["program"]
    steps = p["steps"]
    total = sum(r["stages"].values())
    first = r["first_step"]
    first_prog = first["substages"]["forces"]["program"]
    return {
        "hash": r["state_hash"], "ms": r["ms_per_step"], "prog": p["seconds"] * 1000 / steps,
        "share": 100 * p["seconds"] / total,
        "after": 100 * (p["seconds"] - first_prog) / (total - sum(first["stages"].values())),
        "messages": p["messages_per_step"], "mem": bytes_a_catom(r, p["catoms"]),
        "base": bytes_a_catom(base, p["catoms"]) if base else None, "lists": p["neighbour_listings"],
        "parts": {k: v["max"] * 1000 / steps for k, v in p["parts_s"].items()},
    }


def row(runs, prog, n, lay):
    got = [x for x in (one(d, prog, n, lay) for d in runs) if x]
    if not got:
        return None
    med = lambda key: statistics.median(g[key] for g in got)
    hashes = sorted({g["hash"] for g in got})
    base = f" ({statistics.median(g['base'] for g in got):,.0f})" if got[0]["base"] else ""
    parts = ", ".join(f"{k} {statistics.median(g['parts'][k] for g in got):.1f}" for k in got[0]["parts"])
    return (f"| {prog} {n}, {lay.replace('x', ' x ')} | {' / '.join(hashes)} | {med('ms'):,.1f} | "
            f"{med('prog'):.1f} | {med('share'):.1f} % | {med('after'):.1f} % | "
            f"{got[0]['messages']:.1f} | {got[0]['messages'] * 1000 / med('ms'):,.0f} | {med('mem'):,.0f}{base} | {got[0]['lists']} | {parts} |")


def main():
    d = sys.argv[1]
    runs = sorted(os.path.join(d, r) for r in os.listdir(d) if r.startswith("run") and os.path.isdir(os.path.join(d, r)))
    print(f"medians of {len(runs)} runs each")
    print("| run | state hash | ms a step | program, ms a step | share | share after the first step | "
          "messages a step | messages a second | bytes a catom (none) | listings | parts, ms a step (slowest process) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for n in ("1e5", "1e6"):
        for prog in ("gradient", "sculpt"):
            for lay in ("1x1", "1x2", "1x3", "2x1", "3x1"):
                line = row(runs, prog, n, lay)
                if line:
                    print(line)


if __name__ == "__main__":
    main()
