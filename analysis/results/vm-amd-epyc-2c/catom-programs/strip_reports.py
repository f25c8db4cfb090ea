"""Keeps run reports small: drops the catom program's per-catom lists (ids,
values) from every JSON report in the folder given, rewritten sorted and indented.
Usage: python3 strip_reports.py FOLDER"""
import json
import os
import sys

out = sys.argv[1]
for f in sorted(os.listdir(out)):
    if f.endswith(".json"):
        path = os.path.join(out, f)
        r = json.load(open(path))
        p = r.get("program")
        if p:
            p.pop("ids", None)
            p.pop("values", None)
        json.dump(r, open(path, "w"), indent=1, sort_keys=True)
