#!/usr/bin/env bash
# Reduced-model accuracy on the paper's two examples, each configuration rolled out over the scene's whole design
# (train and test runs in one batch) and evaluated against the full-order runs:
#   poke  : Algorithm 1 and 2, all points and 15 samples (paper: r = 5, 15 samples, 0.50 % / 0.55 %);
#   table2: shear_cylinder_17, Algorithm 1 and 2, all 17 points and 6 samples (paper Table 2);
#   table1: shear_cylinder_3, Algorithm 1 with its 3 points, on each of the three models of the paper's Table 1
#           (lambda1 = lambda2 = 0; lambda2 only; both) and ours with the affine term (lambda3 = 1).
# Samples: the rollout's default selection (greedy projection with fitted weights).
# Usage: scripts/rom_experiments.sh poke|table2|table1 [BUILD_DIR] [OUT_DIR]
# Needs the sweep and model first: poke in out/poke_cylinder (`mpmrom sweep` of scenes/poke_cylinder.toml and
# `mpmrom train` into its model.h5; MODEL=FILE picks another), table2 from scripts/table1_shear.sh (TABLE1_DIR,
# default out/table1: shear17 and its lambda1 = lambda2 = 1 model; MODEL=FILE picks another), table1 from the same
# script (shear3 and its four models).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
experiment=${1:?usage: rom_experiments.sh poke|table2|table1 [BUILD_DIR] [OUT_DIR]}
build=${2:-$here/build/double}
mpmrom="$build/apps/mpmrom"
export OMP_PROC_BIND=${OMP_PROC_BIND:-false}
case "$experiment" in
  poke)
    out=${3:-$here/out/rom_poke}
    data=$here/out/poke_cylinder; model=${MODEL:-$data/model.h5}; scene=$here/scenes/poke_cylinder.toml; few=15;;
  table2)
    out=${3:-$here/out/rom_table2}
    data=${TABLE1_DIR:-$here/out/table1}/shear17; model=${MODEL:-${TABLE1_DIR:-$here/out/table1}/shear17_l1_1_l2_1.h5}
    scene=$here/scenes/shear_cylinder_17.toml; few=6;;
  table1)
    out=${3:-$here/out/rom_table1}
    table1=${TABLE1_DIR:-$here/out/table1}
    data=$table1/shear3; scene=$here/scenes/shear_cylinder_3.toml
    mkdir -p "$out"
    for lambdas in l1_0_l2_0 l1_0_l2_1 l1_1_l2_1 l1_1_l2_1_l3_1; do
      status=0  # 3: some rollouts stopped, the file is written and evaluated
      "$mpmrom" -q rollout "$table1/shear3_$lambdas.h5" "$scene" --out "$out/$lambdas.h5" --samples 0 \
        --params "$data/design.csv" --json > "$out/$lambdas.rollout.json" || status=$?
      [ "$status" -eq 0 ] || [ "$status" -eq 3 ] || { echo "rom_experiments.sh: rollout exited $status" >&2; exit 1; }
      "$mpmrom" -q evaluate "$out/$lambdas.h5" "$data" --json > "$out/$lambdas.errors.json"
    done
    python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
paper = {"l1_0_l2_0": "0.19 % | 13 % | 0.2 %", "l1_0_l2_1": "0.004 % | 0.3 % | 0.3 %",
         "l1_1_l2_1": "0.004 % | 0.2 % | 0.2 %", "l1_1_l2_1_l3_1": "(not the paper's) | | "}
print("| lambda1, lambda2 | split | position | velocity | F | stopped | paper: position | velocity | F |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for name, label in (("l1_0_l2_0", "0, 0"), ("l1_0_l2_1", "0, 1"), ("l1_1_l2_1", "1, 1"), ("l1_1_l2_1_l3_1", "1, 1, lambda3 = 1")):
    e = json.loads((out / f"{name}.errors.json").read_text())
    for split in ("train", "test"):
        cells = [f"{100 * e[split][m]:.3g} %" for m in ("position_error", "velocity_error", "F_error")]
        stopped = sum(1 for run in e["runs"] if run.get("split") == split and not run.get("completed", True))
        print(f"| {label} | {split} | " + " | ".join(cells) + f" | {stopped} | {paper[name]} |")
PY
    exit 0;;
  *) echo "rom_experiments.sh: unknown experiment '$experiment'" >&2; exit 2;;
esac
mkdir -p "$out"
for method in point node; do
  for samples in 0 "$few"; do
    name="${method}_${samples}"
    "$mpmrom" -q rollout "$model" "$scene" --out "$out/$name.h5" --method "$method" --samples "$samples" \
      --params "$data/design.csv" --json > "$out/$name.rollout.json"
    "$mpmrom" -q evaluate "$out/$name.h5" "$data" --json > "$out/$name.errors.json"
  done
done
python3 - "$out" "$few" <<'PY'
import json, pathlib, sys
out, few = pathlib.Path(sys.argv[1]), sys.argv[2]
metrics = ("position_error", "displacement_error", "velocity_error", "F_error", "strain_error")
print("| method | samples | split | " + " | ".join(m.replace("_error", "") for m in metrics) + " | s per step |")
print("| --- | --- | --- | " + " | ".join("---" for _ in metrics) + " | --- |")
for method, label in (("point", "Algorithm 1 (material point)"), ("node", "Algorithm 2 (sample node)")):
    for samples in ("0", few):
        e = json.loads((out / f"{method}_{samples}.errors.json").read_text())
        t = json.loads((out / f"{method}_{samples}.rollout.json").read_text())
        for split in ("train", "test"):
            cells = [f"{100 * e[split][m]:.3g} %" for m in metrics]
            print(f"| {label} | {'all' if samples == '0' else samples} | {split} | " + " | ".join(cells) +
                  f" | {t['rom_step_seconds']:.3g} |")
PY
