#!/usr/bin/env bash
# The command line under mpirun (docs/mpi.md) against one process: `mpmrom sweep`, `train` and `rollout` on two
# processes write the same outputs as on one (sweep and rollout bit for bit; training within round-off, checked by
# test_mpi), the rollout's checkpoints are gone afterwards, a bad input ends every rank with one error line and
# exit 1, and commands that run on one process only are refused.
# Usage: mpi_cli.sh MPMROM MPIEXEC
set -euo pipefail
mpmrom=$1
mpiexec=$2
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
two=("$mpiexec" -n 2 --oversubscribe "$mpmrom" -q)
fail() { echo "mpi_cli: FAIL: $*" >&2; exit 1; }

# The fuzzers' seed scene (the tests' pushed block, 0.02 s in 2 frames) with five pushes, one held out.
sed -e 's/^push = \[.*/push = [0.5, 0.75, 1.0, 1.25, 1.5]/' -e 's/^test = \[.*/test = [2]/' \
  "$here/../../fuzz/seed_scene.toml" > "$work/scene.toml"
grep -q '^\[design\]' "$work/scene.toml" || fail "the seed scene has no design"

"${two[@]}" sweep "$work/scene.toml" --out "$work/two"
"$mpmrom" -q sweep "$work/scene.toml" --out "$work/one"
cmp "$work/one/design.csv" "$work/two/design.csv" || fail "design.csv differs"
# The FOM is bitwise reproducible on host backends; a GPU's P2G atomics change the order of sums from run to run
# (docs/reliability.md: tens of float eps of O(1) fields), so there the snapshots agree to an absolute 5e-5.
tolerance=()
"$mpmrom" info | grep -q "backend: *Cuda" && tolerance=(-d 5e-5)
for run in "$work"/one/runs/*.h5; do
  name=$(basename "$run")
  for field in x v F C; do
    h5diff -q "${tolerance[@]}" "$run" "$work/two/runs/$name" "/$field" "/$field" || fail "$name /$field differs"
  done
done

"$mpmrom" -q train "$work/one" --out "$work/model.h5" --latent 2 --width 8 --depth 3 --epochs 20
"${two[@]}" train "$work/one" --out "$work/model_two.h5" --latent 2 --width 8 --depth 3 --epochs 20
[ -f "$work/model_two.h5" ] || fail "train under mpirun wrote no model"

"${two[@]}" rollout "$work/model.h5" "$work/scene.toml" --out "$work/rom_two.h5" --samples 8 --checkpoint-seconds 0
"$mpmrom" -q rollout "$work/model.h5" "$work/scene.toml" --out "$work/rom_one.h5" --samples 8
for dataset in latent/xhat latent/xhatdot latent/time outcome/flags outcome/stopped_at parameters/values; do
  h5diff -q "$work/rom_one.h5" "$work/rom_two.h5" "/$dataset" "/$dataset" || fail "ROM /$dataset differs"
done
ls "$work"/rom_two.h5.ckpt* >/dev/null 2>&1 && fail "checkpoints left behind"

# A bad input on every rank: one line each, exit 1, nothing written.
echo "not hdf5" > "$work/broken.h5"
set +e
"${two[@]}" rollout "$work/broken.h5" "$work/scene.toml" --out "$work/rom_bad.h5" 2> "$work/bad.err"
status=$?
"${two[@]}" simulate "$work/scene.toml" --out "$work/sim.h5" 2> "$work/refused.err"
refused=$?
set -e
[ "$status" -ne 0 ] || fail "a broken model file exited 0"
grep -q "mpmrom: error: .*broken.h5" "$work/bad.err" || { cat "$work/bad.err" >&2; fail "no error line"; }
[ -e "$work/rom_bad.h5" ] && fail "a failed rollout wrote its output"
[ "$refused" -ne 0 ] || fail "simulate under mpirun was not refused"
grep -q "under mpirun, mpmrom runs sweep, train and rollout" "$work/refused.err" || fail "no refusal line"
echo "mpi_cli: sweep, train and rollout on 2 processes match 1; errors end every rank"
