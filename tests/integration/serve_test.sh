#!/usr/bin/env bash
# lec serve against the twin on a real pseudo-terminal holding IDs 1-4, with
# real clients at once: mbpoll (Modbus TCP), python3-pymodbus writing steps,
# `lec watch` and `lec move` through the daemon, curl on the HTTP API. Then a
# configured ID that does not exist, fifty polling clients (the cache), a
# broken MBAP frame, a client killed mid-request, RTU over TCP, and SIGTERM.
#
# Every wait is on an event (a ready line, a reply, a process ending) with a
# deadline; nothing sleeps to synchronise.
set -u
: "${LEC:?LEC must name the lec binary}"
IT_DIR=$(cd "$(dirname "$0")" && pwd)
PY=/usr/bin/python3
CLIENTS="$PY $IT_DIR/serve_clients.py"
TMP=$(mktemp -d "${TMPDIR:-/tmp}/lec6-serve-XXXXXX")
PIDS=()
PASSED=0
FAILED=0

cleanup() {
  for p in "${PIDS[@]}"; do kill -KILL "$p" 2>/dev/null; done
  wait 2>/dev/null
  rm -rf "$TMP"
}
trap cleanup EXIT

pass() { echo "ok   $*"; PASSED=$((PASSED + 1)); }
fail() { echo "FAIL $*"; FAILED=$((FAILED + 1)); }
check() { local what=$1; shift; if "$@"; then pass "$what"; else fail "$what"; fi; }
jget() { $PY -c 'import json,sys; d=json.loads(sys.argv[1]); print(eval(sys.argv[2]))' "$1" "$2"; }
for tool in mbpoll curl; do
  command -v $tool >/dev/null || { echo "missing $tool: sudo apt-get install -y $tool"; exit 1; }
done

# start NAME ARGS...: runs `$LEC ARGS...` in the background, stdout into a
# fifo read until its ready line (10 s at most). Sets PID and READY.
start() {
  local name=$1; shift
  mkfifo "$TMP/$name.fifo"
  "$LEC" "$@" >"$TMP/$name.fifo" 2>"$TMP/$name.err" &
  PID=$!
  PIDS+=("$PID")
  exec {fd}<"$TMP/$name.fifo"
  READY=""
  read -r -t 10 -u "$fd" READY || true
  # Keep draining stdout so the process never blocks on a full pipe.
  cat <&"$fd" >"$TMP/$name.out" &
  exec {fd}<&-
  [[ -n $READY ]] || { echo "$name did not start: $(cat "$TMP/$name.err")"; return 1; }
}

# stop_wait PID SECONDS: waits for the child PID to end, SIGKILL after SECONDS;
# STATUS = its exit status. `wait` returns on the event; the killer is the deadline.
stop_wait() {
  local pid=$1 limit=$2
  ( sleep "$limit"; kill -KILL "$pid" 2>/dev/null ) &
  local killer=$!
  wait "$pid" 2>/dev/null
  STATUS=$?
  kill -KILL "$killer" 2>/dev/null
  wait "$killer" 2>/dev/null
}

start twin sim --pty "$TMP/pty" --ids 1-4 || exit 1
# 5 Hz telemetry leaves the line room, so the cache test below measures the cache.
# ID 5 is configured but the twin does not have it: a dead controller.
start serve serve --port "$TMP/pty" --ids 1-5 --telemetry-hz 5 --modbus-tcp 127.0.0.1:0 --rtu-tcp 127.0.0.1:0 \
  --http 127.0.0.1:0 || exit 1
SERVE=$PID
MB=$(grep -o 'tcp://127.0.0.1:[0-9]*' <<<"$READY" | head -1 | sed 's|.*:||')
RTU=$(grep -o 'rtu+tcp://127.0.0.1:[0-9]*' <<<"$READY" | sed 's|.*:||')
HTTP=http://$(grep -o 'http://[0-9.:]*' <<<"$READY" | sed 's|http://||')
echo "serve: $READY"
L() { "$LEC" --port "tcp://127.0.0.1:$MB" "$@"; }
check "the start says which port and axes each line has" \
  grep -q "line line1 on $TMP/pty @ 38400 baud: axis1=1, axis2=2, axis3=3, axis4=4, axis5=5" "$TMP/serve.err"
check "5 IDs at 5 Hz fit the line: no telemetry note" \
  bash -c "! grep -q 'telemetry at these rates' '$TMP/serve.err'"

# ---- four clients at once -------------------------------------------------------
L --id 1 serial on >/dev/null && L --id 1 servo on >/dev/null && L --id 1 home >/dev/null
check "lec through the daemon: ID 1 homed" test $? -eq 0
( for i in 1 2 3 4 5; do mbpoll -m tcp -a 2 -p "$MB" -t 4 -r 36864 -c 7 -0 -1 127.0.0.1; done ) \
  >"$TMP/mbpoll.out" 2>&1 &
MBPOLL=$!
$CLIENTS pymodbus-steps "$MB" 3 >"$TMP/pymodbus.out" 2>&1 &
PYM=$!
L --id 1 --json watch --count 20 >"$TMP/watch.out" 2>&1 &
WATCH=$!
L --id 1 move --to 150 >"$TMP/move.out" 2>&1 &
MOVE=$!
( curl -s -w '\n' -XPOST "$HTTP/api/axes/axis4/serial" -d '{"on":true}' &&
  curl -s -w '\n' -XPOST "$HTTP/api/axes/axis4/servo" -d '{"on":true}' &&
  curl -s -w '\n' -XPOST "$HTTP/api/axes/axis4/home" &&
  curl -s -w '\n' -XPOST "$HTTP/api/axes/axis4/move" -d '{"position_mm": 75.5, "speed_mm_s": 300}' ) \
  >"$TMP/curl.out" 2>&1 &
CURL=$!
wait $MBPOLL; check "mbpoll -m tcp exits 0" test $? -eq 0
wait $PYM
wait $WATCH; check "lec watch through the daemon exits 0" test $? -eq 0
wait $MOVE; MOVE_STATUS=$?
wait $CURL
check "mbpoll read D9000x7 of ID 2 five times" test "$(grep -c '^\[36864\]:' "$TMP/mbpoll.out")" -eq 5
check "pymodbus wrote step 5 of ID 3 and read it back" \
  test "$(jget "$(cat "$TMP/pymodbus.out")" 'd["equal"]')" = True
check "lec move --to 150 through the daemon exits 0: $(cat "$TMP/move.out")" test $MOVE_STATUS -eq 0
pos=$(L --id 1 --json status | $PY -c 'import json,sys; print(json.load(sys.stdin)["position_mm"])')
check "ID 1 ends at its target (150.0): $pos" test "$pos" = 150.0
check "lec watch printed its samples" test "$(grep -c position_mm "$TMP/watch.out")" -ge 10
last=$(tail -n 1 "$TMP/curl.out")
check "curl: the HTTP move of axis4 reached 75.50 mm: $last" \
  test "$(jget "$last" 'd["outcome"] + " " + str(d["position_mm"])')" = "reached 75.5"
check "the step pymodbus wrote reads back through lec" \
  grep -q "123.45" <(L --id 3 step get 5)

# per_s COUNT-BEFORE COUNT-AFTER T-BEFORE T-AFTER: a counter's rate over a window.
per_s() {
  $PY -c 'import sys; a, b, t, u = map(float, sys.argv[1:]); print(round((b - a) / (u - t), 1))' "$@"
}

# ---- clients that fill the line leave a move and the telemetry their turn ----------
# Three clients send FC08 (never cached) to ID 1 back to back for 10 s: the line is
# full of client commands. A move of axis4 started then must end (its completion
# polls take turns with them) while they still poll, and ID 2's telemetry go on.
# answers ID: the exchanges with controller ID so far.
answers() { curl -s "$HTTP/metrics" | awk -v id="$1" -F'[ "]' '/^lec6_device_transactions_total/ && $4 == id {print $NF}'; }
mkfifo "$TMP/echo.fifo"
$CLIENTS echo "$MB" 3 10 1 >"$TMP/echo.fifo" &
ECHO=$!
PIDS+=("$ECHO")
exec 7<"$TMP/echo.fifo"
read -r -t 30 -u 7 echo_ready
c0=$(answers 2); s0=$EPOCHREALTIME
moved=$(curl -s -XPOST "$HTTP/api/axes/axis4/move" -d '{"position_mm": 380, "speed_mm_s": 100}')
c1=$(answers 2); s1=$EPOCHREALTIME
kill -0 $ECHO 2>/dev/null && still=polling || still=gone
echo_out=$(cat <&7); exec 7<&-
wait $ECHO
check "three echo clients filled the line ($echo_ready): $echo_out" \
  test "$echo_ready $(jget "$echo_out" 'd["errors"] == 0 and d["min_answers"] > 20')" = "ready True"
check "a move under them reached 380 mm while they still polled ($still): $moved" \
  test "$(jget "$moved" 'd["outcome"] + " " + str(d["position_mm"])') $still" = "reached 380.0 polling"
t2=$(per_s "$c0" "$c1" "$s0" "$s1")
# The line carries ~60 exchanges/s; the clients keep a third to half of it, the
# move's polls and the telemetry of four axes share the rest (strict priority: ~0/s;
# shared: 4-8/s, 3.8 seen under ASan on a loaded host).
check "ID 2's telemetry went on meanwhile: $t2 reads/s (asked: 5 Hz x flags, state, ~12/s)" \
  $PY -c 'import sys; sys.exit(float(sys.argv[1]) < 2)' "$t2"

# ---- the cache: fifty clients polling cost the line (almost) nothing --------------
# The line's load is its telemetry plus the client reads that reach it: count
# those directly (client requests done minus those the cache answered), rather
# than compare two windows' rates, which a loaded machine moves by itself.
prom() { curl -s "$HTTP/metrics" | awk -v m="$1" -v l="$2" 'index($0, m) == 1 && index($0, l) {print $NF}'; }
client_reqs() { prom lec6_request_latency_seconds_count 'priority="command"'; }
cache_hits() { prom lec6_line_cache_hits_total '{'; }
rate() { prom lec6_line_transactions_total '{'; }
r0=$(client_reqs); h0=$(cache_hits); t0=$(rate); s0=$EPOCHREALTIME
$CLIENTS poll "$MB" 50 3 >"$TMP/poll.out"
r1=$(client_reqs); h1=$(cache_hits); t1=$(rate); s1=$EPOCHREALTIME
out=$(cat "$TMP/poll.out")
check "50 clients each got answers: $out" test "$(jget "$out" 'd["min_answers"] > 0 and d["errors"] == 0 and d["mismatched"] == 0')" = True
to_line=$($PY -c 'import sys; r0, r1, h0, h1 = map(float, sys.argv[1:]); print(int(r1 - r0 - (h1 - h0)))' "$r0" "$r1" "$h0" "$h1")
answered=$(jget "$out" 'd["total"]')
check "50 clients: $to_line of their $answered reads reached the line (at most 1 %; line at $(per_s "$t0" "$t1" "$s0" "$s1") transactions/s)" \
  test $((to_line * 100)) -le "$answered"

# ---- a dead controller is backed off and costs the others nothing much -------------
# Three seconds of ordinary traffic, then each live ID's telemetry counted. A
# wall-clock window: a host loaded by the tests beside it once held the daemon
# and its real-time twin past it (27 of 31 exchanges, every ID alike, make test
# 2026-11-28), so a second window is taken when the first falls short; a dead
# ID that really costs the others fails both.
declare -A before got
for window in 1 2; do
  for id in 1 2 3 4; do before[$id]=$(answers $id); done
  t_start=$(date +%s%N)
  $CLIENTS poll "$MB" 1 3 >/dev/null
  t_end=$(date +%s%N)
  secs=$(( (t_end - t_start) / 1000000 ))
  short=0
  for id in 1 2 3 4; do
    got[$id]=$(( $(answers $id) - before[$id] ))
    # 5 Hz of flags + state (10 exchanges/s) at least, 90 % of it.
    (( got[$id] * 1000 >= secs * 9 )) || short=1
  done
  [[ $short -eq 0 ]] && break
  [[ $window -eq 1 ]] && echo "    (window 1: ${got[1]}, ${got[2]}, ${got[3]}, ${got[4]} exchanges in $secs ms: a loaded host? once more)"
done
for id in 1 2 3 4; do
  check "ID $id kept its telemetry next to a dead ID 5: ${got[$id]} exchanges in $secs ms (window $window)" \
    test $((got[$id] * 1000)) -ge $((secs * 9))
done
axis5=$(curl -s "$HTTP/api/axes/axis5")
check "ID 5 is reported offline, with the reason" \
  test "$(jget "$axis5" 'd["online"] is False and "not answering" in d.get("offline_reason", "")')" = True
out=$(L --id 5 --retries 0 status 2>&1); st=$?
check "a client asking for ID 5 gets a fast, clear error (exit 3): $out" \
  test $st -eq 3 -a -n "$(grep -o 'did not answer' <<<"$out")"

# ---- protocol errors close that connection only; a killed client -----------------
out=$($CLIENTS bad-mbap "$MB")
check "a broken MBAP frame closes that connection, the other is answered: $out" \
  test "$(jget "$out" 'd["broken_closed"] and d["other_answered"]')" = True
mkfifo "$TMP/hold.fifo"
$CLIENTS hold "$MB" 20 >"$TMP/hold.fifo" &
HOLD=$!
read -r -t 10 sent <"$TMP/hold.fifo"  # its requests are out: kill it with them queued
kill -KILL $HOLD; wait $HOLD 2>/dev/null
check "after a client was killed mid-request the daemon still answers" L --id 2 status
check "RTU over TCP: lec status via rtu+tcp://" "$LEC" --port "rtu+tcp://127.0.0.1:$RTU" --id 4 status

# ---- bad input -------------------------------------------------------------------
code=$(curl -s -o "$TMP/bad.json" -w '%{http_code}' -XPOST "$HTTP/api/axes/axis1/move" -d '{"position_mm":150,"speed_mm_s":70000}')
check "HTTP: a speed out of range is 400 naming the field" \
  test "$code $(jget "$(cat "$TMP/bad.json")" 'd["field"]')" = "400 speed_mm_s"
out=$(L --id 9 status 2>&1); st=$?
check "an ID the daemon does not have: exit 3, exception 0A named: $out" \
  test $st -eq 3 -a -n "$(grep -o 'no controller with ID 9' <<<"$out")"
out=$("$LEC" --port "127.0.0.1:$MB" status 2>&1)
check "a URL without protocol gets the hint: $out" grep -q "tcp://127.0.0.1:$MB for Modbus TCP" <<<"$out"

# ---- telemetry that overfills the line is said at start --------------------------
start busy serve --port sim --ids 1-4 --telemetry-hz 10 --modbus-tcp 127.0.0.1:0 --http "" || exit 1
kill -TERM "$PID"
stop_wait "$PID" 10
check "4 axes at 10 Hz at 38400: the start says the line carries about 70 % of it" \
  grep -q "telemetry at these rates needs 143 % of the line at 38400 baud (4 axes, up to 10 Hz each): each axis refreshes at about 70 % of its telemetry_hz" "$TMP/busy.err"

# ---- SIGTERM: queued requests answered with an error, exit 0 -----------------------
mkfifo "$TMP/pipeline.fifo"
$CLIENTS pipeline "$MB" 30 >"$TMP/pipeline.fifo" &
PIPE=$!
exec {pfd}<"$TMP/pipeline.fifo"
read -r -t 10 -u "$pfd" sent  # all 30 are queued in the daemon: stop it now
kill -TERM "$SERVE"
stop_wait "$SERVE" 10
check "lec serve exits 0 on SIGTERM" test "$STATUS" -eq 0
read -r -t 20 -u "$pfd" out
exec {pfd}<&-
wait $PIPE
check "every pipelined request was answered (written or exception 06): $out" \
  test "$(jget "$out" 'd["answered"] == 30 and set(d["kinds"]) <= {"ok", "exception 06"}')" = True
grep -q "stopping" "$TMP/serve.err" && pass "the daemon logged its stop" || fail "no stop logged"

echo "$PASSED passed, $FAILED failed"
[[ $FAILED -eq 0 ]]
