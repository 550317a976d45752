#!/usr/bin/env bash
# README's main-job command: sets up everything on a fresh Debian machine, builds mpmrom (double precision) and runs
# it end to end on the poke cylinder: the parameter sweep (27 runs, 22 train / 5 test) into out/poke_cylinder/ (each
# run an HDF5 snapshot with an XDMF side file for ParaView), training, then the reduced model (Algorithm 1, 15 greedy
# samples) rolled out over the whole design and evaluated against the full-order runs.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=$("$here/scripts/build.sh" double)
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
"$build_dir/apps/mpmrom" info
"$build_dir/apps/mpmrom" sweep "$here/scenes/poke_cylinder.toml" --out "$here/out/poke_cylinder"
"$build_dir/apps/mpmrom" train "$here/out/poke_cylinder" --out "$here/out/poke_cylinder/model.h5"
out="$here/out/poke_cylinder"
"$build_dir/apps/mpmrom" rollout "$out/model.h5" "$here/scenes/poke_cylinder.toml" --out "$out/rom.h5" --samples 15 \
  --selection greedy --data "$out" --params "$out/design.csv" --decode reference
"$build_dir/apps/mpmrom" evaluate "$out/rom.h5" "$out" --json > "$out/rom_errors.json"
echo "main: wrote $out/design.csv, runs/*.h5 (open runs/*.xmf in ParaView), model.h5, rom.h5 and rom_errors.json" >&2
