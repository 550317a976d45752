#!/usr/bin/env bash
# README's main-job command: sets up everything on a fresh Debian machine, builds mpmrom (double precision) and runs
# the pipeline on the poke cylinder into out/poke_pipeline/: the parameter sweep (27 runs: 18 train, 4 validation,
# 5 test), the FOM at 4 resolutions against a 2x finer reference, training (r = 5, 5 layers of 48), Algorithm 1
# with 8, 15, 30 and all samples at two time steps, the batch throughput, and report.md / report.json with charts;
# then pictures/ (scripts/pictures.sh: a test run and its reduced model rendered by ParaView, PNG and GIF).
# Run again, it reuses the sweep and the trained model. Arguments go to `mpmrom pipeline`.
# MPMROM_SETUP_ONLY=1 stops after the set-up (packages, Kokkos, build). Prints nothing on stdout; a failed step
# ends it with the one "...: error: ..." line of the step that failed and a non-zero exit.
set -euo pipefail
exec 1>&2  # no result on stdout: the outputs are files in out/poke_pipeline
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir="$here/build/double"
start=$SECONDS
"$here/scripts/install-deps.sh" --render  # the set-up scripts print their own error line
"$here/scripts/build.sh" double > /dev/null
echo "main: set up in $((SECONDS - start)) s: $build_dir/apps/mpmrom"
[ -n "${MPMROM_SETUP_ONLY:-}" ] && exit 0

export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
"$build_dir/apps/mpmrom" info
out="$here/out/poke_pipeline"
# each step prints its own one-line error and fails this script
"$build_dir/apps/mpmrom" pipeline "$here/scenes/poke_cylinder.toml" --out "$out" "$@"
"$here/scripts/pictures.sh" "$out" "$here/scenes/poke_cylinder.toml" "$build_dir"
echo "main: done in $((SECONDS - start)) s: open out/poke_pipeline/report.md (charts beside it) and pictures/;" \
  "data/runs/*.xmf open in ParaView"
