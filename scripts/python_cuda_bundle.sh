#!/bin/bash
# The Python package built for a GPU machine (docs/gpu.md "The Python package on a GPU"): the module compiled here
# with nvcc against a CUDA Kokkos and the GPU machine's Python version, packed with the shared libraries it needs
# (but libc, libstdc++ and the driver) into one tar.xz. Prints the archive's path on stdout.
#
#   scripts/python_cuda_bundle.sh KOKKOS_CUDA_PREFIX PYTHON OUT.tar.xz
#
# PYTHON: an interpreter of the GPU machine's major.minor version (its headers and extension suffix are used; the
# built module is not imported here). nanobind comes from NANOBIND_PYTHON (default python3) -m nanobind.
# BUILD (default build-pycuda) is kept, so a second run recompiles what changed; PRECISION (default float).
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 KOKKOS_CUDA_PREFIX PYTHON OUT.tar.xz" >&2; exit 2; }
kokkos=$(realpath "$1") python=$2 out=$(realpath -m "$3")
build=${BUILD:-build-pycuda}
nanobind_dir=$("${NANOBIND_PYTHON:-python3}" -m nanobind --cmake_dir) ||
  { echo "python_cuda_bundle: error: no nanobind (pip install nanobind) for ${NANOBIND_PYTHON:-python3}" >&2; exit 1; }
cd "$(dirname "$0")/.."
cmake -S . -B "$build" -G Ninja -DKokkos_ROOT="$kokkos" -DCMAKE_CXX_COMPILER="$kokkos/bin/nvcc_wrapper" \
  -DMPMROM_PRECISION="${PRECISION:-float}" -DMPMROM_ENABLE_TESTS=OFF -DMPMROM_ENABLE_BENCHMARKS=OFF \
  -DMPMROM_ENABLE_PYTHON=ON -DMPMROM_PYTHON_STUB=OFF -DPython_EXECUTABLE="$python" -Dnanobind_DIR="$nanobind_dir" >&2
cmake --build "$build" --target mpmrom_python -j "$(nproc)" >&2

stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/run/pkg/mpmrom" "$stage/run/lib"
cp python/mpmrom/*.py python/mpmrom/py.typed "$build"/python/_core*.so "$stage/run/pkg/mpmrom/"
# The GPU machine has its own libc, libstdc++ (newer) and driver; everything else the module links goes with it.
ldd "$build"/python/_core*.so | awk '/=> \// {print $3}' |
  grep -v -E 'lib(c|m|pthread|dl|rt|cuda|stdc\+\+|gcc_s)\.so' | xargs -I{} cp -L {} "$stage/run/lib/"
tar -C "$stage" -cJf "$out" run
echo "python_cuda_bundle: on the GPU machine: tar -xJf $(basename "$out"); LD_LIBRARY_PATH=\$PWD/run/lib" \
  "PYTHONPATH=\$PWD/run/pkg python3 -c 'import mpmrom'" >&2
echo "$out"
