#!/usr/bin/env bash
# Our client against a third-party slave: Debian's python3-pymodbus serving
# the LEC registers as RTU over TCP. Our typed reads must decode what another
# Modbus stack encodes.
set -euo pipefail
: "${LEC:?path of the lec binary}"
here=$(cd "$(dirname "$0")" && pwd)
source "$here/harness.sh"
need --module pymodbus.server --module pymodbus.datastore
port=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
slave_log=$(mktemp)
/usr/bin/python3 "$here/pymodbus_slave.py" "$port" >"$slave_log" 2>&1 &
slave=$!
trap 'kill $slave 2>/dev/null || true; rm -f "$slave_log"' EXIT

lec() { "$LEC" --port "rtu+tcp://127.0.0.1:$port" --reply-margin 200ms "$@"; }
# Wait (<= 10 s) for the slave to answer: it prints no ready line, so the
# event is its first reply.
answers() { lec name >/dev/null 2>&1; }
if ! wait_for 10 "the pymodbus slave on 127.0.0.1:$port to answer" -- answers; then
  kill -0 "$slave" 2>/dev/null || { echo "the pymodbus slave exited:" >&2; cat "$slave_log" >&2; }
  echo "0 passed, 1 failed"
  exit 1
fi

pass=0 fail=0
check() {  # check NAME EXPECTED ACTUAL
  if [[ "$2" == "$3" ]]; then pass=$((pass + 1)); else fail=$((fail + 1)); echo "FAIL $1: expected '$2', got '$3'"; fi
}

status=$(lec status --json)
get() { /usr/bin/python3 -c "import json,sys; d=json.loads(sys.argv[1]); print(eval(sys.argv[2]))" "$1" "$2"; }
check "position" "-123.45" "$(get "$status" 'd["position_mm"]')"
check "speed" "42" "$(get "$status" 'd["speed_mm_s"]')"
check "thrust" "17" "$(get "$status" 'd["thrust_pct"]')"
check "target" "150.0" "$(get "$status" 'd["target_mm"]')"
check "step" "1" "$(get "$status" 'd["step"]')"
check "flags" "False True True True True" "$(get "$status" 'd["flags"]["busy"], d["flags"]["svre"], d["flags"]["seton"], d["flags"]["inp"], d["flags"]["alarm"]' | tr -d '(),')"
check "serial mode" "True" "$(get "$status" 'd["serial_mode"]')"
check "active alarm" "[51]" "$(get "$status" 'd["alarms"]')"
# Millimetres print with two decimals in the JSON text itself.
grep -q '"position_mm": -123.45' <<<"$status" && pass=$((pass + 1)) || { fail=$((fail + 1)); echo "FAIL json decimals"; }
grep -q '"target_mm": 150.00' <<<"$status" && pass=$((pass + 1)) || { fail=$((fail + 1)); echo "FAIL json 150.00"; }

check "name" "PYMODBUS-AX1" "$(lec name)"
alarms=$(lec alarms --json)
check "history" "51 99" "$(get "$alarms" '" ".join(str(g["alarms"][0]["code"]) for g in d["history"] if g["alarms"])')"
decoded=$(lec raw 01 03 04 10 00 10)
grep -q "step 1 position = 150.00 mm" <<<"$decoded" && pass=$((pass + 1)) || { fail=$((fail + 1)); echo "FAIL raw step read: $decoded"; }

echo "$pass passed, $fail failed"
[[ $fail -eq 0 ]]
