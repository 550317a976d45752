#!/usr/bin/env bash
# README's test command: sets up everything on a fresh Debian machine (packages, cached Kokkos), builds mpmrom in
# double precision with MPI and in float precision without, and runs the whole test suite for both (the MPI build
# adds test_mpi and test_mpi_cli, on two processes: docs/mpi.md); then the sanitizer job
# (scripts/sanitize.sh: the suite under ASan + UBSan, and the fuzzers' smoke runs); and the example consumer
# (scripts/example.sh: examples/rollout_consumer built against the installed package, running three rollouts).
# Exits non-zero on any failure.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
status=0
for variant in double-mpi float; do
  build_dir=$("$here/scripts/build.sh" "$variant")
  echo "== tests, $variant ==" >&2
  (cd "$build_dir" && ctest --output-on-failure --timeout 1200) || status=1
done
echo "== example consumer against the installed package ==" >&2
"$here/scripts/example.sh" "$here/build/double-mpi" || status=1
"$here/scripts/sanitize.sh" || status=1
exit $status
