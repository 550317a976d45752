#!/usr/bin/env bash
# Tries each bad input of docs/reliability.md on the command line (quietly: -q, so that only what a failure prints
# is counted) and prints the table rows: the input, the exit code and the one line the tool printed (rerun it to
# refresh the document). Uses fuzz/seed_scene.toml and the seed files of fuzz/corpus/hdf5/ as the good inputs that
# each case spoils.
# Usage: scripts/bad_inputs.sh [BUILD_DIR]     (default build/double)
set -uo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mpmrom=$(cd "${1:-$here/build/double}" && pwd)/apps/mpmrom
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
export OMP_NUM_THREADS=1
seed="$here/fuzz/seed_scene.toml"
corpus="$here/fuzz/corpus/hdf5"

# A copy of the seed scene with one line replaced (sed expression).
scene_with() { sed -e "$1" "$seed" > "$2"; }

row() {  # row DESCRIPTION COMMAND...
  local description=$1
  shift
  local output status
  output=$("$@" 2>&1 >/dev/null)
  status=$?
  local lines
  lines=$(printf '%s' "$output" | grep -c '' || true)
  output=$(printf '%s' "$output" | head -n 1 | sed -e "s|$work/||g" -e "s|$here/||g" -e 's/|/\\|/g')
  printf '| %s | %s | %s | `%s` |\n' "$description" "$status" "$lines" "$output"
}

echo "| bad input | exit | lines | what the tool printed (first line) |"
echo "| --- | --- | --- | --- |"
# Spoiled scenes, one a line: "description|file|sed expression that spoils the seed scene".
while IFS='|' read -r description file edit; do
  scene_with "$edit" "$file"
  row "$description" "$mpmrom" -q simulate "$file" --out out.h5
done <<'CASES'
scene: TOML syntax error|syntax.toml|s/^\[time\]$/[time/
scene: missing [grid]|nogrid.toml|/^\[grid\]$/,/^dx/d
scene: wrong type (dx = "fine")|type.toml|s/^dx = 0.1$/dx = "fine"/
scene: zero grid spacing|zero.toml|s/^dx = 0.1$/dx = 0.0/
scene: negative body size|negative.toml|s/^size = .*$/size = [0.2, -0.2, 0.2]/
scene: nu = 0.5|nu.toml|s/^poisson_ratio = 0.3$/poisson_ratio = 0.5/
scene: body with no material point (spacing above its size)|empty.toml|s/^spacing = 0.05$/spacing = 0.5/
scene: body outside the grid|outside.toml|s/^center = .*$/center = [0.45, 0.0, 0.0]/
scene: NaN material constant|nan.toml|s/^youngs_modulus = .*$/youngs_modulus = nan/
scene: a count beyond int's range (outputs = 2777777777)|outputs.toml|s/^outputs = 2$/outputs = 2777777777/
scene: 8e12 material points (too little memory)|huge.toml|s/^spacing = 0.05$/spacing = 0.00001/
scene: 1.7e9 grid nodes, 55 GB (too little memory)|biggrid.toml|s/^lo = .*$/lo = [-6.0, -6.0, -6.0]/; s/^hi = .*$/hi = [6.0, 6.0, 6.0]/; s/^dx = 0.1$/dx = 0.01/
scene: 8e15 grid nodes|hugegrid.toml|s/^lo = .*$/lo = [-100.0, -100.0, -100.0]/; s/^hi = .*$/hi = [100.0, 100.0, 100.0]/; s/^dx = 0.1$/dx = 0.001/
CASES
row "scene: NaN in --set" "$mpmrom" -q simulate "$seed" --set push=inf --out out.h5
row "scene: a count that is not whole (--set time.outputs=2.5)" \
  "$mpmrom" -q simulate "$seed" --set time.outputs=2.5 --out out.h5
row "scene file missing" "$mpmrom" -q simulate missing.toml --out out.h5

row "unwritable output path (/proc)" "$mpmrom" -q simulate "$seed" --out /proc/out.h5
row "output in a missing directory" "$mpmrom" -q simulate "$seed" --out no/such/dir/out.h5
row "model output in a missing directory (checked before training)" "$mpmrom" -q train "$corpus/snapshot.h5" --out no/dir/m.h5
row "ROM output in a missing directory (checked before the rollouts)" "$mpmrom" -q rollout "$corpus/model.h5" "$seed" --out no/dir/rom.h5

head -c 6000 "$corpus/snapshot.h5" > truncated.h5
mkdir -p sweep/runs && cp truncated.h5 sweep/runs/run_000.h5
printf 'push,split,file\n0.5,train,runs/run_000.h5\n' > sweep/design.csv
row "snapshot truncated (training input)" "$mpmrom" -q train sweep --out m.h5 --epochs 1
printf 'not an hdf5 file\n' > text.h5
cp text.h5 sweep/runs/run_000.h5
row "snapshot that is not HDF5" "$mpmrom" -q train sweep --out m.h5 --epochs 1
cp "$corpus/model.h5" sweep/runs/run_000.h5
row "a model file given as a snapshot" "$mpmrom" -q train sweep --out m.h5 --epochs 1
cp "$corpus/snapshot.h5" version.h5
if python3 -c 'import h5py' 2>/dev/null; then
  python3 -c 'import h5py, sys; f = h5py.File(sys.argv[1], "r+"); f.attrs["format_version"] = 99' version.h5
  cp version.h5 sweep/runs/run_000.h5
  row "snapshot of another format version" "$mpmrom" -q train sweep --out m.h5 --epochs 1
  cp "$corpus/snapshot.h5" shape.h5
  python3 - shape.h5 <<'PY'
import h5py, sys
f = h5py.File(sys.argv[1], "r+")
x = f["x"][...]
del f["x"]
f["x"] = x[:, :-1, :]
PY
  cp shape.h5 sweep/runs/run_000.h5
  row "snapshot with mismatched shapes (x one point short)" "$mpmrom" -q train sweep --out m.h5 --epochs 1
else
  echo "bad_inputs: python3 has no h5py: the rows 'snapshot of another format version' and 'snapshot with mismatched shapes' are left out" >&2
fi
row "model truncated" "$mpmrom" -q rollout truncated.h5 "$seed" --out rom.h5
row "a snapshot given as a model" "$mpmrom" -q rollout "$corpus/snapshot.h5" "$seed" --out rom.h5
row "model of an older mpmrom (older HDF5 layout, variable-length strings)" "$mpmrom" -q rollout "$here/tests/data/legacy/model_v1.h5" "$seed" --out rom.h5
row "ROM file of an older mpmrom (evaluate)" "$mpmrom" -q evaluate "$corpus/legacy_rom_v1.h5" sweep
row "upgrade: not an mpmrom file" "$mpmrom" -q upgrade text.h5
scene_with 's/^name = .*$/name = "another_scene"/; s/^spacing = 0.05$/spacing = 0.04/' other.toml
row "model used with a scene it was not trained for" "$mpmrom" -q rollout "$corpus/model.h5" other.toml --out rom.h5
printf 'push\nnan\n' > nan.csv
row "NaN in a rollout's parameter file" "$mpmrom" -q rollout "$corpus/model.h5" "$seed" --out rom.h5 --params nan.csv
row "ROM file truncated (evaluate)" "$mpmrom" -q evaluate truncated.h5 sweep
