#!/usr/bin/env bash
# A stop always reaches the controller (issue 22): a slow move on lec serve's
# twin, stopped through HTTP, MQTT and Modbus TCP in each fault of the line
# (stop_matrix.py has the cases and prints the time from post to the wire).
set -euo pipefail
exec /usr/bin/python3 "$(dirname "$0")/stop_matrix.py" "$@"
