#!/usr/bin/env python3
"""The README's scene-file reference is the code's table: the lines between
`<!-- scene-keys:begin -->` and `<!-- scene-keys:end -->` in README.md must
equal what `parode keys` prints (src/scene/scene_keys.cpp, the table the
reader takes its keys from). Exits 1 naming the first line that differs;
with --update, writes the table into the README instead. The README stays
within its line budget (--max-lines, default 600).

Usage: readme_keys.py PARODE README.md [--update] [--max-lines N]
Trade-off: an exact text comparison (regenerate with --update after changing
the table) rather than a parse of the Markdown: simple, and any drift shows.
"""
import argparse
import subprocess
import sys

BEGIN, END = "<!-- scene-keys:begin -->", "<!-- scene-keys:end -->"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("parode")
    ap.add_argument("readme")
    ap.add_argument("--update", action="store_true")
    ap.add_argument("--max-lines", type=int, default=600)
    a = ap.parse_args()
    table = subprocess.run([a.parode, "keys"], check=True, capture_output=True, text=True).stdout
    text = open(a.readme, encoding="utf-8").read()
    if BEGIN not in text or END not in text:
        print(f"{a.readme}: the markers {BEGIN} and {END} are missing")
        return 1
    head, rest = text.split(BEGIN, 1)
    body, tail = rest.split(END, 1)
    if a.update:
        text = head + BEGIN + "\n" + table + END + tail
        open(a.readme, "w", encoding="utf-8").write(text)
    elif body.strip("\n") != table.strip("\n"):
        have, want = body.strip("\n").split("\n"), table.strip("\n").split("\n")
        for i in range(max(len(have), len(want))):
            h = have[i] if i < len(have) else "(nothing)"
            w = want[i] if i < len(want) else "(nothing)"
            if h != w:
                print(f"{a.readme}: scene-file reference line {i + 1} is\n  {h}\nwhile `parode keys` prints\n  {w}")
                break
        print(f"regenerate it: python3 tests/support/readme_keys.py {a.parode} {a.readme} --update")
        return 1
    lines = text.count("\n")
    if lines > a.max_lines:
        print(f"{a.readme}: {lines} lines, more than the user's guide's budget of {a.max_lines}")
        return 1
    print(f"{a.readme}: the scene-file reference is the code's table; {lines} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())
