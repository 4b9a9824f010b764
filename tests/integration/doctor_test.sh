#!/usr/bin/env bash
# lec doctor against `lec sim` on real pseudo-terminals, each line fault the
# twin plays alone and three combinations: the doctor names each fault with
# its fix, exits 0/7/8 (healthy/degraded/broken); a clean line is healthy
# with information only; IDs 1 and 3 at 57600 with an alarm are found with
# no options; a dead line ends within the budget; bad input (a missing port,
# a port held by lec serve) is named.
# Needs: LEC (the lec binary), /usr/bin/python3.

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need

# doctor NAME ARGS...: runs `lec ARGS... doctor`, output in $TMP/NAME.doc, exit in RC, seconds in SECS.
doctor() {
  local name=$1
  shift
  local t0=${EPOCHREALTIME/./}
  RC=0
  timeout 60 "$LEC" "$@" >"$TMP/$name.doc" 2>&1 || RC=$?
  SECS=$(((${EPOCHREALTIME/./} - t0) / 1000000))
  sed 's/^/    /' "$TMP/$name.doc"
}
has() { grep -qF -- "$2" "$TMP/$1.doc"; }
hasnt() { ! grep -qF -- "$2" "$TMP/$1.doc"; }
# A host busy with other work (make test's other tests, the sanitizer tree
# building beside them) stalls a twin past the doctor's windows now and then:
# a scan that misses an ID, a few timeouts or a broken echo in the burst (CI,
# stop 40, and three clean make test runs on 2026-11-28: one case each). So a
# case whose verdict depends on the twin answering in time gets up to three
# runs. Only a verdict (exit 0, 7, 8) gets another: a crash, a sanitizer's
# abort or a hang (timeout's 124) fails at once; a real regression fails all
# three. SECS is the longest run's.
verdict() { [[ $RC -eq 0 || $RC -eq 7 || $RC -eq 8 ]]; }
# doctor_while CONDITION NAME ARGS...: runs doctor, again while CONDITION
# (a shell command) holds after a verdict, three runs at most.
doctor_while() {
  local condition=$1
  shift
  local longest=0 run
  for run in 1 2 3; do
    doctor "$@"
    ((longest = SECS > longest ? SECS : longest))
    verdict && eval "$condition" || break
    [[ $run -lt 3 ]] && echo "    (run $run: $condition: a loaded host? once more)"
  done
  SECS=$longest
}
# doctor_healthy NAME ARGS...: for a line that must be healthy (exit 0).
doctor_healthy() { doctor_while '[[ $RC -eq 7 || $RC -eq 8 ]]' "$@"; }
# doctor_expect CODE NAME ARGS...: for a line whose verdict must be exit CODE.
doctor_expect() {
  local code=$1
  shift
  doctor_while "[[ \$RC -ne $code ]]" "$@"
}
# doctor_finds TEXT NAME ARGS...: for a --fix case that needs its twin's
# controller found (TEXT, e.g. "serial mode on (Y30)"): every run's output is
# kept in NAME.doc, since a fix applied by one run is not applied again.
doctor_finds() {
  local text=$1 name=$2
  shift
  local longest=0 run all="$TMP/$name.all"
  : >"$all"
  for run in 1 2 3; do
    doctor "$@"
    ((longest = SECS > longest ? SECS : longest))
    cat "$TMP/$name.doc" >>"$all"
    verdict && ! grep -qF -- "$text" "$all" || break
    [[ $run -lt 3 ]] && echo "    (run $run: no \"$text\": a loaded host? once more)"
  done
  SECS=$longest
  cp "$all" "$TMP/$name.doc"
}
# warm PTY [BAUD]: one read before the doctor runs. A twin that has just
# started can stall for tens of ms on a loaded host; reading late, it takes
# the queries that queued up as one frame (no real line does that).
warm() { "$LEC" --port "$1" --baud "${2:-38400}" --retries 5 status >/dev/null 2>&1 || true; }
# full_run: the scenarios below it guards run in the optimised tree only. Under
# the sanitizers (LEC6_SANITIZED) the test runs alone for about 100 s, wire
# time the sanitizers add nothing to; there the findings whose code the other
# scenarios already run (another master, Td, lumps, Silent INT, the three
# combinations, the dead line) are left to the optimised tree, and the
# sanitized run keeps one of each path: search, echo, noise, duplicates,
# the latency timer and --fix, the fast twin, bad ports, through lec serve.
full_run() { [[ -z ${LEC6_SANITIZED:-} ]]; }
# only_info NAME: no WARN or BROKEN line.
only_info() { ! grep -qE '^  (WARN|BROKEN) ' "$TMP/$1.doc"; }

# A clean line: healthy, information only.
start_twin clean --pty "$TMP/clean" --ids 1 --strict-baud || exit 1
warm "$TMP/clean"
# A reply the loaded host made late turns "the line is clean" into "garbles
# nothing; a few replies came late" (a clean make test run, 2026-11-29): that
# gets another run too.
doctor_while '[[ $RC -eq 7 || $RC -eq 8 ]] || ! has clean "the line is clean"' \
  clean --port "$TMP/clean" doctor --ids 1-4
check "clean: exit 0" test "$RC" -eq 0
check "clean: healthy" has clean "healthy"
check "clean: information only" only_info clean
check "clean: the baud and ID" has clean "ID 1 at 38400"
check "clean: line quality clean" has clean "the line is clean"
# --reply-margin: the controllers' reads refused it once (a Client on the master given it again: exit 2).
doctor_expect 0 clean-json --port "$TMP/clean" --reply-margin 100ms --json doctor --ids 1-4
check_sh "clean --json: health and baud" \
  "/usr/bin/python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d[\"health\"]==\"healthy\" and d[\"baud\"]==38400 and d[\"ids\"]==[1], d' '$TMP/clean-json.doc'"
stop_twin "$TWIN_PID"

# The integration case: IDs 1 and 3 at 57600, ID 3 with an alarm; no options.
start_twin two --pty "$TMP/two" --ids 1,3 --baud 57600 --strict-baud || exit 1
L3() { "$LEC" --port "$TMP/two" --baud 57600 --id 3 "$@" >/dev/null 2>&1; }
L3 serial on && L3 servo on && L3 home
L3 move --to 900  # beyond the stroke: alarm 62
doctor_expect 7 two --port "$TMP/two" doctor
check "two: exit 7 (degraded: an alarm)" test "$RC" -eq 7
check "two: both IDs and the baud" has two "ID 1 and 3 at 57600; nothing at 38400, 9600, 19200"
check "two: --baud named" has two "give --baud 57600"
check "two: the alarm and its meaning" has two "alarm 62"
check "two: the command that clears it" has two "lec --port $TMP/two --baud 57600 --id 3 reset"
check "two: ID 1 needs serial mode first" has two "--id 1 serial on"
doctor two-fix --port "$TMP/two" --baud 57600 doctor --ids 1-3 --fix
check "two --fix: the alarm cleared" has two-fix "alarm 62 cleared (RESET)"
check "two --fix: serial mode left alone (a PLC may drive it)" hasnt two-fix "serial mode on (Y30)"
check "two --fix: names the command that would" has two-fix "lec doctor --fix --serial-ids 1"
check "two --fix: nothing moved" has two-fix "nothing was moved"
doctor_finds "serial mode on (Y30)" two-serial --port "$TMP/two" --baud 57600 doctor --ids 1-3 --fix --serial-ids 1
check "two --fix --serial-ids 1: serial mode on" has two-serial "serial mode on (Y30)"
stop_twin "$TWIN_PID"

# Echo: a 2-wire adapter.
start_twin echo --pty "$TMP/echo" --ids 1 --echo-adapter --strict-baud || exit 1
warm "$TMP/echo"
doctor_expect 8 echo --port "$TMP/echo" doctor --ids 1-4
check "echo: exit 8" test "$RC" -eq 8
check "echo: named, with --echo verified" has echo "add --echo to every lec command (verified"
doctor_healthy echo-fixed --port "$TMP/echo" --echo doctor --ids 1-4
check "echo with --echo: healthy" test "$RC" -eq 0
stop_twin "$TWIN_PID"

# Noise on the line: about a third of the exchanges lost. (At 400, half of
# them, the search once found no controller at any rate: it now asks again at
# the first rate when it hears noise, 1 + kNoisyRescans scans.)
start_twin noise --pty "$TMP/noise" --ids 1 --noise-rate 250 --seed 7 --strict-baud || exit 1
warm "$TMP/noise"
doctor noise --port "$TMP/noise" doctor --ids 1-4
check "noise: degraded or broken" test "$RC" -eq 7 -o "$RC" -eq 8
check "noise: the causes in order" has noise "likely causes, in order: termination"
stop_twin "$TWIN_PID"

# Two controllers with ID 2.
start_twin dup --pty "$TMP/dup" --ids 1,2 --duplicate-ids 2 --strict-baud || exit 1
warm "$TMP/dup"
doctor_expect 8 dup --port "$TMP/dup" doctor --ids 1-4
check "duplicate: exit 8" test "$RC" -eq 8
check "duplicate: ID 2 named" has dup "two controllers answer ID 2"
stop_twin "$TWIN_PID"

if full_run; then
# A second master polling ID 1.
start_twin other --pty "$TMP/other" --ids 1 --other-master 20 --strict-baud || exit 1
warm "$TMP/other"
doctor_expect 8 other --port "$TMP/other" doctor --ids 1-4
check "other master: exit 8" test "$RC" -eq 8
check "other master: named" has other "another master polls this line"
stop_twin "$TWIN_PID"

# Td of 20 ms (the controller's Min Resp delay), lec assumes 5.
start_twin td --pty "$TMP/td" --ids 1 --td 20ms --strict-baud || exit 1
warm "$TMP/td"
doctor_expect 7 td --port "$TMP/td" doctor --ids 1-4
check "Td: exit 7" test "$RC" -eq 7
check "Td: inferred and named" has td "--td 20ms"
stop_twin "$TWIN_PID"
fi

# A USB adapter's latency timer at 16 ms (a stand-in sysfs: a pty has none), then --fix.
start_twin usb --pty "$TMP/usb" --ids 1 --strict-baud || exit 1
warm "$TMP/usb"
PTS=$(basename "$(readlink -f "$TMP/usb")")
mkdir -p "$TMP/sys/bus/usb-serial/devices/$PTS"
echo 16 >"$TMP/sys/bus/usb-serial/devices/$PTS/latency_timer"
LEC6_SYSFS_ROOT=$TMP/sys doctor_expect 7 usb --port "$TMP/usb" doctor --ids 1-4
check "usb latency: exit 7" test "$RC" -eq 7
check "usb latency: the command" has usb "echo 1 | sudo tee $TMP/sys/bus/usb-serial/devices/$PTS/latency_timer"
LEC6_SYSFS_ROOT=$TMP/sys doctor_healthy usb-fix --port "$TMP/usb" doctor --ids 1-4 --fix
check "usb latency --fix: set to 1 ms" test "$(cat "$TMP/sys/bus/usb-serial/devices/$PTS/latency_timer")" = 1
check "usb latency --fix: healthy" test "$RC" -eq 0
stop_twin "$TWIN_PID"

if full_run; then
# The latency timer again, as the twin plays it (replies in 16 ms lumps) and
# without a sysfs file to read: the doctor sees it in the round trips.
start_twin lumps --pty "$TMP/lumps" --ids 1 --strict-baud --usb-latency 16ms || exit 1
warm "$TMP/lumps"
LEC6_SYSFS_ROOT=$TMP/nosys doctor lumps --port "$TMP/lumps" doctor --ids 1-4
check "usb lumps: seen in the round trips" has lumps "a USB adapter's latency timer"
check "usb lumps: the fix" has lumps "set the adapter's latency timer to 1 ms"
stop_twin "$TWIN_PID"
fi

# A port no wire paces (the twin with --timing fast answers sooner than 38400
# baud carries the bytes): healthy, timing not judged, not "1000 timeouts".
start_twin fast --pty "$TMP/fast" --ids 1 --timing fast || exit 1
warm "$TMP/fast"
doctor_healthy fast --port "$TMP/fast" doctor --ids 1-4
check "fast twin: exit 0" test "$RC" -eq 0
check "fast twin: timing not judged, said why" has fast "no RS485 line paces this port"
check "fast twin: line clean" has fast "the line is clean"
stop_twin "$TWIN_PID"

if full_run; then
# Silent INT 20 (Ts = 70 chars, 18 ms at 38400), lec assumes 1: a query in two parts is still one frame.
start_twin ts --pty "$TMP/ts" --ids 1 --silent-interval 20 --strict-baud || exit 1
warm "$TMP/ts"
doctor_expect 7 ts --port "$TMP/ts" doctor --ids 1-4
check "Silent INT: exit 7" test "$RC" -eq 7
# (On a loaded host the split-query probe may not bracket Ts; the Td finding
# then names Silent INT too.)
check "Silent INT: named" has ts "Silent INT is"
stop_twin "$TWIN_PID"

# Combination 1: echo and a wrong baud.
start_twin c1 --pty "$TMP/c1" --ids 2 --baud 19200 --strict-baud --echo-adapter || exit 1
warm "$TMP/c1" 19200
doctor_expect 8 c1 --port "$TMP/c1" doctor --ids 1-4
check "echo + baud: exit 8" test "$RC" -eq 8
check "echo + baud: the baud" has c1 "ID 2 at 19200"
check "echo + baud: the echo" has c1 "add --echo"
stop_twin "$TWIN_PID"

# Combination 2: another master and a long Td.
start_twin c2 --pty "$TMP/c2" --ids 1 --other-master 10 --td 20ms --strict-baud || exit 1
warm "$TMP/c2"
doctor_expect 8 c2 --port "$TMP/c2" doctor --ids 1-4
check "other master + Td: the master" has c2 "another master polls this line"
check "other master + Td: broken" test "$RC" -eq 8
stop_twin "$TWIN_PID"

# Combination 3: a duplicate ID at 115200 with an alarm on the other ID.
start_twin c3 --pty "$TMP/c3" --ids 1,4 --duplicate-ids 4 --baud 115200 --strict-baud || exit 1
L1() { "$LEC" --port "$TMP/c3" --baud 115200 --retries 3 --id 1 "$@" >>"$TMP/c3-setup.log" 2>&1; }
# The setup is not under test, but the alarm finding needs it: ID 1 homed,
# then alarm 62 from a move past its stroke (on a loaded host a first try
# once left ID 1 unhomed and no alarm to find). Tried twice, then said.
c3_alarm() {
  L1 serial on && L1 servo on && L1 home || return 1
  L1 move --to 900 || true # refused by the controller: alarm 62
  "$LEC" --port "$TMP/c3" --baud 115200 --retries 3 --id 1 --json status 2>>"$TMP/c3-setup.log" |
    /usr/bin/python3 -c 'import json,sys; sys.exit(0 if 62 in [a["code"] if isinstance(a, dict) else a for a in json.load(sys.stdin)["alarms"]] else 1)'
}
c3_alarm || { L1 reset; c3_alarm; } || { cat "$TMP/c3-setup.log"; check "dup + baud + alarm: alarm 62 set up on ID 1" false; }
doctor_expect 8 c3 --port "$TMP/c3" doctor --ids 1-4
check "dup + baud + alarm: exit 8" test "$RC" -eq 8
check "dup + baud + alarm: the baud" has c3 "at 115200"
check "dup + baud + alarm: the duplicate" has c3 "two controllers answer ID 4"
check "dup + baud + alarm: the alarm" has c3 "alarm 62"
stop_twin "$TWIN_PID"

# A dead line: nothing answers at any baud, within the budget.
start_twin dead --pty "$TMP/dead" --ids 1 --drop-rate 1 || exit 1
doctor_expect 8 dead --port "$TMP/dead" doctor
check "dead: exit 8" test "$RC" -eq 8
check "dead: nothing answers at any baud" has dead "nothing answers at any baud"
check "dead: the list of what to check" has dead "A/B (+/-) are not swapped"
check "dead: within 30 s (took $SECS s)" test "$SECS" -lt 30
stop_twin "$TWIN_PID"
fi

# Bad input: a port that does not exist.
doctor missing --port "$TMP/no-such-port" doctor
check "missing port: exit 3" test "$RC" -eq 3
check "missing port: named" has missing "$TMP/no-such-port"

# Bad input: the port held by lec serve: named, with the way through it.
start_twin held --pty "$TMP/held" --ids 1 || exit 1
MB=$(/usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
"$LEC" serve --port "$TMP/held" --ids 1 --modbus-tcp "127.0.0.1:$MB" --http "" >"$TMP/serve.out" 2>&1 &
SERVE=$!
TWIN_PIDS+=("$SERVE")
wait_for 10 "lec serve's Modbus TCP port" -- \
  /usr/bin/python3 -c "import socket,sys; socket.create_connection(('127.0.0.1',$MB),0.2)"
doctor busy --port "$TMP/held" doctor
check "busy: exit 3" test "$RC" -eq 3
check "busy: the holder named" has busy "port busy (another program has it open: pid $SERVE"
check "busy: lec serve and the way through it" has busy "go through it with --port tcp://127.0.0.1:$MB"
doctor through --port "tcp://127.0.0.1:$MB" doctor --ids 1-2
check "through lec serve: the controller's state" has through "ID 1"
check "through lec serve: not broken" test "$RC" -ne 8 -a "$RC" -ne 3
stop_twin "$SERVE"
stop_twin "$TWIN_PID"

finish
