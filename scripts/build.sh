#!/usr/bin/env bash
# Configures and builds mpmrom in build/<precision>/ (float or double; default double). Installs the Debian
# packages and the cached OpenMP Kokkos first when they are missing. Use your own Kokkos with KOKKOS_ROOT=/path.
# Extra arguments go to CMake's configure step.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
precision=${1:-double}
shift || true
case "$precision" in float|double) ;; *) echo "build.sh: precision must be float or double, not '$precision'" >&2; exit 2;; esac

"$here/scripts/install-deps.sh"
kokkos_root=${KOKKOS_ROOT:-$("$here/scripts/install-kokkos.sh")}

build_dir="$here/build/$precision"
cmake -S "$here" -B "$build_dir" -DKokkos_ROOT="$kokkos_root" -DMPMROM_PRECISION="$precision" "$@" >&2
cmake --build "$build_dir" --parallel "$(nproc)" >&2
echo "$build_dir"
