#!/usr/bin/env bash
# The set-up path a new user takes, on a simulated fresh machine: stand-in apt-get, dpkg-query and sudo first on
# PATH report every package missing until the stand-in apt-get has "installed" it, and print on stdout and stderr as
# the real tools do. Under them:
#   1. build.sh prints the build folder and nothing else on stdout, and has taken the install path;
#   2. main.sh and test.sh (MPMROM_SETUP_ONLY=1: packages, Kokkos, builds) find their builds, with nothing on stdout;
#   3. a failing apt-get install ends build.sh with one error line and a non-zero exit, stdout empty;
#   4. an empty Kokkos cache whose source download fails ends build.sh with one error line, nothing left cached.
# The packages and Kokkos must already be there for real (test.sh runs this after its builds): the stand-ins only
# pretend to install. Prints "fresh_machine: N passed, 0 failed" last; exits 1 on the first failed check.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
passed=0
fail() { echo "fresh_machine: error: $*" >&2; echo "fresh_machine: $passed passed, 1 failed"; exit 1; }
pass() { passed=$((passed + 1)); echo "fresh_machine: ok: $*" >&2; }

stand_ins="$work/bin"
mkdir -p "$stand_ins"
export FRESH_STATE="$work/installed"  # the packages the stand-in apt-get has "installed", one a line
touch "$FRESH_STATE"
cat > "$stand_ins/dpkg-query" <<'EOF'
#!/usr/bin/env bash
# dpkg-query -W -f='${Status}' PACKAGE: installed only once the stand-in apt-get installed it
package=${*: -1}
echo "dpkg-query: chatter on stderr" >&2
if grep -qx "$package" "$FRESH_STATE"; then printf 'install ok installed'; exit 0; fi
echo "dpkg-query: no packages found matching $package" >&2
exit 1
EOF
cat > "$stand_ins/apt-get" <<'EOF'
#!/usr/bin/env bash
# Prints on both streams like apt-get; FRESH_APT_FAIL=install or =source makes that command fail.
echo "Reading package lists... (stand-in apt-get $*)"
echo "W: stand-in apt-get chatter on stderr" >&2
command=
for arg in "$@"; do case "$arg" in update|install|source) command=$arg; break;; esac; done
if [ "${FRESH_APT_FAIL:-}" = "$command" ]; then
  echo "E: Unable to locate package (stand-in failure of apt-get $command)"
  exit 100
fi
if [ "$command" = install ]; then
  for arg in "$@"; do case "$arg" in -*|install) ;; *) echo "$arg" >> "$FRESH_STATE"; echo "Setting up $arg ...";; esac; done
fi
EOF
cat > "$stand_ins/sudo" <<'EOF'
#!/usr/bin/env bash
echo "[sudo] stand-in running: $*"
exec "$@"
EOF
chmod +x "$stand_ins"/*
fresh_path="$stand_ins:$PATH"

# 1. build.sh on the fresh machine: the build folder alone on stdout.
out=$(PATH="$fresh_path" bash "$here/scripts/build.sh" double-mpi 2> "$work/build.err") ||
  fail "build.sh failed on a fresh machine: $(grep -m1 'error:' "$work/build.err" || tail -n1 "$work/build.err")"
[ "$out" = "$here/build/double-mpi" ] || fail "build.sh printed '$out' on stdout, not the build folder"
grep -q "install-deps: installing" "$work/build.err" || fail "build.sh did not take the install path"
grep -qx "libhdf5-dev" "$FRESH_STATE" || fail "the stand-in apt-get was not asked to install libhdf5-dev"
pass "build.sh prints only its build folder with every package missing and apt printing on stdout"

# 2. The README commands' set-up steps find their builds, nothing on stdout.
: > "$FRESH_STATE"
out=$(PATH="$fresh_path" MPMROM_SETUP_ONLY=1 bash "$here/scripts/test.sh" 2> "$work/test.err") ||
  fail "test.sh's set-up failed: $(grep -m1 'error:' "$work/test.err" || tail -n1 "$work/test.err")"
[ -z "$out" ] || fail "test.sh's set-up printed on stdout: $(head -c 200 <<< "$out")"
grep -q "test: set up" "$work/test.err" || fail "test.sh's set-up did not report its builds"
: > "$FRESH_STATE"
out=$(PATH="$fresh_path" MPMROM_SETUP_ONLY=1 bash "$here/scripts/main.sh" 2> "$work/main.err") ||
  fail "main.sh's set-up failed: $(grep -m1 'error:' "$work/main.err" || tail -n1 "$work/main.err")"
[ -z "$out" ] || fail "main.sh's set-up printed on stdout: $(head -c 200 <<< "$out")"
grep -q "main: set up in .*$here/build/double/apps/mpmrom" "$work/main.err" || fail "main.sh did not find its build"
grep -qx "python3-paraview" "$FRESH_STATE" || fail "main.sh did not install ParaView's Python modules"
pass "main.sh and test.sh set up and find their builds, nothing on stdout"

# Exactly one "error:" line on stderr, naming what failed; nothing on stdout.
expect_one_error() {  # expect_one_error WHAT PATTERN STATUS STDOUT STDERR_FILE
  [ "$3" -ne 0 ] || fail "$1: exit status 0"
  [ -z "$4" ] || fail "$1: printed on stdout: $(head -c 200 <<< "$4")"
  local errors
  errors=$(grep -c 'error:' "$5" || true)
  [ "$errors" -eq 1 ] || fail "$1: $errors error lines, expected one: $(grep 'error:' "$5" | head -n 3)"
  grep -q "$2" "$5" || fail "$1: the error line does not say '$2': $(grep 'error:' "$5")"
}

# 3. A failing install step.
: > "$FRESH_STATE"
status=0
out=$(PATH="$fresh_path" FRESH_APT_FAIL=install bash "$here/scripts/build.sh" double-mpi 2> "$work/fail.err") ||
  status=$?
expect_one_error "a failed apt-get install" "install-deps: error: apt-get install failed for: .*libhdf5-dev" \
  "$status" "$out" "$work/fail.err"
pass "a failed apt-get install ends build.sh with one error line (exit $status)"

# 4. An empty Kokkos cache whose source package cannot be downloaded.
: > "$FRESH_STATE"
status=0
out=$(PATH="$fresh_path" FRESH_APT_FAIL=source MPMROM_CACHE_DIR="$work/cache" \
  bash "$here/scripts/build.sh" double-mpi 2> "$work/kokkos.err") || status=$?
expect_one_error "a failed Kokkos source download" \
  "install-kokkos: error: downloading the trilinos source package failed" "$status" "$out" "$work/kokkos.err"
[ -z "$(ls -A "$work/cache" 2> /dev/null)" ] || fail "a failed Kokkos install left $(ls "$work/cache") in the cache"
pass "an empty Kokkos cache whose download fails ends build.sh with one error line and caches nothing"

echo "fresh_machine: $passed passed, 0 failed"
