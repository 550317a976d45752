#!/usr/bin/env bash
# FOM throughput records: particle-steps per second on the cylinder scenes, for each P2G variant, in the precision of
# the given build. Writes one JSON record per run.
# Usage: perf/run_fom_bench.sh BUILD_DIR [STEPS]     (e.g. build/float 20)
#   SCENES (default "cylinder_1e5 cylinder_1e6"), STRATEGIES (default "atomic scatter tiled"), SUFFIX (e.g. _h200)
#   tags the file names, RESULTS (default perf/results) is where the records go.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:?usage: run_fom_bench.sh BUILD_DIR [STEPS]}
steps=${2:-20}
scenes=${SCENES:-"cylinder_1e5 cylinder_1e6"}
strategies=${STRATEGIES:-"atomic scatter tiled"}
suffix=${SUFFIX:-}
results=${RESULTS:-$here/perf/results}
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
mkdir -p "$results"
for scene in $scenes; do
  for p2g in $strategies; do
    record=$("$build/apps/mpmrom" -q bench fom "$here/scenes/$scene.toml" --p2g "$p2g" --steps "$steps" --json)
    backend=$(echo "$record" | sed -n 's/.*"backend":"\([^"]*\)".*/\1/p')
    precision=$(echo "$record" | sed -n 's/.*"precision":"\([^"]*\)".*/\1/p')
    out="$results/fom_${scene}_${p2g}_${backend,,}_${precision}${suffix}.json"
    echo "$record" > "$out"
    echo "$out: $(echo "$record" | sed -n 's/.*"fom_particle_steps_per_s":\([^,}]*\).*/\1/p') particle-steps/s" >&2
  done
done
