#!/usr/bin/env bash
# The reduced step's time against the particle count (issue 29: within 2x from 10^4 to 10^7 particles at one sample
# count), beside the full-order step on the same scenes: `mpmrom bench rom MODEL SCENE` (one network, decoded at each
# scene's own material points; random samples, so no training runs are needed) and `mpmrom bench fom SCENE` per
# scene, then one record and its chart (perf/plot_rom_scaling.py).
# Usage: perf/run_rom_scaling.sh BUILD_DIR MODEL SCENE...
# Environment: SAMPLES (60), ROLLOUTS (2), FRAMES (3), ROM_FLAGS (more `bench rom` flags, e.g. "--integrator euler"),
# FOM_STEPS (5; 0 leaves the FOM out), TAG (appended to the record's name, e.g. _h100), OUT (default perf/results).
# Writes OUT/rom_step_scaling_<backend>_<precision>TAG.{json,png,svg}; prints one line per scene on stdout.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
usage="usage: run_rom_scaling.sh BUILD_DIR MODEL SCENE..."
build=${1:?$usage}; model=${2:?$usage}; shift 2
[ $# -gt 0 ] || { echo "$usage" >&2; exit 2; }
mpmrom="$build/apps/mpmrom"
out=${OUT:-$here/perf/results}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
read -r -a flags <<< "${ROM_FLAGS:-}"
for scene in "$@"; do
  name=$(basename "$scene" .toml)
  "$mpmrom" -q bench rom "$model" "$scene" --samples "${SAMPLES:-60}" --rollouts "${ROLLOUTS:-2}" \
    --frames "${FRAMES:-3}" "${flags[@]}" --json > "$work/$name.rom.json"
  if [ "${FOM_STEPS:-5}" -gt 0 ]; then
    "$mpmrom" -q bench fom "$scene" --steps "${FOM_STEPS:-5}" --warmup 1 --json > "$work/$name.fom.json"
  fi
  python3 - "$work/$name.rom.json" "$work/$name.fom.json" <<'PY'
import json, os, sys
rom = json.load(open(sys.argv[1]))
fom = json.load(open(sys.argv[2])) if os.path.exists(sys.argv[2]) else None
line = "%s: %d particles, ROM %.3g ms a step (%d rollouts, %d samples)" % (
    rom["scene"], rom["particles"], 1e3 * rom["rom_step_seconds"], rom["rollouts"], rom["samples"])
if fom:
    line += ", FOM %.3g ms a step" % (1e3 * fom["fom_step_seconds"])
print(line)
PY
done
python3 "$here/perf/plot_rom_scaling.py" "$work" "$out" "${TAG:-}"
