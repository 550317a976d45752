#!/usr/bin/env python3
"""The reduced step's time against the particle count, beside the full-order step's: one record and its chart.

Usage: perf/plot_rom_scaling.py WORK_DIR OUT_DIR [TAG]
Reads WORK_DIR/<scene>.rom.json (`mpmrom bench rom --json`) and <scene>.fom.json (`mpmrom bench fom --json`, where
present), writes OUT_DIR/rom_step_scaling_<backend>_<precision>TAG.json (the records, sorted by particle count, and
the largest over the smallest ROM step time) and .png/.svg (gnuplot, as the tool's own charts), and prints the
record's path on stdout.
"""
import glob
import json
import os
import subprocess
import sys


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__.splitlines()[2])
    work, out, tag = sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else ""
    points = []
    for path in glob.glob(os.path.join(work, "*.rom.json")):
        fom_path = path[: -len(".rom.json")] + ".fom.json"
        points.append({"rom": json.load(open(path)),
                       "fom": json.load(open(fom_path)) if os.path.exists(fom_path) else None})
    if not points:
        sys.exit("plot_rom_scaling: error: no bench rom records in %s" % work)
    points.sort(key=lambda p: p["rom"]["particles"])
    first = points[0]["rom"]
    if any(p["rom"]["samples"] != first["samples"] or p["rom"]["rollouts"] != first["rollouts"] for p in points):
        sys.exit("plot_rom_scaling: error: the records differ in samples or rollouts")
    times = [p["rom"]["rom_step_seconds"] for p in points]
    record = {"benchmark": "rom_step_scaling", "device": first["device"], "backend": first["backend"],
              "precision": first["precision"], "samples": first["samples"], "rollouts": first["rollouts"],
              "model": first["model"], "git_commit": first["git_commit"],
              "particles": [p["rom"]["particles"] for p in points], "rom_step_seconds": times,
              "fom_step_seconds": [p["fom"]["fom_step_seconds"] if p["fom"] else None for p in points],
              "rom_step_time_spread": max(times) / min(times), "points": points}
    base = os.path.join(out, "rom_step_scaling_%s_%s%s" % (first["backend"].lower(), first["precision"], tag))
    with open(base + ".json.tmp", "w") as f:
        json.dump(record, f, indent=1)
    os.replace(base + ".json.tmp", base + ".json")
    rom_rows = "\n".join("%d %.9g" % (p["rom"]["particles"], 1e3 * p["rom"]["rom_step_seconds"]) for p in points)
    fom_rows = "\n".join("%d %.9g" % (p["rom"]["particles"], 1e3 * p["fom"]["fom_step_seconds"])
                         for p in points if p["fom"])
    plots = ["$rom using 1:2 with linespoints lw 2 title \"ROM step, %d samples, %d rollouts\"" %
             (first["samples"], first["rollouts"])]
    if fom_rows:
        plots.append("$fom using 1:2 with linespoints lw 2 dt 2 title \"FOM step\"")
    body = "\n".join([
        "set title \"Step time against particles: %s %s, %s\"" % (first["device"], first["backend"], first["precision"]),
        "set xlabel \"material points\"", "set ylabel \"ms per step\"", "set logscale x", "set logscale y",
        "set xrange [%g:%g]" % (record["particles"][0] / 2, record["particles"][-1] * 2),
        "set termoption noenhanced", "set grid", "set key below",
        "$rom << EOD\n%s\nEOD" % rom_rows, "$fom << EOD\n%s\nEOD" % fom_rows, "plot " + ", \\\n     ".join(plots)])
    for terminal, ext in (("pngcairo size 1000,700", "png"), ("svg size 1000,700", "svg")):
        script = "set terminal %s\nset output \"%s.%s\"\n%s\n" % (terminal, base, ext, body)
        subprocess.run(["gnuplot"], input=script, text=True, check=True)
    print("%s.json: ROM step %.3g-%.3g ms over %d-%d particles (largest / smallest %.2f)" % (
        base, 1e3 * min(times), 1e3 * max(times), record["particles"][0], record["particles"][-1],
        record["rom_step_time_spread"]))


if __name__ == "__main__":
    main()
