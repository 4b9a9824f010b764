#!/usr/bin/env bash
# lec serve --record on a disk that is full (/dev/full: every write fails
# with ENOSPC): one clear error naming the file, and the line keeps serving
# (issue 33). A record path whose directory is gone refuses the start, naming
# the file. Waits are on events (the ready line, the log line) with deadlines.
# Also: a FIFO nobody reads, several lines with a --record that is no file
# name, and the CLI's --record / lec sniff --capture keeping earlier captures.

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"


start_serve full --port sim --ids 1 --modbus-tcp 127.0.0.1:0 --http "" --record /dev/full || {
  finish
  exit 1
}
logged() { grep -q "error: line line1: recording stopped: cannot write /dev/full: No space left on device" "$TMP/full.err"; }
check "one clear error naming the file" wait_for 10 "the recording error" -- logged
L() { "$LEC" --port "tcp://127.0.0.1:$MB" "$@"; }
# The line keeps working: commands and reads through the gateway, after the error.
check "lec serial on through the gateway, after the error" L serial on
check "lec servo on" L servo on
check "lec status reads SVRE = 1" bash -c "'$LEC' --port tcp://127.0.0.1:$MB --json status | grep -q '\"svre\": *true'"
for _ in 1 2 3; do L status >/dev/null; done
check_sh "the error was said once: $(grep -c 'recording stopped' "$TMP/full.err")" \
  '[ "$(grep -c "recording stopped" "$TMP/full.err")" = 1 ]'
check "/dev/full is still a character device (never kept as an earlier capture)" test -c /dev/full
stop_twin "$SERVE_PID"
check "lec serve exits 0 on SIGTERM" [ "$STATUS" = 0 ]

# A pipe whose reader goes away (`--record >(zstd >c.zst)` and the compressor
# died, or a FIFO's reader quit): EPIPE is a write error like a full disk,
# said once; lec serve must not die of SIGPIPE (found in review: exit 141,
# the line's gateway gone without a word).
mkfifo "$TMP/rec.pipe"
(head -c 200 <"$TMP/rec.pipe" >/dev/null) &
TWIN_PIDS+=("$!")
start_serve pipe --port sim --ids 1 --modbus-tcp 127.0.0.1:0 --http "" --record "$TMP/rec.pipe" || {
  finish
  exit 1
}
logged_pipe() { grep -q "recording stopped: cannot write $TMP/rec.pipe: Broken pipe" "$TMP/pipe.err"; }
check "a pipe whose reader left: one clear error naming it" wait_for 10 "the broken pipe" -- logged_pipe
check "lec serve is still alive after its recording pipe broke" kill -0 "$SERVE_PID"
check "the line still answers through the gateway" L status
stop_twin "$SERVE_PID"
check "lec serve exits 0 on SIGTERM (not 141, SIGPIPE)" [ "$STATUS" = 0 ]

# A FIFO nothing reads yet: opening it for writing would wait for a reader for
# ever (lec serve hung at start, before its ready line); the start is refused,
# naming the FIFO and what to do.
mkfifo "$TMP/unread.pipe"
out=$(timeout 10 "$LEC" serve --no-history --port sim --modbus-tcp 127.0.0.1:0 --http "" \
  --record "$TMP/unread.pipe" 2>&1 </dev/null)
rc=$?
check_sh "a FIFO nobody reads refuses the start at once (exit 2, not a hang: $rc): $out" \
  '[ $rc = 2 ] && grep -qF "cannot record to $TMP/unread.pipe: it is a FIFO and nothing reads it yet" <<<"$out"'

# Several lines and a --record that is not a file name (a pipe, /dev/fd/N):
# FILE-<line>.jsonl would be a path nobody made; refused before anything starts.
cat >"$TMP/two.yaml" <<'YAML'
lines:
  - {name: left, port: sim, axes: [{name: a, id: 1}]}
  - {name: right, port: sim, axes: [{name: b, id: 1}]}
YAML
out=$(timeout 10 "$LEC" serve --no-history --config "$TMP/two.yaml" --modbus-tcp 127.0.0.1:0 \
  --http "" --record /dev/fd/1 2>&1 </dev/null | head -c 2000)
check_sh "--record /dev/fd/1 with two lines is refused, naming the rule: $out" \
  'grep -qF -- "--record /dev/fd/1: the config has 2 lines and each gets its own capture" <<<"$out"'
out=$(timeout 10 "$LEC" serve --no-history --config "$TMP/two.yaml" --modbus-tcp 127.0.0.1:0 \
  --http "" --record "$TMP/unread.pipe" 2>&1 </dev/null)
rc=$?
check_sh "a FIFO with two lines is refused (exit 2: $rc), not opened" \
  '[ $rc = 2 ] && grep -qF "is not a regular file" <<<"$out"'

# The CLI's --record and lec sniff --capture keep an earlier capture as lec
# serve does (found in review: a second `lec --record c.jsonl ...` truncated
# the first, which docs/replay.md tells users to run a few times).
"$LEC" --port sim --record "$TMP/cli.jsonl" status >/dev/null 2>&1
first=$(wc -l <"$TMP/cli.jsonl")
out=$("$LEC" --port sim --record "$TMP/cli.jsonl" status 2>&1 >/dev/null)
check_sh "a second lec --record keeps the first capture as .1 and says so: $out" \
  '[ "$(wc -l <"$TMP/cli.jsonl.1")" = "$first" ] && [ "$first" -gt 1 ] && grep -qF "kept the earlier capture $TMP/cli.jsonl as $TMP/cli.jsonl.1" <<<"$out"'
"$LEC" sniff --read "$TMP/cli.jsonl.1" --capture "$TMP/sniffed.jsonl" >/dev/null 2>&1
out=$("$LEC" sniff --read "$TMP/cli.jsonl.1" --capture "$TMP/sniffed.jsonl" 2>&1 >/dev/null)
check_sh "a second lec sniff --capture keeps the first as .1: $out" \
  '[ -s "$TMP/sniffed.jsonl.1" ] && [ -s "$TMP/sniffed.jsonl" ] && grep -qF "kept the earlier capture" <<<"$out"'

# A directory that is gone: the start is refused, naming the file.
out=$("$LEC" serve --no-history --port sim --modbus-tcp 127.0.0.1:0 --http "" \
  --record "$TMP/gone/c.jsonl" 2>&1 </dev/null)
rc=$?
check_sh "a record path in a missing directory refuses the start (exit 2): $out" \
  '[ $rc = 2 ] && grep -qF "cannot create $TMP/gone/c.jsonl: No such file or directory" <<<"$out"'

finish
