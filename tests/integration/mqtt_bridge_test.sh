#!/usr/bin/env bash
# lec serve's MQTT bridge against Debian's mosquitto (tests/integration/mqtt_bridge.py).
set -euo pipefail
exec /usr/bin/python3 "$(dirname "$0")/mqtt_bridge.py" telemetry commands dedup refusals alarms flags home_assistant command_line
