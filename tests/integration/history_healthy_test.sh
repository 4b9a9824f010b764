#!/usr/bin/env bash
# The history's drift detector on a healthy, noisy twin: no warning
# (tests/integration/history_test.py, scenario "healthy"). A test of its own:
# it runs alone in the optimised tree (it judges move durations), the other
# scenarios share the machine.
set -euo pipefail
exec /usr/bin/python3 "$(dirname "$0")/history_test.py" healthy
