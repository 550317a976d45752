#!/usr/bin/env bash
# README's main-job command: sets up everything on a fresh Debian machine, builds mpmrom (double precision) and runs
# the pipeline on the poke cylinder into out/poke_pipeline/: the parameter sweep (27 runs: 18 train, 4 validation,
# 5 test), the FOM at 4 resolutions against a 2x finer reference, training (r = 5, 5 layers of 48), Algorithm 1
# with 8, 15, 30 and all samples at two time steps, the batch throughput, and report.md / report.json with charts;
# then pictures/ (scripts/pictures.sh: a test run and its reduced model rendered by ParaView, PNG and GIF).
# About 18 minutes on 2 CPU cores; run again, it reuses the sweep and the trained model.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=$("$here/scripts/build.sh" double)
"$here/scripts/install-deps.sh" --render
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
"$build_dir/apps/mpmrom" info
"$build_dir/apps/mpmrom" pipeline "$here/scenes/poke_cylinder.toml" --out "$here/out/poke_pipeline" "$@"
"$here/scripts/pictures.sh" "$here/out/poke_pipeline" "$here/scenes/poke_cylinder.toml" "$build_dir"
echo "main: open out/poke_pipeline/report.md (charts beside it) and pictures/; data/runs/*.xmf open in ParaView" >&2
