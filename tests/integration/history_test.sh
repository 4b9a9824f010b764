#!/usr/bin/env bash
# lec serve's move history on the twin, with mosquitto (tests/integration/history_test.py);
# the healthy-twin drift scenario is history_healthy_test.sh.
set -euo pipefail
exec /usr/bin/python3 "$(dirname "$0")/history_test.py" api_mqtt kill9 corrupt
