#!/usr/bin/env bash
# Builds examples/rollout_consumer against an installed mpmrom package and runs a rollout with it: installs BUILD_DIR
# (default build/double) into a scratch prefix, configures the example with find_package(mpmrom), trains a tiny model
# of fuzz/seed_scene.toml with the installed mpmrom, and runs three rollouts through the deployment API.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=${1:-$here/build/double}
kokkos_root=${KOKKOS_ROOT:-$("$here/scripts/install-kokkos.sh")}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cmake --install "$build_dir" --prefix "$work/prefix" > "$work/install.log"
cmake -S "$here/examples/rollout_consumer" -B "$work/consumer" -DCMAKE_PREFIX_PATH="$work/prefix;$kokkos_root" >&2
cmake --build "$work/consumer" >&2
mpmrom="$work/prefix/bin/mpmrom"
"$mpmrom" -q sweep "$here/fuzz/seed_scene.toml" --out "$work/sweep"
"$mpmrom" -q train "$work/sweep" --out "$work/model.h5" --latent 2 --width 8 --depth 3 --epochs 50 \
  --scene "$here/fuzz/seed_scene.toml"
OMP_PROC_BIND=false "$work/consumer/rollout_consumer" "$work/model.h5" "$here/fuzz/seed_scene.toml" 0.5 1.0 1.5
