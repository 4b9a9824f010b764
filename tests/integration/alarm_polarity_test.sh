#!/usr/bin/env bash
# lec serve honours a line's alarm_polarity everywhere it reports ALARM
# (tests/integration/alarm_polarity.py, against Debian's mosquitto).
set -euo pipefail
exec /usr/bin/python3 "$(dirname "$0")/alarm_polarity.py" inverted unset
