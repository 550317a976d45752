#!/usr/bin/env bash
# README's main-job command: sets up everything on a fresh Debian machine, builds mpmrom (double precision) and runs
# it end to end. Outputs go to out/.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build_dir=$("$here/scripts/build.sh" double)
mkdir -p "$here/out"
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
"$build_dir/apps/mpmrom" info
"$build_dir/perf/bench_kernels" --benchmark_out="$here/out/bench_kernels.json" --benchmark_out_format=json
