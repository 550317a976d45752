#!/usr/bin/env python3
"""Largest differences between two mpmrom outputs of the same run (two snapshots or two ROM files), e.g. the same
scene on two backends: per field, max |a - b| over all points and frames, absolute and relative to the field's
largest magnitude, and in units of the precision's epsilon. Used for the cross-backend bound in docs/reliability.md.

Usage: scripts/compare_outputs.py A.h5 B.h5
"""
import sys

import h5py
import numpy as np


def fields(path):
    with h5py.File(path, "r") as f:
        kind = f.attrs["format"]
        kind = kind.decode() if isinstance(kind, bytes) else kind
        precision = f.attrs["precision"]
        precision = precision.decode() if isinstance(precision, bytes) else precision
        if kind == "mpmrom-snapshot":
            return kind, precision, {name: f[name][...] for name in ("x", "v", "F")}
        if kind == "mpmrom-rom":
            return kind, precision, {name: f["latent/" + name][...] for name in ("xhat", "xhatdot")}
        sys.exit("compare_outputs: %s: not a snapshot or ROM file (%s)" % (path, kind))


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    kind_a, precision, a = fields(sys.argv[1])
    kind_b, _, b = fields(sys.argv[2])
    if kind_a != kind_b:
        sys.exit("compare_outputs: the files are of different kinds")
    eps = np.finfo(np.float32 if precision == "float" else np.float64).eps
    for name in a:
        if a[name].shape != b[name].shape:
            sys.exit("compare_outputs: %s has shapes %s and %s" % (name, a[name].shape, b[name].shape))
        diff = np.abs(a[name].astype(np.float64) - b[name].astype(np.float64))
        scale = np.abs(a[name]).max()
        worst = diff.max()
        where = np.unravel_index(diff.argmax(), diff.shape)
        print("%-8s max |a - b| = %.3e at %s, largest |a| = %.3e: %.3e relative = %.1f eps (%s)"
              % (name, worst, tuple(int(i) for i in where), scale, worst / scale if scale else 0.0,
                 worst / scale / eps if scale else 0.0, precision))


main()
