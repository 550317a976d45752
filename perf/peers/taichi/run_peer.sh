#!/usr/bin/env bash
# Our full-order step against Taichi's MLS-MPM on the same machine in one run. For each scene: `mpmrom bench fom`
# (ours, its CFL time step), our run at that fixed step over AGREE_TIME seconds (`mpmrom simulate`; the default
# 0.05 s lets the cylinders' load reach the fixed bottom and come back), the peer's run
# of the same particles at the same step checked against it (agree.py), then the peer's step timed in both of
# Taichi's layouts (fields interleaved, aos, and component by component, soa), ours timed again after them; writes
# OUT/peer_fom_<scene>_taichi_<backend>_<precision><TAG>.json (record.py: ours the mean of its timings before and
# after the peer's) and prints each record's path on stdout.
# Usage: [STEPS=50] [WARMUP=3] [AGREE_TIME=0.05 (0: no check)] [P2G=atomic|scatter] [TAG=_h200] [PEAK_BANDWIDTH=4.8e12]
#        perf/peers/taichi/run_peer.sh BUILD_DIR OUT_DIR SCENE.toml...
# Needs python3 with taichi, h5py and numpy. The peer runs on the GPU when BUILD's backend is CUDA, else on as
# many CPU threads as ours (OMP_NUM_THREADS, or all cores).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
build=${1:?usage: run_peer.sh BUILD_DIR OUT_DIR SCENE.toml...}
out=${2:?usage: run_peer.sh BUILD_DIR OUT_DIR SCENE.toml...}
shift 2
[ $# -gt 0 ] || { echo "run_peer.sh: no scene given" >&2; exit 1; }
mpmrom="$build/apps/mpmrom"
[ -x "$mpmrom" ] || { echo "run_peer.sh: no $mpmrom" >&2; exit 1; }
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export OMP_PROC_BIND=${OMP_PROC_BIND:-spread} OMP_PLACES=${OMP_PLACES:-threads}
backend=$("$mpmrom" info | sed -n 's/^ *backend: *\([A-Za-z]*\).*/\1/p')
precision=$("$mpmrom" info | sed -n 's/^ *precision: *//p')
threads=$("$mpmrom" info | sed -n 's/^ *backend:.*(\([0-9]*\) threads).*/\1/p')
if [ "$backend" = Cuda ]; then arch=cuda; p2g=${P2G:-atomic}; else arch=cpu; p2g=${P2G:-scatter}; fi
peer=(python3 "$here/mpm_taichi.py")
for scene in "$@"; do
  name=$(basename "$scene" .toml)
  bench=("$mpmrom" -q bench fom "$scene" --p2g "$p2g" --steps "${STEPS:-50}" --warmup "${WARMUP:-3}" --json)
  echo "run_peer.sh: $name: ours" >&2
  "${bench[@]}" > "$work/ours_before.json"
  dt=$(python3 -c "import json, sys; print(repr(json.load(open(sys.argv[1]))['dt_s']))" "$work/ours_before.json")
  agree_time=${AGREE_TIME:-0.05}
  if [ "$agree_time" = 0 ]; then  # the particles only (one step's snapshot), no agreement check
    "$mpmrom" -q simulate "$scene" --out "$work/ours.h5" --p2g "$p2g" --set "time.end_time=$dt" --set time.outputs=1
    echo '{"checked": false}' > "$work/agree.json"
  else
    echo "run_peer.sh: $name: agreement over $agree_time s at dt = $dt s" >&2
    "$mpmrom" -q simulate "$scene" --out "$work/ours.h5" --p2g "$p2g" --set "time.end_time=$agree_time" \
      --set time.outputs=10 --set "time.dt=$dt"
    "${peer[@]}" "$scene" "$work/ours.h5" trajectory --arch "$arch" --precision "$precision" \
      --threads "${threads:-0}" --dt "$dt" --out "$work/trajectory.npz"
    python3 "$here/agree.py" "$work/trajectory.npz" "$scene" > "$work/agree.json"
  fi
  for layout in aos soa; do
    echo "run_peer.sh: $name: Taichi, $layout" >&2
    "${peer[@]}" "$scene" "$work/ours.h5" bench --arch "$arch" --precision "$precision" --layout "$layout" \
      --threads "${threads:-0}" --dt "$dt" --steps "${STEPS:-50}" --warmup "${WARMUP:-3}" > "$work/peer_$layout.json"
  done
  echo "run_peer.sh: $name: ours again" >&2
  "${bench[@]}" > "$work/ours_after.json"
  record="$out/peer_fom_${name}_taichi_$(echo "$backend" | tr A-Z a-z)_${precision}${TAG:-}.json"
  python3 "$here/record.py" "$work/ours_before.json" "$work/ours_after.json" "$work/agree.json" \
    "$work/peer_aos.json" "$work/peer_soa.json" \
    --peak-bandwidth "${PEAK_BANDWIDTH:-0}" > "$record.tmp"
  mv "$record.tmp" "$record"
  echo "$record"
done
