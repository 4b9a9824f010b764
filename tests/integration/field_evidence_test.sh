#!/usr/bin/env bash
# Issue 33 end to end on real pseudo-terminals: the default twin and --ideal
# name themselves, the pty answers only its baud (--any-baud opts out), ALARM
# is cross-checked with the alarm code (an active-low twin is named so), the
# twin refuses FC06 with exception 01, and lec sniff names FC06 frames.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/lib.sh"
lec() { "$LEC" "$@"; }

# ---- which twin -------------------------------------------------------------------------
start_twin plain --baud 57600
grep -qF "profile default, busy-delay 20ms, busy-min 60ms, homing 50 mm/s, SETON cleared on re-home" "$tmp/plain.out" &&
  ok || bad "default twin's ready line: $(cat "$tmp/plain.out")"
# ---- the pty answers only its baud --------------------------------------------------------
expect_exit 3 "a master at 38400 on a 57600 line" -- lec --port "$tmp/plain" --baud 38400 --retries 0 status
contains "no reply at the wrong baud" "no reply"
expect_exit 0 "a master at 57600" -- lec --port "$tmp/plain" --baud 57600 status
start_twin anybaud --baud 57600 --any-baud --ideal
grep -qF "profile ideal" "$tmp/anybaud.out" && grep -qF "any baud" "$tmp/anybaud.out" &&
  ok || bad "--ideal --any-baud ready line: $(cat "$tmp/anybaud.out")"
expect_exit 0 "--any-baud answers 38400" -- lec --port "$tmp/anybaud" --baud 38400 status

# ---- FC06: the twin refuses it as the manual's function list says -------------------------
expect_exit 4 "FC06 to the twin" -- lec --port "$tmp/plain" --baud 57600 raw 01 06 91 00 01 00
contains "exception 01 to FC06" "<- 01 86 01"

# ---- ALARM never from X4F alone ---------------------------------------------------------------
cat >"$tmp/inverted.yaml" <<'YAML'
name: inverted
actuator:
  alarm_polarity: active-low
YAML
start_twin inv --profile "$tmp/inverted.yaml"
expect_exit 0 "status of an inverted controller" -- lec --port "$tmp/inv" status
contains "says it is inverted" "this controller reports ALARM inverted; set \`alarm_polarity: active-low\`"
contains "no alarm decided from X4F alone" "Alarms     none"
expect_exit 0 "status with the polarity set" -- lec --port "$tmp/inv" --alarm-polarity active-low status
[[ $out != *"Check"* && $out != *"ALARM"* ]] && ok || bad "with active-low: $out"
LEC_ALARM_POLARITY=active-low expect_exit 0 "the polarity from the environment" -- lec --port "$tmp/inv" status --json
[[ $(json '"alarm_check" in d, d["flags"]["alarm"]') == "(False, False)" ]] && ok || bad "env: $out"
expect_exit 2 "a polarity that does not exist" -- lec --port "$tmp/inv" --alarm-polarity low status

# ---- --port sim is lec sim's default twin; --sim-profile names another -------------------------
expect_exit 0 "--port sim --sim-profile ideal" -- lec --port sim --sim-profile ideal status
expect_exit 2 "a sim profile that cannot be read" -- lec --port sim --sim-profile "$tmp/none.yaml" status
contains "it is named" "--sim-profile: default, ideal or a field profile file: $tmp/none.yaml: cannot read the profile"

# ---- lec sniff names FC06 frames ----------------------------------------------------------------
cat >"$tmp/fc06.jsonl" <<'JSONL'
{"format":"lec6-capture","version":1,"source":"sniff","started_utc":"2026-11-27T00:00:00.000000Z","line":{"baud":38400,"parity":"N","data_bits":8,"stop_bits":1},"port":"hmi","tool":"test"}
{"t_us":1000,"end_us":3083,"dir":"query","hex":"010691000100a4a6"}
{"t_us":12000,"end_us":13300,"dir":"reply","hex":"01860183a0"}
JSONL
expect_exit 0 "sniff an FC06 HMI" -- lec sniff --read "$tmp/fc06.jsonl"
contains "FC06 named" "write single register (06h) D9100 <- 0100h (256)"
contains "its exception" "exception 01"

# ---- lec sniff frames an unknown function code and resynchronises -----------------------------
# A SCADA scan's 0x2B (read device identification), its exception 01, the scan again in one chunk
# with the next read (resent: no reply), and the read's reply.
cat >"$tmp/fc2b.jsonl" <<'JSONL'
{"format":"lec6-capture","version":1,"source":"sniff","started_utc":"2026-11-27T00:00:00.000000Z","line":{"baud":38400,"parity":"N","data_bits":8,"stop_bits":1},"port":"scada","tool":"test"}
{"t_us":1000,"end_us":2900,"dir":"query","hex":"012b0e01007077"}
{"t_us":8000,"end_us":9300,"dir":"reply","hex":"01ab019ef0"}
{"t_us":20000,"end_us":24000,"dir":"query","hex":"012b0e01007077010390000001a90a"}
{"t_us":30000,"end_us":32000,"dir":"reply","hex":"0103020064b9af"}
JSONL
expect_exit 0 "sniff an unknown function code" -- lec sniff --read "$tmp/fc2b.jsonl"
contains "FC 2Bh shown as unknown, with its bytes" \
  "01 2B 0E 01 00 70 77  | ID 1 unknown function 2Bh query, 7 bytes"
contains "its exception pairs with it" "ID 1 exception 01 (illegal function) to function 2Bh"
contains "the read after it in the same chunk is found" "ID 1 read D9000 current position"
contains "and its reply" "D9000 current position = 100"
contains "no noise" "0 noise bursts (0 bytes)"
contains "counted" "2 of an unknown function code"

finish
