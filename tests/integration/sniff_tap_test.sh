#!/usr/bin/env bash
# `lec sniff` on the twin's tap (`lec sim --tap`): third-party masters
# (mbpoll, python3-pymodbus, a libmodbus program) drive the twin; every frame
# the twin's --trace logs is in the sniff output, paired and decoded, none
# lost, merged or split; with the tap in 16 ms USB lumps too; noise shows as
# noise; a master that skips Ts (libmodbus), a late twin (--extra-delay) and
# two masters at once are flagged; a missing port and a cut capture file get
# clear errors. (10^5 exchanges: tests/sim/sniff_line_test.cpp on virtual
# time, and `make soak`.)

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need --program mbpoll --program tshark --module pymodbus.client

MASTER=$IT_DIR/sniff_master.py
COMPARE=$IT_DIR/sniff_compare.py
PEER=$LEC6_BUILD_DIR/peers/libmodbus_peer

# start_sniff NAME ARGS...: `lec sniff ARGS... --json` in the background, its
# output in $TMP/NAME.jsonl; waits for "listening on" (≤ 10 s). Sets SNIFF_PID.
start_sniff() {
  local name=$1
  shift
  "$LEC" sniff "$@" --json >"$TMP/$name.jsonl" 2>"$TMP/$name.err" &
  SNIFF_PID=$!
  TWIN_PIDS+=("$SNIFF_PID")
  wait_for 10 "lec sniff listening" -- grep -qs "listening on" "$TMP/$name.err"
}
# stop_sniff: SIGINT, as a user's Ctrl-C; the statistics come last.
stop_sniff() {
  sleep 0.3  # the tap's last bytes (a reply is written at its end instant)
  kill -INT "$SNIFF_PID"
  wait_bounded "$SNIFF_PID" 10
}
# compare NAME MODE: runs sniff_compare.py on the twin's trace and the sniff output.
compare() {
  COMPARED=$("$PY" "$COMPARE" "$TMP/$1.err" "$TMP/$2.jsonl" "$3" 2>&1)
  local rc=$?
  sed 's/^/    /' <<<"$COMPARED"
  return $rc
}
count() { sed -n "s/^$1=//p" <<<"$COMPARED"; }

# ---- 1: mbpoll, pymodbus and libmodbus in turn, tap without latency ----------
if start_twin t1 --pty "$TMP/p1" --tap "$TMP/tap1" --trace --baud 38400; then
  grep -q "tap $TMP/tap1 listen-only" <<<"$READY" && pass "the ready line names the tap" ||
    fail "the ready line names the tap: $READY"
  start_sniff s1 --port "$TMP/tap1" --baud 38400 --capture "$TMP/s1.capture.jsonl" --pcap "$TMP/s1.pcap"
  check "lec sniff says it never transmits" grep -q "listen-only: lec sniff never transmits" "$TMP/s1.err"
  timeout --signal=INT 3 mbpoll -m rtu -a 1 -b 38400 -P none -0 -t 4 -r 36864 -c 2 -l 10 "$TMP/p1" >/dev/null 2>&1
  out=$(timeout 60 "$PY" "$MASTER" "$TMP/p1" 38400 300 2>/dev/null)
  check "pymodbus: $out" [ -n "$out" ]
  timeout --signal=INT 3 mbpoll -m rtu -a 1 -b 38400 -P none -0 -t 0 -r 25 -l 10 "$TMP/p1" 1 >/dev/null 2>&1
  if [ -x "$PEER" ]; then timeout 120 "$PEER" "$TMP/p1" >/dev/null 2>&1; fi
  stop_sniff
  if compare t1 s1 same; then pass "every traced frame heard, paired, decoded, in order"; else fail "every traced frame heard"; fi
  check "  with hundreds of exchanges ($(count reply) replies)" [ "$(count reply)" -gt 300 ]
  check "  no reply nobody asked for" [ "$(count unsolicited)" = 0 ]
  check "  the masters that skip Ts (libmodbus, mbpoll) flagged: $(count short_silence)" [ "$(count short_silence)" -gt 0 ]
  # (No check that nothing is judged late: on a loaded machine the sniffer's read
  # times jitter by milliseconds; the exact verdicts are tested on virtual time.)
  # tshark reads the pcap as Modbus RTU: the same frames, the same function codes.
  tshark -o 'uat:user_dlts:"User 0 (DLT=147)","mbrtu","0","","0",""' -r "$TMP/s1.pcap" \
    -T fields -e modbus.func_code >"$TMP/s1.tshark" 2>"$TMP/s1.tshark.err"
  "$PY" -c '
import json, sys
fns = [int(l.split()[0]) for l in open(sys.argv[1]) if l.strip()]
ours = [int(j["hex"].split()[1], 16) & 0x7F for j in map(json.loads, open(sys.argv[2]))
        if j.get("dir") in ("query", "reply")]
print(len(fns), len(ours)); sys.exit(0 if fns == ours and fns else 1)' "$TMP/s1.tshark" "$TMP/s1.jsonl" >"$TMP/s1.fns" 2>&1
  rc=$?  # (taken before the message's $(cat …), which would set $? to cat's)
  check "tshark decodes the --pcap as Modbus RTU: same frames, same function codes ($(cat "$TMP/s1.fns"))" [ $rc = 0 ]
  # The capture replays through the same decoder: the same frames.
  "$LEC" sniff --read "$TMP/s1.capture.jsonl" --json >"$TMP/r1.jsonl" 2>"$TMP/r1.err"
  check "lec sniff --read replays the capture (exit 0)" [ $? = 0 ]
  a=$(grep -c '"dir":"reply"' "$TMP/s1.jsonl"); b=$(grep -c '"dir":"reply"' "$TMP/r1.jsonl")
  check "  the same replies ($a live, $b replayed)" [ "$a" = "$b" ]
  stop_twin "$TWIN_PID"
fi

# ---- 2: the tap in 16 ms lumps, a thousand exchanges ------------------------------
# `make soak` sets SNIFF_EXCHANGES=100000 SNIFF_BAUDS="115200 9600" (and 10^5 on
# the virtual clock: tests/sim/sniff_line_test.cpp).
N=${SNIFF_EXCHANGES:-1000}
for baud in ${SNIFF_BAUDS:-115200}; do
  limit=$((N * (baud < 20000 ? 60 : 40) / 1000 + 60))
  if start_twin t2 --pty "$TMP/p2" --tap "$TMP/tap2" --tap-latency 16ms --trace --baud "$baud"; then
    start_sniff s2 --port "$TMP/tap2" --baud "$baud" --capture "$TMP/s2.capture.jsonl"
    out=$(timeout "$limit" "$PY" "$MASTER" "$TMP/p2" "$baud" "$N" 2>/dev/null)
    check "pymodbus at $baud baud: $out" [ -n "$out" ]
    stop_sniff
    if compare t2 s2 same; then pass "$baud baud, 16 ms lumps: every frame heard, none lost, merged or split"; else fail "$baud baud, 16 ms lumps"; fi
    check "  $N replies" [ "$(count reply)" = "$N" ]
    check "  the lumps were noticed (timing not judged)" grep -q '"lumpy":true' "$TMP/s2.jsonl"
    # Replayed, frames that shared a read are fed as one chunk again: the same lumps.
    "$LEC" sniff --read "$TMP/s2.capture.jsonl" --json >"$TMP/r2.jsonl" 2>/dev/null
    check "  replayed: the same $N replies, the lumps noticed again" \
      [ "$(grep -c '"dir":"reply"' "$TMP/r2.jsonl")" = "$N" ] && grep -q '"lumpy":true' "$TMP/r2.jsonl"
    stop_twin "$TWIN_PID"
  fi
done

# ---- 3: noise on the line -------------------------------------------------------
if start_twin t3 --pty "$TMP/p3" --tap "$TMP/tap3" --trace --baud 115200 --noise-rate 30; then
  start_sniff s3 --port "$TMP/tap3" --baud 115200
  timeout 60 "$PY" "$MASTER" "$TMP/p3" 115200 500 >/dev/null 2>&1
  stop_sniff
  if compare t3 s3 subsequence; then pass "noise: no traced frame lost"; else fail "noise: no traced frame lost"; fi
  check "  the noise shown as noise ($(count noise) bursts)" [ "$(count noise)" -gt 0 ]
  stop_twin "$TWIN_PID"
fi

# ---- 4: a late twin ---------------------------------------------------------------
if start_twin t4 --pty "$TMP/p4" --tap "$TMP/tap4" --trace --baud 115200 --extra-delay 30ms; then
  start_sniff s4 --port "$TMP/tap4" --baud 115200
  timeout 60 "$PY" "$MASTER" "$TMP/p4" 115200 40 >/dev/null
  stop_sniff
  compare t4 s4 same >/dev/null
  # Every reply whose time could be measured (a loaded host's reader may get a
  # query and its reply in one read: not timed), but two: a reader stalled
  # 25 ms or more between the query's bytes and the reply's dates the query's
  # end that much late, and the reply then looks in time (a clean make test
  # run, 2026-11-29, under the sanitizers at -j4: 39 of 40). Without the late
  # rule none would be late.
  check "--extra-delay 30ms: every timed reply but two judged late ($(count late) of $(count timed) timed, $(count reply) replies)" \
    [ "$(count late)" -ge "$(($(count timed) - 2))" -a "$(count timed)" -gt 20 ]
  stop_twin "$TWIN_PID"
fi

# ---- 5: two masters at once ---------------------------------------------------------
if start_twin t5 --pty "$TMP/p5" --tcp 127.0.0.1:0 --tap "$TMP/tap5" --baud 38400; then
  url=$(grep -o 'rtu+tcp://[0-9.:]*' <<<"$READY")
  start_sniff s5 --port "$TMP/tap5" --baud 38400
  # Collisions are what this case makes: each costs a master its timeout
  # (0.2 s: a reply at 38400 takes ~15 ms; 1 s made this case 40 s long).
  SNIFF_MASTER_TIMEOUT=0.2 timeout 60 "$PY" "$MASTER" "$TMP/p5" 38400 100 >/dev/null &
  m1=$!
  SNIFF_MASTER_TIMEOUT=0.2 timeout 60 "$PY" "$MASTER" "tcp://${url#rtu+tcp://}" 100 >/dev/null
  wait "$m1"
  stop_sniff
  second=$(grep -o '"second_master":[0-9]*' "$TMP/s5.jsonl" | tail -1 | cut -d: -f2)
  check "two masters on one line flagged ($second queries)" [ "${second:-0}" -gt 0 ]
  stop_twin "$TWIN_PID"
fi

# ---- 6: bad input -------------------------------------------------------------------
rc=0; err=$("$LEC" sniff --port "$TMP/no-such-port" 2>&1) || rc=$?
check "a missing port: exit 3, named ($err)" [ "$rc" = 3 ] && grep -q "cannot open $TMP/no-such-port" <<<"$err"
if [ -f "$TMP/s1.capture.jsonl" ]; then
  size=$(stat -c %s "$TMP/s1.capture.jsonl")
  head -c $((size - 7)) "$TMP/s1.capture.jsonl" >"$TMP/cut.jsonl"
  rc=0; err=$("$LEC" sniff --read "$TMP/cut.jsonl" 2>&1) || rc=$?
  lines=$(wc -l <"$TMP/cut.jsonl")
  check "a cut capture: exit 1, file, line and byte named ($err)" \
    [ "$rc" = 1 ] && grep -qE "cut.jsonl, line $((lines + 1)) \(byte [0-9]+\): the file ends in the middle" <<<"$err"
  printf '{"format":"lec6-capture","version":1}\n{"t_us":1,"end_us":2,"dir":"query","hex":"0G"}\n' >"$TMP/bad.jsonl"
  rc=0; err=$("$LEC" sniff --read "$TMP/bad.jsonl" 2>&1) || rc=$?
  check "a corrupt capture: exit 1 ($err)" [ "$rc" = 1 ] && grep -qF "bad.jsonl, line 2 (byte 38): 'hex' has 'G' at digit 2" <<<"$err"
fi
finish
