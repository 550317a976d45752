#!/usr/bin/env bash
# The C++ sources in .clang-format's style. `scripts/format.sh` rewrites them in place; `scripts/format.sh --check`
# changes nothing and fails (exit 1, naming each file that differs) when one is not in the style: scripts/test.sh
# runs it, so CI does. Prints nothing on stdout.
set -euo pipefail
exec 1>&2
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"
command -v clang-format > /dev/null || { echo "format: error: clang-format is not installed (scripts/install-deps.sh)"; exit 1; }
mapfile -t files < <(git ls-files -co --exclude-standard -- '*.cpp' '*.hpp' | grep -v '^fuzz/corpus/')
[ ${#files[@]} -gt 0 ] || { echo "format: error: no C++ sources found under $here"; exit 1; }
if [ "${1:-}" = "--check" ]; then
  differ=()
  for file in "${files[@]}"; do
    [ -f "$file" ] || continue
    clang-format --style=file "$file" | cmp -s - "$file" || differ+=("$file")
  done
  if [ ${#differ[@]} -gt 0 ]; then
    printf 'format: %s is not in the style of .clang-format\n' "${differ[@]}"
    echo "format: error: ${#differ[@]} files differ from .clang-format (scripts/format.sh rewrites them)"
    exit 1
  fi
  echo "format: ${#files[@]} sources in the style of .clang-format"
else
  for file in "${files[@]}"; do [ -f "$file" ] && clang-format --style=file -i "$file"; done
  echo "format: ${#files[@]} sources formatted"
fi
