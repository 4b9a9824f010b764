#!/usr/bin/env bash
# The README's install, checked: a clean copy of the sources (no build tree),
# a fresh virtualenv, `pip install` offline with Debian's wheels only, then the
# installed package imported from elsewhere and used on its twin.
#
#   pip_install_test.sh REPO PYTHON       (ctest runs it: python.pip_install)
set -euo pipefail

repo=$1
python=${2:-/usr/bin/python3}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
trap 'exit 143' TERM INT  # ended (make test's `tools/idle-build stop`): the EXIT trap cleans up

mkdir "$tmp/src"
tar -C "$repo" --exclude='./build*' --exclude=.git --exclude=node_modules --exclude='*.egg-info' \
  --exclude=__pycache__ -cf - . | tar -C "$tmp/src" -xf -

"$python" -m venv "$tmp/venv"
start=$(date +%s)
# Built unoptimised: this checks the install (sources, wheel, metadata, entry
# points, the module found and working), not the code, which the Python and
# C++ suites test at -O2. Half the compile time (make test's 30 minutes).
LEC6_CMAKE_ARGS='-DCMAKE_CXX_FLAGS_RELEASE=-O0' \
"$tmp/venv/bin/pip" install --no-index --find-links /usr/share/python-wheels "$tmp/src/python" \
  >"$tmp/pip.log" 2>&1 || { cat "$tmp/pip.log"; echo "pip install failed"; exit 1; }
echo "pip install took $(($(date +%s) - start)) s at -O0 (CMAKE_BUILD_PARALLEL_LEVEL=${CMAKE_BUILD_PARALLEL_LEVEL:-all cores})"

cd "$tmp"  # not the source tree: the import must find the installed package
"$tmp/venv/bin/python" - <<'PY'
import importlib.metadata as md
import os
import sys

import lec6

assert os.path.dirname(lec6.__file__).startswith(sys.prefix), lec6.__file__
assert md.version("lec6") == lec6.__version__, (md.version("lec6"), lec6.__version__)
plugins = [e.value for e in md.entry_points(group="pytest11") if e.name == "lec6"]
assert plugins == ["lec6.pytest_plugin"], plugins
files = {os.path.basename(str(f)) for f in md.files("lec6")}
assert {"py.typed", "_lec6.pyi", "pytest_plugin.py"} <= files, files

with lec6.Twin(initial_position_mm=1.0) as twin, twin.connect() as bus:
    axis = bus.axis(1)
    axis.set_serial_mode(True)
    axis.servo_on()
    axis.home()
    result = axis.move(to=50.0, speed=500)
    status = axis.status()
assert result.in_position and status.position_mm == 50.0, status
print("installed lec6", lec6.__version__, "works:", status)
PY
