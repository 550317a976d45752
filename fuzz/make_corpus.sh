#!/usr/bin/env bash
# Regenerates the fuzzers' seed corpus from fuzz/seed_scene.toml with a built mpmrom (default build/double):
# corpus/scene/ gets every scene of the repository plus the seed; corpus/hdf5/ gets one file of each kind the
# loaders read (snapshot, model, reduced-model file with and without decoded fields) and one of an older format.
# Usage: fuzz/make_corpus.sh [BUILD_DIR]
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
mpmrom=${1:-$here/../build/double}/apps/mpmrom
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export OMP_NUM_THREADS=1
# inputs the fuzzer found problems with (regression_*.h5) are kept
find "$here/corpus" -type f ! -name 'regression_*' -delete
mkdir -p "$here/corpus/scene" "$here/corpus/hdf5"
cp "$here"/../scenes/*.toml "$here/seed_scene.toml" "$here/corpus/scene/"
"$mpmrom" -q sweep "$here/seed_scene.toml" --out "$work/sweep"
"$mpmrom" -q train "$work/sweep" --out "$work/model.h5" --latent 2 --width 8 --depth 3 --epochs 50
"$mpmrom" -q rollout "$work/model.h5" "$here/seed_scene.toml" --out "$work/rom.h5" --samples 4 --energy-growth 0
"$mpmrom" -q rollout "$work/model.h5" "$here/seed_scene.toml" --out "$work/rom_decoded.h5" --samples 4 --energy-growth 0 \
  --decode reference
cp "$work/sweep/runs/run_000.h5" "$here/corpus/hdf5/snapshot.h5"
cp "$work/model.h5" "$work/rom.h5" "$work/rom_decoded.h5" "$here/corpus/hdf5/"
# a file of an older format (variable-length string attributes), which every loader must refuse without reading them
cp "$here/../tests/data/legacy/rom_v1.h5" "$here/corpus/hdf5/legacy_rom_v1.h5"
ls -l "$here/corpus"/*
