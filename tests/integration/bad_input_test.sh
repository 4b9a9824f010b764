#!/usr/bin/env bash
# Bad input of every class (docs/robustness.md, "Bad input"): CLI arguments,
# out-of-range values, step-table files, frames, wrong IDs, broadcast misuse.
# A refused command exits 2 with a message naming the field and its range,
# and sends nothing: the twin runs with --trace, so every frame that reaches
# the line shows up on its stderr, and lec runs with --trace too.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
source "$here/lib.sh"
data=${LEC6_TEST_DIR:-$here/..}/data

start_twin ax --ids 1,2 --trace
export LEC_PORT="$tmp/ax"
lec() { "$LEC" "$@"; }
# Frames the twin has received so far.
frames_seen() { grep -c ' <- ' "$tmp/ax.err" || true; }

# refused NAME NEEDLE... -- command: exit 2, every NEEDLE in the message, nothing sent.
refused() {
  local name=$1
  shift
  local needles=()
  while [[ $1 != -- ]]; do
    needles+=("$1")
    shift
  done
  shift
  local before
  before=$(frames_seen)
  expect_exit 2 "$name" -- "$@"
  for n in "${needles[@]}"; do contains "$name" "$n"; done
  if grep -q ' -> ' <<<"$out"; then bad "$name: lec sent a frame: $out"; else ok; fi
  local after
  after=$(frames_seen)
  if [[ $before == "$after" ]]; then ok; else bad "$name: the twin received $((after - before)) frame(s)"; fi
}

# ---- CLI arguments ---------------------------------------------------------------
refused "id 0 (broadcast) read" "--id 0 is broadcast" "only writes can be broadcast" -- lec --trace --id 0 status
refused "id 0 (broadcast) move" "--id 0 is broadcast" -- lec --trace --id 0 move --to 10
refused "id 256" "--id" "0 to 255" -- lec --trace --id 256 status
refused "baud" "--baud" "38400" -- lec --trace --baud 12345 status
refused "reply margin" "--reply-margin" "0s to 60s" -- lec --trace --reply-margin -5ms status
refused "old timeout" "--timeout" "0s to 60s" -- lec --trace --timeout -5 status
refused "reply spin" "--reply-spin" "0s to 1ms" -- lec --trace --reply-spin 5ms status
refused "duration unit" "--reply-margin" "no known unit" "500ms" -- lec --trace --reply-margin 5parsecs status
refused "rs485 delay" "--rs485-delay-before" "whole multiple of 1ms" -- lec --trace --rs485-delay-before 0.5ms status
refused "retries" "--retries" "0 to 10" -- lec --trace --retries 11 status
refused "silent interval" "--silent-interval" "1 to 100" -- lec --trace --silent-interval 0 status
refused "no command" "subcommand" -- lec --trace
refused "no port" "no port given" "LEC_PORT" -- env -u LEC_PORT "$LEC" --trace status
refused "tcp port" "bad TCP port" "1 to 65535" -- lec --trace --port tcp://localhost:99999 status
refused "scan ids 0" "--ids" "1-255" -- lec --trace scan --ids 0-3
refused "scan ids backwards" "--ids" "1-255" -- lec --trace scan --ids 5-2
refused "bench n" "-n" "1 to" -- lec --trace bench -n 0
refused "bench op" "--op" "read-state" -- lec --trace bench --op nope
refused "ping interval" "--interval" "0" -- lec --trace ping -i -1
refused "watch interval" "--interval" "0s to 60s" -- lec --trace watch --interval -1
refused "watch count" "--count" -- lec --trace watch --count 0
refused "on/off" "serial" "on or off" -- lec --trace serial maybe
refused "jog direction" "jog" "+ or -" -- lec --trace jog x

# ---- out-of-range values (the manual's ranges, checked before sending) --------------
refused "position range" "position" "21474836.47" -- lec --trace move --to 99999999
refused "position text" "position" "not a length" -- lec --trace move --to abc
refused "position decimals" "position" "two decimals" -- lec --trace move --to 10.001
refused "speed 0" "speed" "1 to 65535" -- lec --trace move --to 10 --speed 0
refused "speed 70000" "speed" "1 to 65535" -- lec --trace move --to 10 --speed 70000
refused "moving force" "moving-force" "0 to 300" -- lec --trace move --to 10 --moving-force 301
refused "pushing force" "push" "0 to 100" -- lec --trace move --to 10 --push 101
refused "in-position below 0" "in-position" "0.00 to" -- lec --trace move --to 10 --in-position=-0.01
refused "trigger without push" "--trigger" "--push" -- lec --trace move --to 10 --trigger 20
refused "area" "--area" "A:B" -- lec --trace move --to 10 --area 100
refused "step and to" "exactly one" -- lec --trace move --step 1 --to 5
refused "move step 64" "64" "0 to 63" -- lec --trace move --step 64
refused "step set 64" "64" "0 to 63" -- lec --trace step set 64 speed=10
refused "step set speed" "step 3" "speed 0 mm/s" "1 to 65535" "nothing was sent" -- lec --trace step set 3 speed=0
refused "step set field" "unknown field 'bogus'" -- lec --trace step set 3 bogus=1
# A rule between two fields given on the command line: refused, no write. (The
# current direct-operation data are read first, to merge the fields not given.)
expect_exit 2 "trigger over push" -- lec --trace move --to 10 --push 50 --trigger 60
contains "trigger over push" "trigger level 60 % exceeds pushing force 50 %"
if grep -q ' -> 01 10' <<<"$out"; then bad "trigger over push: a write was sent: $out"; else ok; fi

# ---- step-table files (CSV / JSON): all-or-nothing, nothing sent --------------------
refused "csv out of range" "bad_row.csv" "line 5 (step 3)" "speed_mm_s 70000" "nothing was sent" -- \
  lec --trace step restore "$data/steps/bad_row.csv"
refused "csv duplicate step" "step 2 repeats line 4" "nothing was sent" -- \
  lec --trace step restore "$data/steps/duplicate_step.csv"
refused "csv unknown column" "unknown columns 'colour', 'Notes'" -- \
  lec --trace step restore "$data/steps/unknown_column.csv"
printf 'step,mode\r\n\xff\xfe\x00garbage\x00\n' >"$tmp/binary.csv"
refused "csv binary" "not UTF-8 text" "nothing was sent" -- lec --trace step restore "$tmp/binary.csv"
printf '{"steps": [{"step": 0, "mode": "abs"' >"$tmp/cut.json"
refused "json truncated" "cut.json" "nothing was sent" -- lec --trace step restore "$tmp/cut.json"
refused "missing file" "does not exist" -- lec --trace step restore "$tmp/nonexistent.csv"

# ---- frames --------------------------------------------------------------------
refused "decode not hex" "not hex" -- lec decode zz
refused "decode odd digits" "lone hex digit" -- lec decode 01 0
refused "decode bad CRC" "CRC 8C 36 does not match" "expected 8C 35" -- lec decode 01 05 00 30 FF 00 8C 36
refused "decode short" "too short" -- lec decode 01
refused "raw empty" "no bytes given" -- lec raw 0x
# A frame with a bad CRC reaches the twin and is ignored: no reply, no effect.
expect_exit 3 "raw bad CRC" -- lec raw --as-is 01 05 00 30 FF 00 8C 36
contains "raw bad CRC" "(nothing)"
expect_exit 0 "still parallel" -- lec --json status
[[ $(json 'd["serial_mode"]') == "False" ]] && ok || bad "a bad-CRC frame changed the mode: $out"
# Function codes the controller does not have: exception 01, exit 4.
expect_exit 4 "FC04" -- lec raw 01 04 90 00 00 01
contains "FC04" "exception 01"
# Longer than any frame (300 bytes): the twin's framer drops it, silence.
long="01 10 04 00 00 7F FE $(printf '00 %.0s' $(seq 293))"
expect_exit 3 "oversized frame" -- lec raw --as-is $long
contains "oversized frame" "(nothing)"
# (The twin models the wire: 300 bytes keep its line busy for 78 ms at 38400.)
# Wait until it answers again (a ping gets its reply) before the next check.
answers() { "$LEC" ping -c 1 -i 0 >/dev/null 2>&1; }
wait_for 10 "the twin to answer again after the oversized frame" -- answers || bad "the twin stays silent after an oversized frame"
# A read with a count the client refuses, sent raw: the controller's 03.
expect_exit 4 "raw count 126" -- lec raw 01 03 90 00 00 7E
contains "raw count 126" "exception 03"

# ---- wrong IDs -------------------------------------------------------------------
start=$(date +%s%3N)
expect_exit 3 "absent ID" -- lec --id 7 status
elapsed=$(($(date +%s%3N) - start))
contains "absent ID" "no reply from ID 7"
contains "absent ID" "check the ID"
((elapsed < 3000)) && ok || bad "absent ID took ${elapsed} ms"
# Scanning finds the two that are there, and only them.
expect_exit 0 "scan" -- lec scan --ids 1-4
contains "scan" "ID   1  answers"
contains "scan" "ID   2  answers"
if grep -q "ID   3" <<<"$out"; then bad "scan invented ID 3: $out"; else ok; fi

# ---- broadcast misuse -----------------------------------------------------------
# --id 0 is refused for reads (above). A raw broadcast read: the controllers ignore
# it, nothing answers, and lec says so without waiting for a reply that cannot come.
expect_exit 0 "raw broadcast read" -- lec raw 00 03 90 00 00 07
contains "raw broadcast read" "(nothing)"
# A raw broadcast write is executed by every controller, without a reply.
expect_exit 0 "raw broadcast write" -- lec raw 00 05 00 30 FF 00
contains "raw broadcast write" "(nothing)"
expect_exit 0 "ID 1 serial" -- lec --json --id 1 status
[[ $(json 'd["serial_mode"]') == "True" ]] && ok || bad "broadcast write not executed by ID 1: $out"
expect_exit 0 "ID 2 serial" -- lec --json --id 2 status
[[ $(json 'd["serial_mode"]') == "True" ]] && ok || bad "broadcast write not executed by ID 2: $out"
# Writes go out with --id 0: every controller obeys, no reply is awaited.
expect_exit 0 "broadcast hold" -- lec --id 0 hold on
for id in 1 2; do
  expect_exit 0 "ID $id hold" -- lec raw 0$id 01 00 18 00 01  # read Y18 HOLD
  contains "broadcast HOLD executed by ID $id" "<- 0$id 01 01 01"
done
expect_exit 0 "broadcast hold off" -- lec --id 0 hold off
# `lec reset` reads the alarms after its pulse: refused before the pulse.
refused "broadcast reset" "--id 0 is broadcast" -- lec --trace --id 0 reset

finish
