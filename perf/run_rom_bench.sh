#!/usr/bin/env bash
# ROM step time against FOM step time on the same scene: one record per ROM configuration (Algorithm 1 and 2, all
# points and SAMPLES samples), each holding the FOM's step time on the same scene from the same build, and the ratio.
# The ROM figures come from `mpmrom rollout --json` (a batch of BATCH rollouts of the scene's first design run);
# the FOM's from `mpmrom bench fom`.
# Usage: perf/run_rom_bench.sh BUILD_DIR MODEL SCENE [SAMPLES] [BATCH] [END_TIME]
# END_TIME (s) shortens the rollouts (default: the scene's end time); CONFIGS="point:0 point:15 node:0 node:15"
# (method:samples, 0 = all points) picks the configurations, e.g. to leave out all-point rollouts on 10^6 points;
# SELECTION (default region) the sample selection; ROM_FLAGS more rollout flags (e.g. "--cfl 3"), with TAG appended
# to the record names. Per simulated second, the FOM's cost is its step time over its time step (`bench fom`'s
# dt_s, the scene's CFL step at rest) and the ROM's its batch time over the simulated time and the rollouts.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:?usage: run_rom_bench.sh BUILD_DIR MODEL SCENE [SAMPLES] [BATCH]}
model=${2:?model file}
scene=${3:?scene file}
samples=${4:-15}
batch=${5:-1}
end_time=${6:-0}
configs=${CONFIGS:-"point:0 point:$samples node:0 node:$samples"}
export OMP_PROC_BIND=${OMP_PROC_BIND:-false}
mpmrom="$build/apps/mpmrom"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fom=$("$mpmrom" -q bench fom "$scene" --steps 50 --json)
# The first run of the scene's design, repeated BATCH times.
python3 "$here/perf/design_params.py" "$scene" "$batch" "$work/params.csv" --first
for config in $configs; do
  method=${config%%:*} n=${config##*:}
  rom=$("$mpmrom" -q rollout "$model" "$scene" --out "$work/rom.h5" --method "$method" --samples "$n" \
        --selection "${SELECTION:-region}" --params "$work/params.csv" --end-time "$end_time" ${ROM_FLAGS:-} --json)
  name=$(basename "$scene" .toml)
  record=$(python3 - "$fom" "$rom" <<'PY'
import json, sys
fom, rom = json.loads(sys.argv[1]), json.loads(sys.argv[2])
rom["fom_step_seconds"] = fom["fom_step_seconds"]
rom["fom_particle_steps_per_s"] = fom["fom_particle_steps_per_s"]
rom["rom_seconds_per_rollout_step"] = rom["rom_step_seconds"] / rom["rollouts"]
rom["rom_over_fom_step_time"] = rom["rom_seconds_per_rollout_step"] / fom["fom_step_seconds"]
rom["fom_seconds_per_simulated_second"] = fom["fom_step_seconds"] / fom["dt_s"]
rom["speedup_per_simulated_second"] = rom["fom_seconds_per_simulated_second"] / rom["rom_seconds_per_simulated_second"]
print(json.dumps(rom))
PY
)
  out="$here/perf/results/rom_${name}_${method}_samples${n}_$(echo "$rom" | sed -n 's/.*"backend":"\([^"]*\)".*/\1/p' | tr A-Z a-z)_$(echo "$rom" | sed -n 's/.*"precision":"\([^"]*\)".*/\1/p')${TAG:-}.json"
  echo "$record" > "$out"
  echo "$out: $(echo "$record" | python3 -c 'import json,sys; d=json.load(sys.stdin); print("ROM %.3g s per rollout-step, FOM %.3g s per step, ratio %.3g; per simulated second FOM / ROM %.3g" % (d["rom_seconds_per_rollout_step"], d["fom_step_seconds"], d["rom_over_fom_step_time"], d["speedup_per_simulated_second"]))')" >&2
done
