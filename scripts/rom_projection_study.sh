#!/usr/bin/env bash
# The reduced model's projection variants side by side (docs/results/rom/): each configuration rolled out over a
# sweep's runs in one batch and evaluated against their full-order runs (SPEC.md's metrics, train and test apart).
# Writes OUT_DIR/<name>.json per configuration (the rollout's flags, errors by split, stopped rollouts, condition,
# seconds per simulated second per rollout) and prints a markdown table on stdout; the ROM files go to
# WORK_DIR (default out/rom_projection_study), not beside the records.
# Usage: scripts/rom_projection_study.sh DATA_DIR MODEL SCENE OUT_DIR [BUILD_DIR]
#   DATA_DIR: the sweep (design.csv and runs/); SPLIT=test rolls out only its test runs (default: every run).
#   CONFIGS: "name|flags;name|flags;..." (default: the projection schemes and damping weights below).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
usage="usage: rom_projection_study.sh DATA_DIR MODEL SCENE OUT_DIR [BUILD_DIR]"
data=${1:?$usage}; model=${2:?$usage}; scene=${3:?$usage}; out=${4:?$usage}
mpmrom=${5:-$here/build/double}/apps/mpmrom
source "$here/scripts/lib/rom_configuration.sh"
[ -f "$data/design.csv" ] || { echo "rom_projection_study: error: no $data/design.csv" >&2; exit 1; }
work=${WORK_DIR:-$here/out/rom_projection_study}
mkdir -p "$out" "$work"
# The rollouts' parameter values: every design column before split, the rows of SPLIT (all when unset).
design_params "$data/design.csv" "$work/params.csv" "${SPLIT:-}"
default_configs="velocity|--projection velocity;position|--projection position"
default_configs+=";velocity damping 0.01|--projection velocity --rate-damping 0.01"
default_configs+=";position damping 0.01|--projection position --rate-damping 0.01"
IFS=';' read -r -a configurations <<< "${CONFIGS:-$default_configs}"
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
for entry in "${configurations[@]}"; do
  name=${entry%%|*}
  read -r -a flags <<< "${entry#*|}"
  stem=$(tr ' ' '_' <<< "$name")
  file="$work/$stem"
  echo "rom_projection_study: $name: ${flags[*]}" >&2
  rom_configuration rom_projection_study "$mpmrom" "$model" "$scene" "$work/params.csv" "$data" "$file" "${flags[@]}"
  python3 - "$file" "$out/$stem.json" "$name" "${flags[*]}" "$model" "$(git -C "$here" rev-parse --short HEAD)" \
    "${SPLIT:-all}" <<'PY'
import json, sys
file, record_path, name, flags, model, commit, split = sys.argv[1:8]
rollout = json.load(open(file + ".rollout.json"))
errors = json.load(open(file + ".errors.json"))
record = {"name": name, "flags": flags, "model": model, "commit": commit, "runs": split, "errors": errors,
          "rollout": rollout}
json.dump(record, open(record_path, "w"), indent=1)
PY
  rm -f "$file.rollout.json" "$file.errors.json"
done
python3 - "$out" "${configurations[@]}" <<'PY'
import json, sys
out, entries = sys.argv[1], sys.argv[2:]
print("| configuration | split | position | displacement | velocity | F | stopped | max condition | s per simulated s |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for entry in entries:
    name = entry.split("|", 1)[0]
    r = json.load(open(f"{out}/{name.replace(' ', '_')}.json"))
    roll = r["rollout"]
    for split in ("train", "test"):
        e = r["errors"].get(split)
        if not e or r["runs"] not in ("all", split):
            continue
        cells = [f"{100 * e[m]:.3g} %" for m in ("position_error", "displacement_error", "velocity_error", "F_error")]
        print(f"| {name} | {split} | " + " | ".join(cells) +
              f" | {roll.get('stopped_rollouts', '?')} | {roll.get('max_condition', 0):.3g} |"
              f" {roll.get('rom_seconds_per_simulated_second', 0):.3g} |")
PY
