#!/usr/bin/env bash
# Configures and builds mpmrom in build/<variant>/: float or double precision, and float-mpi or double-mpi for the
# MPI build (docs/mpi.md); default double. Installs the Debian packages and the cached OpenMP Kokkos first when they
# are missing. Use your own Kokkos with KOKKOS_ROOT=/path. Extra arguments go to CMake's configure step.
# Prints the build folder on stdout and nothing else (progress goes to stderr); a failed step ends it with one line
# "...: error: ..." from the script that found it (install-deps, install-kokkos, or this one) and a non-zero exit.
set -euo pipefail
exec 3>&1 1>&2  # fd 3 is the result (the build folder); every tool's output goes to stderr
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
variant=${1:-double}
shift || true
case "$variant" in
  float|double) precision=$variant; mpi=OFF;;
  float-mpi|double-mpi) precision=${variant%-mpi}; mpi=ON;;
  *) echo "build: error: the build must be float, double, float-mpi or double-mpi, not '$variant'"; exit 2;;
esac

"$here/scripts/install-deps.sh"  # each install script prints its own error line
kokkos_root=${KOKKOS_ROOT:-$("$here/scripts/install-kokkos.sh")}

build_dir="$here/build/$variant"
echo "build: configuring $build_dir (Kokkos in $kokkos_root)"
cmake -S "$here" -B "$build_dir" -DKokkos_ROOT="$kokkos_root" -DMPMROM_PRECISION="$precision" \
      -DMPMROM_ENABLE_MPI="$mpi" "$@" || { echo "build: error: CMake could not configure $build_dir"; exit 1; }
echo "build: compiling $build_dir on $(nproc) cores (about 2 minutes from scratch on 2 cores)"
cmake --build "$build_dir" --parallel "$(nproc)" || { echo "build: error: compiling $build_dir failed"; exit 1; }
echo "$build_dir" >&3
