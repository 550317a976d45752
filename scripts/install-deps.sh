#!/usr/bin/env bash
# Installs the Debian packages mpmrom builds with; with --render also those that render pictures (ParaView's
# pvbatch under a virtual X server, Pillow for the GIFs: scripts/render.sh). Idempotent: does nothing when they are
# all present. Runs as root (or through sudo when available).
set -euo pipefail

packages=(
  build-essential cmake git pkg-config tar gzip
  libeigen3-dev libhdf5-dev hdf5-tools libcli11-dev libtomlplusplus-dev nlohmann-json3-dev
  libgtest-dev libbenchmark-dev gnuplot-nox
  clang libclang-rt-dev libtrilinos-kokkos-dev
  libopenmpi-dev openmpi-bin
)
if [ "${1:-}" = "--render" ]; then
  packages+=(paraview xvfb xauth python3-pil)
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[ ${#missing[@]} -eq 0 ] && exit 0

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
echo "install-deps: installing ${missing[*]}" >&2
"${sudo_cmd[@]}" apt-get update -q
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
