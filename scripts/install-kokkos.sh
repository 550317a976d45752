#!/usr/bin/env bash
# Builds Kokkos (OpenMP + Serial backends) from the Kokkos sources inside Debian's `trilinos` source package and
# installs it into a cache outside the clone. Prints the install prefix on stdout and nothing else (progress goes to
# stderr); a failed step ends it with one line "install-kokkos: error: ..." and leaves no partial cache. Reuses the
# cache when present.
#
# The source package is fetched with apt's own source-package support, from a deb-src list derived from the
# machine's configured apt sources (nothing here names a package host). Environment:
#   MPMROM_CACHE_DIR   cache root (default: ${XDG_CACHE_HOME:-$HOME/.cache}/mpmrom)
set -euo pipefail
exec 3>&1 1>&2  # fd 3 is the result (the prefix); every tool's output goes to stderr
step="starting"
trap 'echo "install-kokkos: error: $step failed (messages above); nothing was cached"' ERR

cache_root=${MPMROM_CACHE_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/mpmrom}
compiler_tag=$(c++ -dumpfullversion 2>/dev/null || echo unknown)
prefix="$cache_root/kokkos-trilinos-openmp-gcc$compiler_tag"

if [ -f "$prefix/lib/cmake/Kokkos/KokkosConfig.cmake" ] || [ -f "$prefix/lib64/cmake/Kokkos/KokkosConfig.cmake" ]; then
  echo "install-kokkos: reusing $prefix"
  echo "$prefix" >&3
  exit 0
fi

work=$(mktemp -d "${TMPDIR:-/tmp}/mpmrom-kokkos.XXXXXX")
trap 'rm -rf "$work" "${staging:-}"' EXIT
echo "install-kokkos: building Kokkos (OpenMP) once into $prefix, about 1 minute on 2 cores (work in $work)"

# deb-src entries mirroring every configured deb entry, in both apt source formats.
mkdir -p "$work/apt/parts" "$work/apt/lists/partial"
for f in /etc/apt/sources.list.d/*.sources; do
  [ -f "$f" ] && sed -E 's/^Types:.*$/Types: deb-src/' "$f" > "$work/apt/parts/$(basename "$f")"
done
for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
  [ -f "$f" ] && sed -n -E 's/^deb[[:space:]]+/deb-src /p' "$f" > "$work/apt/parts/$(basename "$f").list"
done
apt_opts=(-o "Dir::Etc::SourceList=/dev/null" -o "Dir::Etc::SourceParts=$work/apt/parts"
          -o "Dir::State::Lists=$work/apt/lists" -o "APT::Sandbox::User=root")
step="apt-get update of the deb-src lists"
apt-get "${apt_opts[@]}" -q update
step="downloading the trilinos source package"
(cd "$work" && apt-get "${apt_opts[@]}" -q source --download-only trilinos)

step="unpacking Kokkos from the trilinos sources"
orig=$(ls "$work"/trilinos_*.orig.tar.* | head -n 1)
tar -xf "$orig" -C "$work" --wildcards '*/packages/kokkos/*'
src=$(ls -d "$work"/*/packages/kokkos | head -n 1)

staging="$prefix.partial.$$"
step="configuring Kokkos"
cmake -S "$src" -B "$work/build" -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX="$prefix" \
  -DCMAKE_CXX_STANDARD=17 -DKokkos_ENABLE_OPENMP=ON -DKokkos_ENABLE_SERIAL=ON -DBUILD_SHARED_LIBS=ON
step="building Kokkos"
cmake --build "$work/build" --parallel "$(nproc)"
# Install to a staging prefix then move into place, so an interrupted build never leaves a half cache behind.
step="installing Kokkos"
DESTDIR="$staging" cmake --install "$work/build" > /dev/null
mkdir -p "$(dirname "$prefix")"
mv "$staging$prefix" "$prefix"
rm -rf "$staging"
echo "install-kokkos: installed $prefix"
echo "$prefix" >&3
