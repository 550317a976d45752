#!/usr/bin/env bash
# clang-tidy with .clang-tidy's checks over the library's and the program's sources, compiled as in BUILD_DIR's
# compile_commands.json. Prints nothing on stdout; fails (exit 1) when a check warns. About 10 minutes on 2 cores.
# Usage: scripts/tidy.sh [BUILD_DIR]     (default build/double)
set -euo pipefail
exec 1>&2
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=$(cd "${1:-$here/build/double}" && pwd)
[ -f "$build/compile_commands.json" ] || { echo "tidy: error: no $build/compile_commands.json (configure with scripts/build.sh)"; exit 1; }
command -v clang-tidy > /dev/null || { echo "tidy: error: clang-tidy is not installed (scripts/install-deps.sh)"; exit 1; }
cd "$here"
mapfile -t sources < <(git ls-files 'src/*.cpp' 'apps/*.cpp')
# gcc's OpenMP flag and native tuning mean nothing to clang's parser here
printf '%s\n' "${sources[@]}" | xargs -P "$(nproc)" -n 4 clang-tidy -p "$build" --quiet \
  --extra-arg=-Wno-unknown-warning-option --extra-arg=-Wno-unused-command-line-argument ||
  { echo "tidy: error: clang-tidy found problems (above)"; exit 1; }
echo "tidy: ${#sources[@]} sources pass .clang-tidy"
