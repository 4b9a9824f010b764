#!/usr/bin/env bash
# End to end: `lec step list/get/set/backup/restore/diff` with the real `lec`
# binary against `lec sim --pty` twins, their EEPROM kept in --state files.
#
# The twin's per-step write counters are only visible in its state file, and
# it is saved for certain at exit: counters() stops the twin with SIGTERM,
# reads the file, and starts the twin again on the same pty path and state.
#
# Proves the issue's "done when":
#  - backup -> three `step set` -> restore -> `step diff` is empty, and the
#    counters show the restore wrote exactly those three steps, once each;
#  - a file with one bad row exits 2, names the line and the field, and
#    changes nothing (counters and steps as before);
#  - backup CSV round-trips byte for byte, and also after a spreadsheet
#    round trip (BOM, CRLF, quotes, ';' and decimal commas); the fixtures of
#    tests/data/steps restore cleanly and diff empty.
# Env: LEC (the lec binary), LEC6_TEST_DIR (tests/); set by ctest.

set -euo pipefail

LEC=${LEC:?set LEC to the lec binary}
TEST_DIR=${LEC6_TEST_DIR:-$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)}
DATA=$TEST_DIR/data/steps
source "$(dirname "${BASH_SOURCE[0]}")/harness.sh"
need --program jq
WORK=$(mktemp -d "${TMPDIR:-/tmp}/lec6-step-cli.XXXXXX")

declare -A PID=()

gone() { ! kill -0 "$1" 2>/dev/null; }

cleanup() {
  local name
  for name in "${!PID[@]}"; do
    kill -TERM "${PID[$name]}" 2>/dev/null || true
  done
  for name in "${!PID[@]}"; do
    wait_for 5 "twin $name to end after SIGTERM" -- gone "${PID[$name]}" || true  # then SIGKILL
    kill -KILL "${PID[$name]}" 2>/dev/null || true
    wait "${PID[$name]}" 2>/dev/null || true
  done
  rm -rf "$WORK"
}
trap cleanup EXIT

fail() {
  echo "FAIL: $*" >&2
  exit 1
}

# start_twin NAME [sim options...]: a twin on $WORK/NAME, state in $WORK/NAME.state.
start_twin() {
  local name=$1
  shift
  # Empty the log here, not in the child's redirection: the child truncates
  # it only once it runs, so a restarted twin's old "ready" line could be read.
  : >"$WORK/$name.log"
  "$LEC" sim --pty "$WORK/$name" --state "$WORK/$name.state" --timing fast "$@" \
    >>"$WORK/$name.log" 2>&1 &
  PID[$name]=$!
  wait_for 10 "twin $name's ready line" -- ready_or_gone "$name" ||
    { cat "$WORK/$name.log" >&2; fail "twin $name printed no ready line within 10 s"; }
  if ! grep -qs '^lec sim: ready on ' "$WORK/$name.log"; then
    cat "$WORK/$name.log" >&2
    fail "twin $name exited before it was ready"
  fi
}
ready_or_gone() { grep -qs '^lec sim: ready on ' "$WORK/$1.log" || gone "${PID[$1]}"; }

# stop_twin NAME: SIGTERM (saves the state file), bounded wait.
stop_twin() {
  local name=$1 pid=${PID[$1]}
  kill -TERM "$pid"
  if ! wait_for 10 "twin $name to end after SIGTERM" -- gone "$pid"; then
    kill -KILL "$pid" 2>/dev/null || true
    fail "twin $name did not stop within 10 s of SIGTERM"
  fi
  wait "$pid" || fail "twin $name exited with status $?"
  unset "PID[$name]"
}

# counters NAME: sets COUNTERS to "step:writes" lines for every step written
# at least once, from the state file of a stopped-and-restarted twin. (Not
# for $(...): the twin's PID bookkeeping must stay in this shell.)
counters() {
  local name=$1
  stop_twin "$name"
  COUNTERS=$(awk '$1 == "step" && $3 == "writes" && $4 > 0 { print $2 ":" $4 }' "$WORK/$name.state")
  start_twin "$name"
}

# Steps whose counter grew between two counters() outputs, with the growth: "0:+1 3:+1".
counter_growth() {
  awk -F: 'NR == FNR { before[$1] = $2; next }
           { d = $2 - before[$1]; if (d != 0) printf "%s%s:+%d", (n++ ? " " : ""), $1, d }
           END { print "" }' <(echo "$1") <(echo "$2")
}

# run EXPECTED_STATUS lec-arguments...: output in $OUT / $ERR.
run() {
  local want=$1 got=0
  shift
  "$LEC" --reply-margin 500ms "$@" >"$WORK/out" 2>"$WORK/err" || got=$?
  OUT=$(cat "$WORK/out")
  ERR=$(cat "$WORK/err")
  if [[ $got != "$want" ]]; then
    printf 'stdout:\n%s\nstderr:\n%s\n' "$OUT" "$ERR" >&2
    fail "lec $* exited $got, expected $want"
  fi
}

expect_out() {
  grep -qF -- "$1" <<<"$OUT" || { printf 'stdout:\n%s\n' "$OUT" >&2; fail "stdout lacks: $1"; }
}
expect_err() {
  grep -qF -- "$1" <<<"$ERR" || { printf 'stderr:\n%s\n' "$ERR" >&2; fail "stderr lacks: $1"; }
}

A=$WORK/a
B=$WORK/b
start_twin a

# ---- a program on the controller --------------------------------------------------
run 0 -p "$A" step restore "$DATA/spreadsheet_saved.csv"
expect_out "3 steps written, 1 unchanged (60 steps not in the file)"
run 0 -p "$A" step set 10 speed=300 position=150.00
expect_err "step 10 was blank: the defaults filled mode=abs accel=1000 decel=1000 push-speed=20 moving-force=100 in-position=0.50"
expect_out "(1 step written)"
run 0 -p "$A" step set 10 moving-force=0
expect_err "moving force is 0 %"
run 2 -p "$A" step set 10 postion=200 speed=70000
expect_err "unknown field 'postion': did you mean 'position'?"
expect_err "allowed 1 to 65535"
run 2 -p "$A" step set 10 position=1.005
expect_err "more than two decimals"
run 0 -p "$A" step set 10 --from 0 position=200.00 speed=300
expect_out "(1 step written)"
run 0 -p "$A" step set 12 mode=inc speed=80 position=-3.25 accel=2000 decel=1500 push-speed=15 in-position=2.5
expect_out "step 12: new step (was blank) written and verified"

run 0 -p "$A" step list
expect_out "5 of 64 steps in use"
[[ $(grep -cE '^ +[0-9]+  [a-z]' <<<"$OUT") == 5 ]] || fail "step list shows other than 5 rows: $OUT"
grep -qE '^ +10  abs +300 +200\.00 ' <<<"$OUT" || fail "step list row of step 10: $OUT"
run 0 -p "$A" step list --all
[[ $(grep -cE '^ +[0-9]+  [a-z]' <<<"$OUT") == 64 ]] || fail "step list --all shows other than 64 rows"
run 0 -p "$A" --json step list
[[ $(jq length <<<"$OUT") == 5 ]] || fail "step list --json: $OUT"
grep -qF '"position_mm": 200.00' <<<"$OUT" || fail "step list --json prints mm with two decimals: $OUT"
run 0 -p "$A" step get 12
expect_out "position      -3.25 mm"
expect_out "in-position   2.50 mm"

# ---- backup -----------------------------------------------------------------------------
run 0 -p "$A" step backup "$WORK/backup.csv"
expect_out "64 steps (5 in use: 0-1, 3, 10, 12) of controller 1 'LEC6-TWIN' saved to $WORK/backup.csv"
[[ $(head -1 "$WORK/backup.csv") == "# equipment_name: LEC6-TWIN" ]] || fail "backup name line"
[[ $(grep -c '^[0-9]' "$WORK/backup.csv") == 64 ]] || fail "backup has other than 64 step rows"
grep -qx '2,0,0,0.00,0,0,0,0,0,0,0.00,0.00,0.00' "$WORK/backup.csv" || fail "a blank step is a row of zeros"
run 0 -p "$A" step backup "$WORK/backup.json"
run 0 -p "$A" step diff "$WORK/backup.json"
expect_out "no differences"

# ---- three `step set`, then restore: only those three are written -------------------------
counters a
before_set=$COUNTERS
run 0 -p "$A" step set 0 position=150.01 speed=501
expect_out "step 0: speed 500 -> 501, position 150.00 -> 150.01 written and verified [D0401-D0403] (1 step written)"
run 0 -p "$A" step set 3 PUSHING_FORCE=80
expect_out "(1 step written)"
run 0 -p "$A" step set 10 mode=inc
expect_out "(1 step written)"
run 0 -p "$A" step set 10 mode=inc
expect_out "step 10: unchanged (0 steps written)"
run 1 -p "$A" step diff "$WORK/backup.csv"
expect_out "0  speed (mm/s)"
grep -qE '^ +0  position \(mm\) +150\.01 +150\.00$' <<<"$OUT" || fail "diff row of step 0 position: $OUT"
expect_out "3  push (%)"
expect_out "10  mode"
expect_err "4 fields differ in 3 steps"

counters a
before_restore=$COUNTERS
[[ $(counter_growth "$before_set" "$before_restore") == "0:+1 3:+1 10:+1" ]] ||
  fail "step set wrote: $(counter_growth "$before_set" "$before_restore")"

run 0 -p "$A" step restore --dry-run "$WORK/backup.csv"
expect_out "step 0: would write: speed 501 -> 500, position 150.01 -> 150.00 [D0401-D0403]"
expect_out "3 steps to write, 61 unchanged"
run 0 -p "$A" step restore "$WORK/backup.csv"
expect_out "step 0: written: speed 501 -> 500, position 150.01 -> 150.00 [D0401-D0403]"
expect_out "step 3: written: push 80 -> 70 [D0436]"
expect_out "step 10: written: mode inc -> abs [D04A0]"
expect_out "every written step was read back and matches"
expect_out "unchanged: 1-2, 4-9, 11-63"
expect_out "3 steps written, 61 unchanged"
run 0 -p "$A" step diff "$WORK/backup.csv"
expect_out "no differences"
run 0 -p "$A" step restore "$WORK/backup.csv"
expect_out "0 steps written, 64 unchanged"

counters a
after_restore=$COUNTERS
[[ $(counter_growth "$before_restore" "$after_restore") == "0:+1 3:+1 10:+1" ]] ||
  fail "restore wrote: $(counter_growth "$before_restore" "$after_restore") (expected 0:+1 3:+1 10:+1)"
run 0 -p "$A" step diff "$WORK/backup.csv"  # the state survived the restart
expect_out "no differences"

# ---- bad files change nothing -----------------------------------------------------------
run 2 -p "$A" step restore "$DATA/bad_row.csv"
expect_err "bad_row.csv: 1 error; nothing was sent to the controller:"
expect_err "line 5 (step 3): speed_mm_s 70000 mm/s is out of range: allowed 1 to 65535 mm/s"
# The backup with a good change on step 0 and a bad row for step 7: the good one is not written either.
sed -e 's/^0,abs,500,150.00,/0,abs,500,160.00,/' -e 's/^7,0,0,/7,abs,0,/' "$WORK/backup.csv" >"$WORK/bad.csv"
run 2 -p "$A" step restore "$WORK/bad.csv"
expect_err "line 11 (step 7)"
run 0 -p "$A" step diff "$WORK/backup.csv"
expect_out "no differences"
counters a
[[ $COUNTERS == "$after_restore" ]] || fail "a refused file changed the write counters"

# ---- round trips ----------------------------------------------------------------------------
run 0 -p "$A" step backup "$WORK/again.csv"
cmp "$WORK/backup.csv" "$WORK/again.csv" || fail "backup -> restore -> backup is not byte-identical"

# As a spreadsheet saves it: BOM, CRLF, every cell quoted, ';' and decimal commas, padding.
awk 'BEGIN { printf "\xef\xbb\xbf" }
     { n = split($0, c, ","); row = ""
       for (i = 1; i <= n; i++) { gsub(/\./, ",", c[i]); row = row (i > 1 ? ";" : "") "\"" c[i] "\"" }
       printf "%s;;\r\n", row }
     END { printf ";;;;\r\n\r\n" }' "$WORK/backup.csv" >"$WORK/sheet.csv"
grep -qF '"0";"abs";"500";"150,00";' "$WORK/sheet.csv" || fail "sheet.csv was not made as intended"
run 0 -p "$A" step diff "$WORK/sheet.csv"
expect_out "no differences"
run 0 -p "$A" step restore "$WORK/sheet.csv"
expect_out "0 steps written, 64 unchanged"
# One cell edited in the spreadsheet: exactly that step is written.
sed -e 's/^"12";"inc";"80";"-3,25";/"12";"inc";"80";"-3,26";/' "$WORK/sheet.csv" >"$WORK/sheet2.csv"
run 0 -p "$A" step restore "$WORK/sheet2.csv"
expect_out "step 12: written: position -3.25 -> -3.26 [D04C3]"
expect_out "1 step written, 63 unchanged"
run 0 -p "$A" step restore "$WORK/backup.csv"
expect_out "1 step written, 63 unchanged"

# ---- controller against controller ----------------------------------------------------------
start_twin b
run 1 -p "$A" step diff --with "$B"
expect_out "step  field"
expect_err "differ in 5 steps"
run 0 -p "$B" step restore "$WORK/backup.csv"
expect_out "5 steps written, 59 unchanged"
run 0 -p "$A" step diff --with "$B"
expect_out "no differences"
run 0 -p "$B" step set 63 --from 12
run 1 -p "$A" --json step diff --with "$B"
[[ $(jq -r '.equal' <<<"$OUT") == false ]] || fail "diff --json: $OUT"
[[ $(jq -r '[.differences[].step] | unique | join(",")' <<<"$OUT") == 63 ]] || fail "diff --json: $OUT"
run 2 -p "$A" step diff
expect_err "give a FILE, or --with PORT"

# ---- the spreadsheet fixtures restore cleanly and then diff empty ------------------------------
for f in spreadsheet_saved.csv semicolon_decimal_comma.csv reordered_columns.csv press2.json; do
  run 0 -p "$A" step restore "$DATA/$f"
  run 0 -p "$A" step diff "$DATA/$f"
  expect_out "no differences"
  run 0 -p "$A" step restore "$DATA/$f"
  expect_out "0 steps written"
done
run 0 -p "$A" step get 5
expect_out "position      -12.50 mm"
expect_out "area1         -1.25 mm"

stop_twin a
stop_twin b
echo "step_cli_test: ok"
