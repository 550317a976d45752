#!/usr/bin/env bash
# The measurement behind `mpmrom rollout`'s defaults (docs/rom.md "Defaults"): on a pipeline's model and its test
# runs, the defaults (no flags) against each alternative of one setting at a time (sample weights, selection and
# count, projection iterations), each rolled out over the test runs and evaluated against their full-order runs.
# Prints a markdown table on stdout: test position, displacement and velocity errors, stopped rollouts, seconds per
# simulated second per rollout. Usage: scripts/rollout_defaults.sh [PIPELINE_DIR] [BUILD_DIR]
# (defaults: out/poke_pipeline from scripts/main.sh, build/double). MODEL=FILE, DATA=SWEEP_DIR and SCENE=FILE take
# another model, sweep or scene than the pipeline's first model, its data/ and scenes/NAME.toml. About 10 minutes on
# 2 cores for the poke cylinder (the 8- and 30-sample selections fit their samples at set-up).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
dir=${1:-$here/out/poke_pipeline}
mpmrom=${2:-$here/build/double}/apps/mpmrom
source "$here/scripts/lib/rom_configuration.sh"
data=${DATA:-$dir/data}
[ -f "$data/design.csv" ] || { echo "rollout_defaults: error: no $data/design.csv (run scripts/main.sh)" >&2; exit 1; }
model=${MODEL:-$(ls "$dir"/models/*.h5 | head -n 1)}
# the scene the pipeline ran (report.json names it), from scenes/ unless SCENE=FILE says otherwise
if [ -z "${SCENE:-}" ]; then
  name=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["scene"])' "$dir/report.json")
  SCENE=$here/scenes/$name.toml
fi
scene=$SCENE
[ -f "$scene" ] || { echo "rollout_defaults: error: no scene file $scene (set SCENE=FILE)" >&2; exit 1; }
work="$dir/rollout_defaults"
mkdir -p "$work"
# The test runs' parameter values (every design column before split).
design_params "$data/design.csv" "$work/test.csv" test
configurations=(
  "defaults|"
  "weights mass|--weights mass"
  "selection greedy|--selection greedy"
  "selection region|--selection region"
  "selection random|--selection random"
  "8 samples|--samples 8"
  "30 samples|--samples 30"
  "projection iterations 0|--projection-iterations 0"
  "projection iterations 1|--projection-iterations 1"
  "projection iterations 3|--projection-iterations 3"
)
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
for entry in "${configurations[@]}"; do
  name=${entry%%|*}
  read -r -a flags <<< "${entry#*|}"
  file="$work/$(tr ' ' '_' <<< "$name")"
  echo "rollout_defaults: $name ${flags[*]}" >&2
  rom_configuration rollout_defaults "$mpmrom" "$model" "$scene" "$work/test.csv" "$data" "$file" "${flags[@]}"
done
python3 - "$work" "$model" "$data" "${configurations[@]}" <<'PY'
import json, os, sys
work, model, data, entries = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4:]
print("Model `%s`, test runs of `%s`:\n" % (model, data))
print("| configuration | flags | position | displacement | velocity | stopped | s per simulated s |")
print("| --- | --- | --- | --- | --- | --- | --- |")
for entry in entries:
    name, flags = entry.split("|", 1)
    base = os.path.join(work, name.replace(" ", "_"))
    e = json.load(open(base + ".errors.json"))
    t = json.load(open(base + ".rollout.json"))
    rollouts = e["rollouts"]
    simulated = t["simulated_seconds"] if "simulated_seconds" in t else None
    cost = t["rom_seconds_per_simulated_second"] if "rom_seconds_per_simulated_second" in t else None
    cells = ["%.3g %%" % (100 * e["test"][m]) for m in ("position_error", "displacement_error", "velocity_error")]
    print("| %s | `%s` | %s | %d of %d | %s |" % (name, flags or "(none)", " | ".join(cells), e["stopped"], rollouts,
                                               "%.3g" % cost if cost is not None else "n/a"))
PY
