#!/usr/bin/env python3
"""Rollout-steps/s against batch size, every record of one scene on the same axes (GPU, CPU and the PyTorch peer).

Usage: perf/plot_batch.py SCENE [RESULTS_DIR]   ->  RESULTS_DIR/rom_batch_SCENE.{gp,png,svg}
Reads RESULTS_DIR/rom_batch_SCENE_*.json (perf/run_batch_bench.sh) and peer_rom_batch_SCENE_*.json
(perf/peers/rom_step_torch.py); draws with gnuplot, as the tool's own charts do.
"""
import glob
import json
import os
import subprocess
import sys


METHODS = {"point": "Algorithm 1", "node": "Algorithm 2", "galerkin": "Galerkin step"}


def label(record):
    settings = record.get("settings", {})
    method = METHODS.get(record.get("method") or settings["method"])
    samples = record.get("samples", settings.get("samples"))
    who = "PyTorch peer" if "pytorch" in record["benchmark"] else "mpmrom"
    backend = record.get("backend", "")
    return "%s %s (%s samples), %s %s, %s" % (who, method, samples, record["device"], backend, record["precision"])


def main():
    scene = sys.argv[1]
    results = sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(__file__), "results")
    paths = sorted(glob.glob(os.path.join(results, "rom_batch_%s_*.json" % scene)) +
                   glob.glob(os.path.join(results, "peer_rom_batch_%s_*.json" % scene)))
    if not paths:
        sys.exit("no records for %s in %s" % (scene, results))
    blocks, plots = [], []
    for i, path in enumerate(paths):
        record = json.load(open(path))
        points = [p for p in record["points"] if p.get("rom_rollout_steps_per_s", 0) > 0]  # errors, out of memory: no point
        blocks.append("$s%d << EOD\n%s\nEOD" % (i, "\n".join("%d %.9g" % (p["batch"], p["rom_rollout_steps_per_s"])
                                                             for p in points)))
        dash = " dt 2" if "pytorch" in record["benchmark"] else ""
        plots.append("$s%d using 1:2 with linespoints lw 2%s title \"%s\"" % (i, dash, label(record)))
    base = os.path.join(results, "rom_batch_%s" % scene)
    body = "\n".join([
        "set title \"Batch rollouts, %s: rollout-steps/s against batch size\"" % scene,
        "set xlabel \"rollouts in the batch\"", "set ylabel \"rollout-steps per second\"",
        "set logscale x", "set logscale y", "set termoption noenhanced", "set grid", "set key below",
        "set format y \"%.0e\"",
        *blocks, "plot " + ", \\\n     ".join(plots)])
    with open(base + ".gp", "w") as f:
        f.write("set terminal pngcairo size 1000,700\nset output \"%s.png\"\n%s\n" % (os.path.basename(base), body))
    for terminal, ext in (("pngcairo size 1000,700", "png"), ("svg size 1000,700", "svg")):
        script = "set terminal %s\nset output \"%s.%s\"\n%s\n" % (terminal, base, ext, body)
        subprocess.run(["gnuplot"], input=script, text=True, check=True)
    print(base + ".png")


if __name__ == "__main__":
    main()
