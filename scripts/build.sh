#!/usr/bin/env bash
# Configures and builds mpmrom in build/<variant>/: float or double precision, and float-mpi or double-mpi for the
# MPI build (docs/mpi.md); default double. Installs the Debian packages and the cached OpenMP Kokkos first when they
# are missing. Use your own Kokkos with KOKKOS_ROOT=/path. Extra arguments go to CMake's configure step.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
variant=${1:-double}
shift || true
case "$variant" in
  float|double) precision=$variant; mpi=OFF;;
  float-mpi|double-mpi) precision=${variant%-mpi}; mpi=ON;;
  *) echo "build.sh: the build must be float, double, float-mpi or double-mpi, not '$variant'" >&2; exit 2;;
esac

"$here/scripts/install-deps.sh"
kokkos_root=${KOKKOS_ROOT:-$("$here/scripts/install-kokkos.sh")}

build_dir="$here/build/$variant"
cmake -S "$here" -B "$build_dir" -DKokkos_ROOT="$kokkos_root" -DMPMROM_PRECISION="$precision" \
      -DMPMROM_ENABLE_MPI="$mpi" "$@" >&2
cmake --build "$build_dir" --parallel "$(nproc)" >&2
echo "$build_dir"
