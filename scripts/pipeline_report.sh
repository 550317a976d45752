#!/usr/bin/env bash
# The committed speed-against-accuracy report for the poke cylinder (docs/results/poke_pipeline/): the pipeline with
# the model search for two targets (1 % and 0.3 % validation position error) over r in {3, 5, 8} at width 16 and
# r = 5 at width 32 (5 layers), Algorithm 1 and the Galerkin step with 8, 15, 30 and all samples at the scene's time
# step and at CFL 3, on the networks the search trains (it skips those whose predicted cost cannot beat its choice).
# 13 minutes on 2 CPU cores at d4dddf9 (two networks trained), 17 minutes at e81dcdf with the networks reused (the
# trial sets' set-up); outputs in out/poke_report/, the report, its JSON and its charts copied to
# docs/results/poke_pipeline/.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=$("$here/scripts/build.sh" double)
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
out="$here/out/poke_report"
"$build_dir/apps/mpmrom" pipeline "$here/scenes/poke_cylinder.toml" --out "$out" --target-error 0.01 0.003 \
  --networks 3x16x5 5x16x5 8x16x5 5x32x5 "$@"
dest="$here/docs/results/poke_pipeline"
mkdir -p "$dest"
cp "$out"/report.md "$out"/report.json "$out"/*.png "$out"/*.svg "$out"/*.gp "$dest"/
echo "pipeline_report: copied the report to $dest" >&2
