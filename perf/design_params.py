#!/usr/bin/env python3
"""Writes a batch's parameter file (design.csv form) from a scene's [design]: BATCH rows cycling through its runs,
or the first run repeated with --first. Shared by the benchmark scripts in perf/.

Usage: perf/design_params.py SCENE BATCH OUT.csv [--first]
"""
import itertools
import sys
import tomllib

scene, batch, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
first_only = "--first" in sys.argv[4:]
design = tomllib.load(open(scene, "rb"))["design"]
if design["kind"] == "list":
    names, runs = design["names"], design["runs"]
else:
    names = [k for k in design if k not in ("kind", "test")]
    runs = list(itertools.product(*(design[n] for n in names)))
if first_only:
    runs = runs[:1]
with open(out, "w") as f:
    f.write(",".join(names) + "\n")
    for b in range(batch):
        f.write(",".join(str(v) for v in runs[b % len(runs)]) + "\n")
