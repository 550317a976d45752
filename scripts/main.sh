#!/usr/bin/env bash
# README's main-job command: sets up everything on a fresh Debian machine, builds mpmrom (double precision) and runs
# it end to end. Today that is the full-order stage of the pipeline: the poke-cylinder parameter sweep (27 runs,
# 22 train / 5 test) into out/poke_cylinder/, each run an HDF5 snapshot with an XDMF side file for ParaView.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=$("$here/scripts/build.sh" double)
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
"$build_dir/apps/mpmrom" info
"$build_dir/apps/mpmrom" sweep "$here/scenes/poke_cylinder.toml" --out "$here/out/poke_cylinder"
"$build_dir/apps/mpmrom" train "$here/out/poke_cylinder" --out "$here/out/poke_cylinder/model.h5"
echo "main: wrote $here/out/poke_cylinder/design.csv, runs/*.h5 (open runs/*.xmf in ParaView) and model.h5" >&2
