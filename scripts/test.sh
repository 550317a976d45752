#!/usr/bin/env bash
# README's test command: sets up everything on a fresh Debian machine (packages, cached Kokkos), builds mpmrom in
# double precision with MPI and in float precision without, and runs the whole test suite for both (the MPI build
# adds test_mpi and test_mpi_cli, on two processes: docs/mpi.md); then the set-up scripts on a simulated fresh
# machine (tests/fresh_machine.sh); the example consumer (scripts/example.sh: examples/rollout_consumer built against
# the installed package, running three rollouts); and the sanitizer job (scripts/sanitize.sh: the suite under
# ASan + UBSan, and the fuzzers' repeatable runs); the Python package (scripts/python.sh: pip install, pytest); and
# the sources' format (scripts/format.sh --check against
# .clang-format). MPMROM_SETUP_ONLY=1 stops after the set-up and builds.
# Prints ctest's and pytest's results (and nothing else) on stdout; exits non-zero on any failure, naming the failed parts last.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
variants=(double-mpi float)
for variant in "${variants[@]}"; do
  "$here/scripts/build.sh" "$variant" > /dev/null
done
[ -n "${MPMROM_SETUP_ONLY:-}" ] && { echo "test: set up: ${variants[*]} built in $here/build" >&2; exit 0; }

failed=()
echo "== source format (.clang-format) ==" >&2
"$here/scripts/format.sh" --check || failed+=("source format")
for variant in "${variants[@]}"; do
  echo "== tests, $variant ==" >&2
  (cd "$here/build/$variant" && ctest --output-on-failure --timeout 1200) || failed+=("tests ($variant)")
done
echo "== the set-up scripts on a simulated fresh machine ==" >&2
bash "$here/tests/fresh_machine.sh" >&2 || failed+=("fresh-machine set-up")
echo "== the Python package: pip install, pytest, the design example ==" >&2
"$here/scripts/python.sh" "$here/build/double-mpi/apps/mpmrom" || failed+=("python package")
echo "== example consumer against the installed package ==" >&2
"$here/scripts/example.sh" "$here/build/double-mpi" >&2 || failed+=("example consumer")
"$here/scripts/sanitize.sh" >&2 || failed+=("sanitizers and fuzzers")
if [ ${#failed[@]} -gt 0 ]; then
  echo "test: error: failed: $(IFS=,; echo "${failed[*]}" | sed 's/,/, /g')" >&2
  exit 1
fi
echo "test: every part passed" >&2
