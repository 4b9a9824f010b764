#!/usr/bin/env bash
# Moves never inherit settings silently: CLI, HTTP, MQTT and Python, one table
# (tests/integration/move_defaults.py).
set -euo pipefail
export PYTHONPATH="${LEC6_BUILD_DIR:-build}/python${PYTHONPATH:+:$PYTHONPATH}"
exec /usr/bin/python3 "$(dirname "$0")/move_defaults.py"
