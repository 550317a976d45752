#!/usr/bin/env bash
# Runs README's commands in a real fresh Debian 12 root: debootstrap (minimal base) into ROOT_DIR, a clone of this
# repository's HEAD inside it, then, chrooted as root, `bash scripts/main.sh` (main), `bash scripts/test.sh` (test),
# both (both), or only their set-up steps (setup: MPMROM_SETUP_ONLY=1, packages, Kokkos and builds). The path a new
# user takes, from nothing; needs root on a Debian or Ubuntu host. Packages come from the host's own apt sources
# (copied into the root); nothing here names a package host. ROOT_DIR is kept for inspection; delete it when done.
# Usage: scripts/fresh-root.sh [setup|main|test|both] [ROOT_DIR]   (default: setup, /var/tmp/mpmrom-fresh-root)
# Prints nothing on stdout; the chrooted commands' progress goes to stderr, and the elapsed time of each at the end.
set -euo pipefail
exec 1>&2
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
mode=${1:-setup}
root=${2:-/var/tmp/mpmrom-fresh-root}
case "$mode" in setup|main|test|both) ;; *) echo "fresh-root: error: mode must be setup, main, test or both"; exit 2;; esac
[ "$(id -u)" -eq 0 ] || { echo "fresh-root: error: needs root (debootstrap, chroot, mounts)"; exit 1; }
[ -e "$root" ] && { echo "fresh-root: error: $root exists; remove it or name another folder"; exit 1; }

# The first configured Debian archive of the host (deb822 .sources or one-line .list form).
mirror=$(sed -n -E 's/^URIs:[[:space:]]*([^[:space:]]+).*/\1/p' /etc/apt/sources.list.d/*.sources 2> /dev/null |
  grep -v -- '-security' | head -n 1 || true)
if [ -z "$mirror" ]; then
  mirror=$(sed -n -E 's/^deb[[:space:]]+(\[[^]]*\][[:space:]]+)?([^[:space:]]+)[[:space:]]+bookworm[[:space:]].*/\2/p' \
    /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2> /dev/null | head -n 1 || true)
fi
[ -n "$mirror" ] || { echo "fresh-root: error: no Debian archive found in the host's apt sources"; exit 1; }

command -v debootstrap > /dev/null || {
  echo "fresh-root: installing debootstrap on the host"
  apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends debootstrap
}
echo "fresh-root: debootstrap bookworm (minbase) into $root"
start=$SECONDS
debootstrap --variant=minbase bookworm "$root" "$mirror" ||
  { echo "fresh-root: error: debootstrap failed (messages above)"; exit 1; }
# The host's apt sources and keyrings, so the root installs from the same archives (and snapshot) as the host.
rm -f "$root/etc/apt/sources.list"
cp -a /etc/apt/sources.list.d/. "$root/etc/apt/sources.list.d/"
[ -f /etc/apt/sources.list ] && cp /etc/apt/sources.list "$root/etc/apt/sources.list"
cp -a /usr/share/keyrings/. "$root/usr/share/keyrings/"
cp /etc/resolv.conf "$root/etc/resolv.conf"
echo "fresh-root: root ready in $((SECONDS - start)) s"

git clone -q "$here" "$root/root/mpmrom"
# The shared/ folder beside the clone, as CI has it, when this checkout has one.
[ -d "$here/../shared" ] && cp -a "$here/../shared" "$root/root/shared"

mounts=()
unmount_all() {
  local m
  for ((m = ${#mounts[@]} - 1; m >= 0; m--)); do umount -l "${mounts[m]}" 2> /dev/null || true; done
}
trap unmount_all EXIT
for fs in proc sys dev dev/pts; do
  mkdir -p "$root/$fs"
  mount --bind "/$fs" "$root/$fs"
  mounts+=("$root/$fs")
done

run_in_root() {  # run_in_root NAME COMMAND: the command in the clone, as root, with a clean environment
  local t0=$SECONDS status=0
  echo "fresh-root: == $1 =="
  chroot "$root" /usr/bin/env -i HOME=/root PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    TERM=dumb LANG=C.UTF-8 /bin/bash -c "cd /root/mpmrom && $2" || status=$?
  echo "fresh-root: $1: exit $status after $((SECONDS - t0)) s"
  return "$status"
}
case "$mode" in
  setup)
    run_in_root "main.sh set-up" "MPMROM_SETUP_ONLY=1 bash scripts/main.sh"
    run_in_root "test.sh set-up" "MPMROM_SETUP_ONLY=1 bash scripts/test.sh";;
  main) run_in_root "main.sh" "bash scripts/main.sh";;
  test) run_in_root "test.sh" "bash scripts/test.sh";;
  both)
    run_in_root "main.sh" "bash scripts/main.sh"
    run_in_root "test.sh" "bash scripts/test.sh";;
esac
echo "fresh-root: done in $((SECONDS - start)) s; the root stays in $root"
