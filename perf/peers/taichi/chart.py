#!/usr/bin/env python3
"""Particle-steps per second against the particle count, ours and Taichi's, on each device: one chart.

Usage: perf/peers/taichi/chart.py RESULTS_DIR OUT_BASE [PRECISION]
Reads RESULTS_DIR/peer_fom_*_taichi_*.json (run_peer.sh's records) of one precision (default float), groups them by
device and backend, and draws OUT_BASE.png and OUT_BASE.svg with gnuplot (as the tool's own charts): for each device
ours and the peer's best layout against the particle count, log-log. Prints one line per device on stdout: its
particle counts and the ratios ours / Taichi.
"""
import collections
import glob
import json
import os
import subprocess
import sys


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__.splitlines()[2])
    results, base = sys.argv[1], sys.argv[2]
    precision = sys.argv[3] if len(sys.argv) > 3 else "float"
    devices = collections.defaultdict(list)
    for path in glob.glob(os.path.join(results, "peer_fom_*_taichi_*.json")):
        record = json.load(open(path))
        if record["precision"] == precision:
            devices[(record["device"], record["backend"])].append(record)
    if not devices:
        sys.exit("chart.py: error: no %s peer records in %s" % (precision, results))
    blocks, plots = [], []
    for k, ((device, backend), records) in enumerate(sorted(devices.items())):
        records.sort(key=lambda r: r["particles"])
        if len({r["particles"] for r in records}) != len(records):
            sys.exit("chart.py: error: two %s %s records of one particle count" % (device, backend))
        rows = "\n".join("%d %.9g %.9g" % (r["particles"], r["fom_particle_steps_per_s"],
                                           r["peer_particle_steps_per_s"]) for r in records)
        blocks.append("$d%d << EOD\n%s\nEOD" % (k, rows))
        threads = {r.get("threads") for r in records}  # a CPU's thread count names the run; a GPU's does not
        suffix = ", %s threads" % threads.pop() if backend != "Cuda" and len(threads) == 1 else ""
        where = "%s (%s%s)" % (device, backend, suffix)
        plots.append("$d%d using 1:2 with linespoints lw 2 lc %d pt 7 title \"mpmrom, %s\"" % (k, k + 1, where))
        plots.append("$d%d using 1:3 with linespoints lw 2 lc %d dt 2 pt 6 title \"Taichi 1.7.4, %s\"" %
                     (k, k + 1, where))
        print("%s: particles %s, ours / Taichi %s" % (where, [r["particles"] for r in records],
                                                    ["%.2f" % r["ratio_vs_peer"] for r in records]))
    counts = [r["particles"] for records in devices.values() for r in records]
    body = "\n".join([
        "set title \"Full-order MPM step, %s: mpmrom against Taichi on the same scenes\"" % precision,
        "set xlabel \"particles\"", "set ylabel \"particle-steps per second\"", "set logscale x", "set logscale y",
        "set xrange [%g:%g]" % (min(counts) / 2, max(counts) * 2), "set format y \"%.0e\"",
        "set termoption noenhanced", "set grid", "set key below"] + blocks + ["plot " + ", \\\n     ".join(plots)])
    for terminal, ext in (("pngcairo size 1000,700", "png"), ("svg size 1000,700", "svg")):
        script = "set terminal %s\nset output \"%s.%s\"\n%s\n" % (terminal, base, ext, body)
        subprocess.run(["gnuplot"], input=script, text=True, check=True)


if __name__ == "__main__":
    main()
