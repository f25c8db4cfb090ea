#!/usr/bin/env python3
"""The layering of parode's sources: every #include "..." of a file in src/,
omp/ or mpi/ names a file of its own layer or of a layer below it, and the
layers of src/ form a line (no cycles). Exits 1 naming each include that runs
back up a layer. Usage: layers.py SOURCE_DIR

Trade-off: a textual check of quoted includes (what decides the build's
dependency graph); angle-bracket includes are libraries and never checked.
"""
import os
import re
import sys

# src/ folders from the bottom up: a file may include its own folder and any
# folder before it.
SRC_LAYERS = ["util", "exec", "scene", "collide", "world", "domain", "forces", "programs", "solve", "observe", "io", "run"]
# omp/ and mpi/ sit above the whole core; inside omp/ runtime/ comes first,
# the stages after it, the registration last.
OMP_LAYERS = ["runtime", "grid", "solver", "forces", "stages"]

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def src_layer(path):
    """Layer index of an include path as src/ files write it ("run/x.hpp")."""
    head = path.split("/", 1)[0]
    return SRC_LAYERS.index(head) if head in SRC_LAYERS else None


def omp_layer(rel):
    """Layer of a file under omp/ ("grid/x.cpp" or "stages.cpp")."""
    head = rel.split("/", 1)[0] if "/" in rel else "stages"
    return OMP_LAYERS.index(head)


def check_src(root, errors):
    for layer, folder in enumerate(SRC_LAYERS):
        d = os.path.join(root, "src", folder)
        for name in sorted(os.listdir(d)) if os.path.isdir(d) else []:
            text = open(os.path.join(d, name), encoding="utf-8").read()
            for inc in INCLUDE.findall(text):
                if inc.startswith(("omp/", "mpi/")):
                    errors.append(f"src/{folder}/{name}: includes {inc}: the core includes no omp/ or mpi/ file")
                    continue
                target = src_layer(inc)
                if target is None:
                    errors.append(f"src/{folder}/{name}: includes {inc}, which is in no layer of src/")
                elif target > layer:
                    errors.append(f"src/{folder}/{name}: includes {inc}: layer '{SRC_LAYERS[target]}' is above "
                                  f"'{folder}' ({' -> '.join(SRC_LAYERS)})")


def check_omp(root, errors):
    base = os.path.join(root, "omp")
    for dirpath, _, files in os.walk(base):
        for name in sorted(files):
            if not name.endswith((".hpp", ".cpp")):
                continue
            rel = os.path.relpath(os.path.join(dirpath, name), base)
            layer = omp_layer(rel)
            text = open(os.path.join(dirpath, name), encoding="utf-8").read()
            for inc in INCLUDE.findall(text):
                if inc.startswith("mpi/"):
                    errors.append(f"omp/{rel}: includes {inc}: omp/ does not depend on mpi/")
                elif inc.startswith("omp/"):
                    target = omp_layer(inc[len("omp/"):])
                    if target > layer:
                        errors.append(f"omp/{rel}: includes {inc}: '{OMP_LAYERS[target]}' is above "
                                      f"'{OMP_LAYERS[layer]}' in omp/ ({' -> '.join(OMP_LAYERS)})")
                elif "/" not in inc:
                    errors.append(f"omp/{rel}: includes \"{inc}\": omp/ files include by their path (omp/...)")


def check_mpi(root, errors):
    base = os.path.join(root, "mpi")
    for name in sorted(os.listdir(base)):
        if not name.endswith((".hpp", ".cpp")):
            continue
        text = open(os.path.join(base, name), encoding="utf-8").read()
        for inc in INCLUDE.findall(text):
            if inc.startswith("omp/"):
                errors.append(f"mpi/{name}: includes {inc}: mpi/ does not depend on omp/")


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..")
    errors = []
    check_src(root, errors)
    check_omp(root, errors)
    check_mpi(root, errors)
    for e in errors:
        print(e)
    print(f"layers: {len(errors)} include(s) against the layering" if errors else "layers: every include runs down")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
