#!/usr/bin/env bash
# Renders an mpmrom output with ParaView, headless: scripts/render.sh FILE.xmf --out DIR [render.py options]
# (PNG of the last frame, PNG per frame, animated GIF; see scripts/render.py). pvbatch needs an X server for OpenGL:
# a virtual one (Xvfb) is started for the run. Tries twice: Xvfb occasionally refuses the first client.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
command -v pvbatch > /dev/null || { echo "render: error: pvbatch not found (Debian package paraview)" >&2; exit 1; }
command -v xvfb-run > /dev/null || { echo "render: error: xvfb-run not found (Debian package xvfb)" >&2; exit 1; }
log=$(mktemp "${TMPDIR:-/tmp}/render.XXXXXX")
trap 'rm -f "$log"' EXIT
status=1
for attempt in 1 2; do
  status=0
  xvfb-run -a -s "-screen 0 1600x1200x24" pvbatch "$here/render.py" "$@" 2> "$log" || status=$?
  [ "$status" -eq 0 ] && exit 0
  # render.py's own errors are one line "render: error: ..."; anything else is ParaView's, worth a retry
  if grep -q "^render: error:" "$log"; then break; fi
done
grep -v '^\s*[0-9]* *0x' "$log" | grep -m 3 -i "error\|render:" >&2 || true
echo "render: error: pvbatch failed (exit $status) on: $*" >&2
exit "$status"
