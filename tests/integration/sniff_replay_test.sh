#!/usr/bin/env bash
# Issue 24's proof with a third-party master: python3-pymodbus drives `lec
# sim`, `lec sniff` takes a capture on the twin's listen-only tap, and `lec
# replay` re-sends the captured queries to a twin of the same settings: every
# reply is the captured one. Then `lec sim --calibrate` reads the same capture.

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need --module pymodbus.client

MASTER=$IT_DIR/sniff_master.py

if start_twin t --pty "$TMP/p" --tap "$TMP/tap" --baud 38400; then
  "$LEC" sniff --port "$TMP/tap" --baud 38400 --capture "$TMP/cap.jsonl" >"$TMP/s.out" 2>"$TMP/s.err" &
  SNIFF_PID=$!
  TWIN_PIDS+=("$SNIFF_PID")
  wait_for 10 "lec sniff listening" -- grep -q "listening on" "$TMP/s.err"
  out=$(timeout 60 "$PY" "$MASTER" "$TMP/p" 38400 200 2>/dev/null)
  check "pymodbus drove the twin: $out" [ -n "$out" ]
  sleep 0.3  # the tap's last bytes
  kill -INT "$SNIFF_PID"
  wait_bounded "$SNIFF_PID" 10
  stop_twin "$TWIN_PID"
  queries=$(grep -c '"dir":"query"' "$TMP/cap.jsonl" || true)
  check "the capture holds the master's queries ($queries)" [ "$queries" -ge 190 ]
  # The tap's timestamps jitter with the sniffer's reads on a loaded machine:
  # response times are not judged here (the round trip on a virtual clock is).
  "$LEC" --json replay "$TMP/cap.jsonl" --response-tolerance 1000 >"$TMP/r.json" 2>"$TMP/r.err"
  rc=$?
  check "lec replay of the sniffed capture matches (exit $rc): $(head -c 300 "$TMP/r.err")" [ "$rc" = 0 ]
  check "  every exchange identical" "$PY" -c '
import json, sys
d = json.load(open(sys.argv[1]))
print(d["exchanges"], d["identical"])
sys.exit(0 if d["exchanges"] >= 190 and d["identical"] == d["exchanges"] else 1)' "$TMP/r.json"
  "$LEC" sim --calibrate "$TMP/cap.jsonl" >"$TMP/fitted.yaml" 2>"$TMP/fit.err"
  check "lec sim --calibrate reads the sniffed capture (exit $?)" grep -q "delay_ms:" "$TMP/fitted.yaml"
fi

finish
