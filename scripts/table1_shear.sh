#!/usr/bin/env bash
# The paper's Table 1 experiment on our data: the shear_cylinder scenes (3 and 17 material points) trained with
# lambda1 = lambda2 = 0, with lambda2 > 0 only, with both > 0, and (ours, not the paper's) with the affine term
# lambda3 = 1 as well; prints the reconstruction errors of each model on its training runs and on its test run
# (codes fitted by projection) as a markdown table.
# Usage: [EPOCHS=N] scripts/table1_shear.sh [BUILD_DIR] [OUT_DIR]   (defaults: 3000 epochs, build/double, out/table1)
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=${1:-$here/build/double}
out=${2:-$here/out/table1}
mpmrom="$build/apps/mpmrom"
export OMP_PROC_BIND=${OMP_PROC_BIND:-false}
mkdir -p "$out"
common=(--latent 3 --width 32 --depth 5 --epochs "${EPOCHS:-3000}" --batch-snapshots 4 --points-per-snapshot 17
        --learning-rate 3e-3 --final-learning-rate 3e-5 --validation 0 --json)
for points in 3 17; do
  scene="$here/scenes/shear_cylinder_$points.toml"
  [ -f "$out/shear$points/design.csv" ] || "$mpmrom" -q sweep "$scene" --out "$out/shear$points"
  for lambdas in "0 0 0" "0 1 0" "1 1 0" "1 1 1"; do
    set -- $lambdas
    name="shear${points}_l1_$1_l2_$2$([ "$3" = 0 ] || echo "_l3_$3")"
    "$mpmrom" -q train "$out/shear$points" --out "$out/$name.h5" \
      --lambda-grad "$1" --lambda-vel "$2" --lambda-affine "$3" "${common[@]}" > "$out/$name.json"
  done
done
python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
print("| points | lambda1 | lambda2 | lambda3 | train position | train velocity | train F | test position | test velocity | test F |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for points in (3, 17):
    for l1, l2, l3 in (("0", "0", "0"), ("0", "1", "0"), ("1", "1", "0"), ("1", "1", "1")):
        name = f"shear{points}_l1_{l1}_l2_{l2}" + ("" if l3 == "0" else f"_l3_{l3}")
        e = json.loads((out / f"{name}.json").read_text())["errors"]
        cells = [f"{100 * e[s][m]:.3g} %" for s in ("train", "test") for m in ("position_error", "velocity_error", "F_error")]
        print(f"| {points} | {l1} | {l2} | {l3} | " + " | ".join(cells) + " |")
PY
