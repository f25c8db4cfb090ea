"""Tables of bench.sh's runs: the fullest rank's peak memory with and without
`gradient` at 50,000 catoms a rank (medians over the turns), and the program
pass's time at 10^5 catoms, before and after.
Usage: python3 table.py [RUNS_DIR]   (default: runs/ beside this file)"""
import glob
import json
import os
import statistics
import sys

RUNS = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "runs")


def reports(pattern):
    return [json.load(open(f)) for f in sorted(glob.glob(os.path.join(RUNS, pattern)))]


def held(r):
    f = r["memory"].get("fullest")
    return f["owned"] + f["ghosts"] if f else r["bodies"]


def memory_table():
    print("| ranks | build | peak MiB, none | peak MiB, gradient | the program's part | held (fullest rank) | bytes a held body, gradient | growth over 1 rank | same hash |")
    print("|---|---|---|---|---|---|---|---|---|")
    base = {}
    for r in (1, 2, 4, 8):
        for b in ("before", "after"):
            none = reports(f"mem-{b}-none-r{r}-t*.json")
            grad = reports(f"mem-{b}-gradient-r{r}-t*.json")
            if not none or not grad:
                continue
            mn = statistics.median(x["memory"]["peak_rss_bytes"]["max"] for x in none) / 2**20
            mg = statistics.median(x["memory"]["peak_rss_bytes"]["max"] for x in grad) / 2**20
            h = statistics.median(held(x) for x in grad)
            per = statistics.median(x["memory"]["peak_rss_bytes"]["max"] / held(x) for x in grad)
            base.setdefault(b, per)
            other = reports(f"mem-{'after' if b == 'before' else 'before'}-gradient-r{r}-t*.json")
            same = {x["state_hash"] for x in grad} == {x["state_hash"] for x in other} and len({x["state_hash"] for x in grad}) == 1
            print(f"| {r} | {b} | {mn:.1f} | {mg:.1f} | {mg - mn:.1f} | {h:,.0f} | {per:,.0f} | {100 * (per / base[b] - 1):+.1f} % | {'yes' if same else 'no'} |")


def speed_table():
    print("| layout | program ms a step before | after | ratio | step ms before | after | same hash |")
    print("|---|---|---|---|---|---|---|")
    for lay in ("1x1", "1x2", "2x1"):
        rows = {}
        for b in ("before", "after"):
            rs = reports(f"speed-{b}-{lay}-t*.json")
            if not rs:
                continue
            prog = statistics.median(1e3 * x["program"]["seconds"] / x["steps"] for x in rs)
            step = statistics.median(x["ms_per_step"] for x in rs)
            rows[b] = (prog, step, {x["state_hash"] for x in rs})
        if len(rows) < 2:
            continue
        (pb, sb, hb), (pa, sa, ha) = rows["before"], rows["after"]
        print(f"| {lay} | {pb:.2f} | {pa:.2f} | {pa / pb:.3f} | {sb:.1f} | {sa:.1f} | {'yes' if hb == ha and len(hb) == 1 else 'no'} |")


memory_table()
print()
speed_table()
