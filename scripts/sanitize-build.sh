#!/usr/bin/env bash
# The sanitizer build that scripts/sanitize.sh (CI) and scripts/fuzz.sh (campaigns) share: clang with
# AddressSanitizer, UndefinedBehaviorSanitizer and the libFuzzer targets, against Debian's Serial Kokkos (3.4.1), in
# build/sanitize/ (or SANITIZE_BUILD_DIR). Builds every target, or only the CMake targets named as arguments.
# Prints the build folder on stdout and nothing else (progress goes to stderr); a failed step ends it with one line
# "...: error: ..." and a non-zero exit.
# Usage: scripts/sanitize-build.sh [TARGET...]
set -euo pipefail
exec 3>&1 1>&2  # fd 3 is the result (the build folder); every tool's output goes to stderr
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
"$here/scripts/install-deps.sh"  # prints its own error line

build_dir=${SANITIZE_BUILD_DIR:-$here/build/sanitize}
mkdir -p "$build_dir" && build_dir=$(cd "$build_dir" && pwd)
cmake -S "$here" -B "$build_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_C_COMPILER=clang \
  -DCMAKE_CXX_COMPILER=clang++ -DKokkos_ROOT=/usr -DMPMROM_PRECISION=double -DMPMROM_ENABLE_SANITIZERS=ON \
  -DMPMROM_ENABLE_FUZZING=ON -DMPMROM_ENABLE_BENCHMARKS=OFF -DMPMROM_NATIVE_ARCH=OFF ||
  { echo "sanitize-build: error: CMake could not configure $build_dir"; exit 1; }
targets=()
for target in "$@"; do targets+=(--target "$target"); done
cmake --build "$build_dir" --parallel "$(nproc)" "${targets[@]}" ||
  { echo "sanitize-build: error: compiling $build_dir failed"; exit 1; }
echo "$build_dir" >&3
