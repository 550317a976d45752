#!/usr/bin/env bash
# Installs the Debian packages mpmrom builds with; with --render also those that render pictures (ParaView's
# pvbatch with its Python modules under a virtual X server, Pillow for the GIFs: scripts/render.sh). Idempotent:
# does nothing when they are all present. Runs as root (or through sudo when available). Prints nothing on stdout
# (apt's output goes to stderr); a failed step ends it with one line "install-deps: error: ..." and exit 1.
set -euo pipefail
exec 1>&2  # no result to print: everything below is progress

packages=(
  build-essential cmake git pkg-config tar gzip
  libeigen3-dev libhdf5-dev hdf5-tools libcli11-dev libtomlplusplus-dev nlohmann-json3-dev
  libgtest-dev libbenchmark-dev gnuplot-nox python3 python3-dev python3-venv
  clang libclang-rt-dev clang-format clang-tidy libtrilinos-kokkos-dev
  libopenmpi-dev openmpi-bin
)
if [ "${1:-}" = "--render" ]; then
  # python3-paraview is only a Recommends of paraview: without it pvbatch cannot import paraview.
  packages+=(paraview python3-paraview xvfb xauth python3-pil)
fi

missing_packages() {
  local p
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || echo "$p"
  done
}
mapfile -t missing < <(missing_packages)
[ ${#missing[@]} -eq 0 ] && exit 0

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: error: need root (or sudo) to install: ${missing[*]}"; exit 1; }
  sudo_cmd=(sudo)
fi
echo "install-deps: installing ${#missing[@]} Debian packages: ${missing[*]}"
"${sudo_cmd[@]}" apt-get update -q ||
  { echo "install-deps: error: apt-get update failed (its messages are above)"; exit 1; }
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}" ||
  { echo "install-deps: error: apt-get install failed for: ${missing[*]}"; exit 1; }
mapfile -t missing < <(missing_packages)
[ ${#missing[@]} -eq 0 ] ||
  { echo "install-deps: error: still not installed after apt-get install: ${missing[*]}"; exit 1; }
