#!/usr/bin/env bash
# The README's examples and every docs/*.md's shell lines, run as a user pastes
# them (tests/integration/readme.py).
set -euo pipefail
here=$(dirname "$0")
exec /usr/bin/python3 "$here/readme.py" "$here/../../README.md" "${LEC6_BUILD_DIR:?}"
