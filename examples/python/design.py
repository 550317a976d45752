#!/usr/bin/env python3
"""Inverse design with the reduced model: which load brings the body's tip to a target position at the end time?

The target is the tip's position in a full-order run at --target parameters. A cross-entropy search (a population
method in NumPy) rolls out --population candidates per iteration in one RolloutBatch, decodes each candidate's tip
at the end time, and refits its sampling distribution to the best tenth; the answer is then checked with one
full-order run. Prints one JSON object on stdout (the answer, its full-order error as a fraction of the body's
height, the loop's wall time with the reduced model and the same loop's estimated with the full-order model, from
the check run's own time); progress goes to stderr. docs/python.md shows it on the poke cylinder.

  python examples/python/design.py MODEL.h5 scenes/poke_cylinder.toml --target rho=1.15 theta=6 phi=11
"""

import argparse
import json
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import h5py
import numpy as np

import mpmrom


def log(text):
    print(f"design: {text}", file=sys.stderr, flush=True)


def design_bounds(scene_path, names):
    """Each parameter's range in the scene's [design]: the box the model was trained on."""
    design = tomllib.loads(Path(scene_path).read_text())["design"]
    return np.array([[min(design[n]), max(design[n])] for n in names], dtype=float)


def tip_point(X):
    """The reference point at the body's top nearest its vertical axis."""
    top = X[:, 2] >= X[:, 2].max() - 1e-9
    centre = X[:, :2].mean(axis=0)
    candidates = np.flatnonzero(top)
    return X[candidates[np.argmin(np.linalg.norm(X[candidates, :2] - centre, axis=1))]]


def full_order_tip(scene, names, values, tip, work):
    """The point at `tip` (a reference point of the run) at the end time of a full-order run, and the run's time."""
    out = Path(work) / f"fom_{len(list(Path(work).glob('fom_*.h5')))}.h5"
    start = time.perf_counter()
    mpmrom.simulate(scene, out, set=dict(zip(names, (float(v) for v in values))), progress=lambda line: None)
    seconds = time.perf_counter() - start
    with h5py.File(out, "r") as f:
        X = f["reference/X"][...]
        point = int(np.argmin(np.linalg.norm(X - tip, axis=1)))
        return f["x"][-1, point, :], seconds


def search(rom, bounds, tip, target, population, iterations, seed):
    """Cross-entropy method on the unit box: sample, roll out, keep the best tenth, refit mean and spread."""
    rng = np.random.default_rng(seed)
    low, span = bounds[:, 0], bounds[:, 1] - bounds[:, 0]
    mean, spread = np.full(len(bounds), 0.5), np.full(len(bounds), 0.3)
    elite = max(2, population // 10)
    best, best_miss, rollouts = mean, np.inf, 0
    for iteration in range(iterations):
        unit = np.clip(mean + spread * rng.standard_normal((population, len(bounds))), 0.0, 1.0)
        with rom.batch(low + span * unit) as batch:
            batch.run()
            ends = batch.positions(tip[None, :])[:, 0, :]
            running = batch.running()
        rollouts += population
        miss = np.where(running, np.linalg.norm(ends - target, axis=1), np.inf)
        order = np.argsort(miss)[:elite]
        if miss[order[0]] < best_miss:
            best, best_miss = unit[order[0]], miss[order[0]]
        mean, spread = unit[order].mean(axis=0), unit[order].std(axis=0) + 1e-4
        log(f"iteration {iteration + 1}/{iterations}: best miss {best_miss:.3e} m, spread {spread.max():.2e}")
    return low + span * best, best_miss, rollouts


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("model")
    parser.add_argument("scene")
    parser.add_argument("--target", nargs="+", required=True, metavar="NAME=VALUE",
                        help="every parameter of the full-order run whose tip position is the target")
    parser.add_argument("--population", type=int, default=1024)
    parser.add_argument("--iterations", type=int, default=12)
    parser.add_argument("--method", choices=["point", "node", "galerkin"], default="point",
                        help="the reduced step, with its measured defaults (mpmrom.RomSettings.defaults)")
    parser.add_argument("--samples", type=int, default=15, help="the reduced model's sample points")
    parser.add_argument("--cfl", type=float, default=0.0,
                        help="the reduced step's CFL number (0: the scene's; the Galerkin step's own bound caps it)")
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()

    start = time.perf_counter()
    rom = mpmrom.ReducedModel(args.model, args.scene, method=args.method, samples=args.samples, cfl=args.cfl)
    setup_seconds = time.perf_counter() - start
    names = rom.parameter_names
    given = dict(item.split("=", 1) for item in args.target if "=" in item)
    if sorted(given) != sorted(names) or len(given) != len(args.target):
        parser.error(f"--target needs NAME=VALUE for each of {', '.join(names)}")
    target_values = [float(given[n]) for n in names]
    X = rom.reference_points
    height = float(X[:, 2].max() - X[:, 2].min())
    tip = tip_point(X)
    with tempfile.TemporaryDirectory() as work:
        target, _ = full_order_tip(args.scene, names, target_values, tip, work)
        log(f"target: tip at {np.round(target, 5).tolist()} m (full-order run at {' '.join(args.target)})")
        start = time.perf_counter()
        found, rom_miss, rollouts = search(rom, design_bounds(args.scene, names), tip, target, args.population,
                                           args.iterations, args.seed)
        loop_seconds = time.perf_counter() - start
        reached, fom_seconds = full_order_tip(args.scene, names, found, tip, work)
    error = float(np.linalg.norm(reached - target))
    print(json.dumps({
        "parameter_names": names,
        "target_parameters": target_values,
        "found_parameters": found.tolist(),
        "tip_reference": tip.tolist(),
        "target_tip": target.tolist(),
        "full_order_tip_at_found": reached.tolist(),
        "reduced_miss_m": float(rom_miss),
        "full_order_miss_m": error,
        "full_order_miss_of_height": error / height,
        "method": args.method,
        "samples": args.samples,
        "cfl": args.cfl,
        "rollouts": rollouts,
        "setup_seconds_reduced": setup_seconds,
        "loop_seconds_reduced": loop_seconds,
        "full_order_run_seconds": fom_seconds,
        "loop_seconds_full_order_estimate": fom_seconds * rollouts,
        "runtime": mpmrom.runtime_info(),
    }, indent=2))


if __name__ == "__main__":
    main()
