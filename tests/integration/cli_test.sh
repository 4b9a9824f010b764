#!/usr/bin/env bash
# Every `lec` command end to end against `lec sim --pty` in real timing, as an
# engineer would type them, with the documented exit codes.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/lib.sh"

start_twin ax1 --ids 1,2 --name AXIS-ONE --workpiece 350
export LEC_PORT="$tmp/ax1"
lec() { "$LEC" "$@"; }

# Power-on: parallel mode, nothing on.
expect_exit 0 "status" -- lec status
contains "status mode" "parallel (Y30 = 0)"
expect_exit 0 "status json" -- lec status --json
[[ $(json 'd["flags"]["svre"], d["serial_mode"], d["position_mm"]') == "(False, False, 0.0)" ]] && ok || bad "power-on status: $out"
expect_exit 2 "servo in parallel mode" -- lec servo on
contains "servo hint" "lec serial on"
expect_exit 4 "controller exception" -- lec raw 01 05 00 19 FF 00
contains "raw exception" "exception 02"

# The manual's preparation.
expect_exit 0 "serial on" -- lec serial on
expect_exit 0 "servo on" -- lec servo on
contains "servo" "SVRE = 1"
expect_exit 0 "flags after servo" -- lec raw 01 02 00 40 00 10
contains "manual reply 4.1.3" "<- 01 02 02 00 02 38 79"
expect_exit 0 "home" -- lec home
contains "home" "reached the origin: 0.00 mm (SETON, INP = 1)"
expect_exit 0 "flags after homing" -- lec raw 01 02 00 40 00 10
contains "manual reply 4.2.2" "<- 01 02 02 00 0E 38 7C"

# Direct operation, absolute and relative, with progress and the final report.
expect_exit 0 "move to" -- lec move --to 120.5 --speed 400 --accel 3000 --decel 3000
contains "move report" "reached 120.50 mm (INP, within ±0.50 mm)"
expect_exit 0 "move relative" -- lec move --to -20.25 --relative --json
[[ $(json 'd["position_mm"], d["in_position"], d["flags"]["busy"]') == "(100.25, True, False)" ]] && ok || bad "relative: $out"
grep -q '"position_mm": 100.25' <<<"$out" && ok || bad "two decimals in JSON: $out"
expect_exit 0 "no-wait" -- lec move --to 200 --no-wait
contains "no-wait" "Started: target 200.00 mm"
expect_exit 0 "status after no-wait" -- lec status --json
[[ $(json 'd["target_mm"]') == "200.0" ]] && ok || bad "target: $out"

# Pushing against the workpiece at 350 mm: INP = 1 while pressing.
expect_exit 0 "push" -- lec move --to 340 --push 50 --trigger 40 --push-speed 10 --in-position 20
contains "push" "pushed: workpiece at 350.00 mm, thrust 50 % (INP)"
expect_exit 0 "thrust while pushing" -- lec status --json
[[ $(json 'd["thrust_pct"]') == "50" ]] && ok || bad "pushing thrust: $out"
expect_exit 0 "stop push" -- lec stop

# Values are checked before anything is sent.
expect_exit 2 "bad speed" -- lec move --to 10 --speed 70000
contains "speed range" "speed 70000 mm/s is out of range: allowed 1 to 65535 mm/s"
expect_exit 2 "bad decimals" -- lec move --to 10.123
contains "decimals" "more than two decimals"
expect_exit 2 "trigger without push" -- lec move --to 10 --trigger 5
expect_exit 2 "no target" -- lec move
expect_exit 2 "bad id" -- lec --id 300 status
expect_exit 2 "unknown command" -- lec frobnicate
contains "unknown command named" "unknown command 'frobnicate' (\`lec --help\` lists the commands)"
expect_exit 2 "mistyped command" -- lec --id 1 stauts
contains "nearest command" "unknown command 'stauts': did you mean 'status'?"

# An alarm: target beyond the stroke.
expect_exit 5 "beyond stroke" -- lec move --to 900
contains "alarm meaning" "62"
expect_exit 0 "alarms" -- lec alarms --json
[[ $(json '[a["code"] for a in d["active"]]') == "[62]" ]] && ok || bad "active alarms: $out"
expect_exit 0 "reset" -- lec reset
expect_exit 0 "alarms after reset" -- lec alarms
contains "history" "group  0:  62"

# A stored step: write the manual's record to step 1 with raw FC10, run it.
expect_exit 0 "write step 1" -- lec raw 01 10 04 10 00 10 20 00 01 01 F4 00 00 3A 98 13 88 13 88 00 00 00 00 00 14 00 64 00 00 00 00 00 00 00 00 00 00 00 64
expect_exit 0 "move step" -- lec move --step 1
contains "step report" "reached 150.00 mm (INP, within ±1.00 mm)"
expect_exit 0 "OUT after step" -- lec status --json
[[ $(json 'd["flags"]["out"], d["step"]') == "(1, 1)" ]] && ok || bad "OUT0-5: $out"
expect_exit 2 "blank step" -- lec move --step 9
contains "blank" "step 9 is blank"

# Jog, hold, watch with a recording.
expect_exit 0 "jog" -- lec jog + --for 400ms
contains "jog" "Jog stopped at"
expect_exit 0 "hold on" -- lec hold on
expect_exit 0 "hold off" -- lec hold off
expect_exit 0 "watch" -- lec watch --count 5 --record "$tmp/watch.csv"
[[ $(wc -l <"$tmp/watch.csv") -eq 6 ]] && ok || bad "watch.csv lines: $(cat "$tmp/watch.csv")"
head -1 "$tmp/watch.csv" | grep -q "^time_s,position_mm.*,wall_clock_utc$" && ok || bad "watch.csv header"
sed -n 2p "$tmp/watch.csv" | grep -qE ',20[0-9]{2}-[01][0-9]-[0-3][0-9]T[0-2][0-9]:[0-5][0-9]:[0-6][0-9]\.[0-9]{3}Z$' && ok ||
  bad "watch.csv rows end with the wall-clock time: $(sed -n 2p "$tmp/watch.csv")"

# Deadline: a slow move with a short deadline.
expect_exit 6 "deadline" -- lec move --to 10 --speed 5 --timeout 300ms
expect_exit 0 "stop" -- lec stop
# The old spelling still works, with a hint naming the new one.
expect_exit 6 "deadline, old spelling" -- lec move --to 10 --speed 5 --timeout-s 0.3
contains "deprecation hint" "--timeout-s 0.3 is deprecated; write --timeout 0.3s"
expect_exit 0 "stop" -- lec stop
expect_exit 2 "deadline without a unit" -- lec move --to 10 --timeout 30
contains "needs a unit" "'30' needs a unit"

# Ctrl-C during a waiting move stops the axis before exiting. --trace shows
# when the move is under way: the first poll that reads BUSY = 1.
"$LEC" --trace move --to 300 --speed 20 >"$tmp/int.out" 2>&1 &
mover=$!
moving() { grep -q "X40–X4F: BUSY" "$tmp/int.out"; }
wait_for 10 "the move to be under way (BUSY = 1)" -- moving || bad "the move did not start: $(tail -n 5 "$tmp/int.out")"
kill -INT $mover
set +e; wait $mover; code=$?; set -e
# The messages, without the trace's frame lines.
said=$(grep -vE '^ *[0-9.]+ ms (->|<-) ' "$tmp/int.out" || true)
[[ $code -eq 130 ]] && ok || bad "Ctrl-C exit $code: $said"
grep -q "stopped" <<<"$said" && ok || bad "Ctrl-C message: $said"
expect_exit 0 "after Ctrl-C" -- lec status --json
[[ $(json 'd["flags"]["busy"], d["speed_mm_s"]') == "(False, 0)" ]] && ok || bad "still moving after Ctrl-C: $out"

# Name, ping, scan, decode, trace.
expect_exit 0 "name" -- lec name
contains "name" "AXIS-ONE"
expect_exit 0 "ping" -- lec ping -c 3 -i 0
contains "ping stats" "3 sent, 3 received, 0.0% loss"
expect_exit 0 "scan" -- lec scan --ids 1-3
contains "scan 1" "ID   1  answers  AXIS-ONE"
contains "scan 2" "ID   2  answers"
grep -q "ID   3" <<<"$out" && bad "ID 3 answered" || ok
expect_exit 0 "decode" -- lec decode 01 05 00 19 FF 00 5D FD
contains "decode" "ID 1 write Y19 SVON = ON"
expect_exit 2 "decode bad crc" -- lec decode 01 05 00 19 FF 00 5D FE
contains "bad crc" "CRC"
expect_exit 0 "trace" -- lec --trace name
contains "trace out" "-> 01 03 00 0E 00 08"
contains "trace in" "<- 01 03 10"

# Bench: JSON fields of the issue.
expect_exit 0 "bench" -- lec bench -n 20 --json
[[ $(json 'sorted(k for k in d if k in ("tx_per_s","latency_ms","limit_ms","ratio"))') == "['latency_ms', 'limit_ms', 'ratio', 'tx_per_s']" ]] && ok || bad "bench json: $out"

# The guided demo over the pseudo-terminal.
expect_exit 0 "demo" -- lec demo
contains "demo" "all four manual examples ran as the manual says"

# Transport errors: a missing port, a silent ID.
expect_exit 3 "missing port" -- lec --port "$tmp/nope" status
contains "missing port" "cannot open"
expect_exit 3 "silent id" -- lec --id 9 --retries 0 name
contains "silent id" "no reply from ID 9"
expect_exit 2 "no port" -- env -u LEC_PORT "$LEC" status
contains "no port" "no port given"

finish
