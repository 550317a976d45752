#!/usr/bin/env bash
# The Python package's job in README's test command (docs/python.md): `pip install .[test]` into a virtual
# environment cached outside the clone (its build folder, build/python, kept between runs), then its pytest suite,
# whose round trip also runs the program CLI (default build/double/apps/mpmrom), and examples/python/design.py on
# a tiny model. Prints pytest's summary on stdout; a failed step ends it with one line "python: error: ..." and
# exit 1. Environment: MPMROM_CACHE_DIR (as install-kokkos.sh), PYTHON (default python3).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cli=${1:-$here/build/double/apps/mpmrom}
cache_root=${MPMROM_CACHE_DIR:-${XDG_CACHE_HOME:-$HOME/.cache}/mpmrom}
venv="$cache_root/python-venv"
step="starting"
trap 'echo "python: error: $step failed (messages above)" >&2' ERR

step="creating the virtual environment $venv"
[ -x "$venv/bin/python" ] || "${PYTHON:-python3}" -m venv "$venv" >&2
step="pip install .[test] (the whole CMake build the first time, about 3 minutes on 2 cores)"
echo "python: $step" >&2
(cd "$here" && "$venv/bin/python" -m pip install -q "$here[test]") >&2
step="importing mpmrom outside the source tree"
(cd / && "$venv/bin/python" -c "import mpmrom; print('python: mpmrom', mpmrom.__version__, mpmrom.runtime_info()['backend'])") >&2
step="the pytest suite"
MPMROM_CLI="$cli" OMP_PROC_BIND=false "$venv/bin/python" -m pytest -q -p no:cacheprovider "$here/python/tests"
