#!/usr/bin/env bash
# `lec sim` as a program: help and defaults, bad values (exit 2 naming the
# option), the symlink's life (only once ready, gone after SIGTERM/SIGINT),
# the state file (saved while running, survives a restart, parseable after a
# SIGKILL in the middle of heavy writes), idle CPU, round-trip timing against
# the limit (as ratios), TCP, fast timing and faults.

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need --module pymodbus.client

PORT=$TMP/lec0

# ---- help and defaults -------------------------------------------------------------
RC=0
HELP=$(timeout 10 "$LEC" sim --help 2>&1) || RC=$?
check "lec sim --help exits 0" [ "$RC" = 0 ]
for want in "--ids LIST=1 " "--baud UINT:{9600,19200,38400,57600,115200,230400}=38400" \
  "--timing TEXT:{real,fast}=real" "=1 " "--td DURATION=5ms" \
  "--stroke MIN:MAX=0:400" "--max-speed MM/S:> 0=1000" "--initial-position MM=10" \
  "--name TEXT=LEC6-TWIN" "--seed UINT=1" "--extra-delay DURATION" "--drop-rate" "--state" \
  "--trace" "--pty" "--tcp" "--workpiece"; do
  check "help shows '$want'" grep -qF -- "$want" <<<"$HELP"
done
check "help shows the silent interval default k = 1" grep -qE -- "--silent-interval .*=1$" <<<"$HELP"

# ---- bad values: exit 2, a message naming the option, no link -----------------------
bad_value() { # bad_value OPTION-NAME-IN-MESSAGE ARGS...
  local name=$1
  shift
  local rc=0 out
  out=$(timeout 10 "$LEC" sim "$@" 2>&1) || rc=$?
  if [[ $rc -eq 2 && $out == *"$name"* && ! -e $TMP/bad && ! -L $TMP/bad ]]; then
    pass "exit 2 naming $name: lec sim $* -> $(head -n 1 <<<"$out")"
  else
    fail "lec sim $*: exit $rc, message '$out' (wanted exit 2 naming $name, no link)"
  fi
}
bad_value --baud --pty "$TMP/bad" --baud 12345
bad_value --timing --pty "$TMP/bad" --timing slow
bad_value --ids --pty "$TMP/bad" --ids 0
bad_value --ids --pty "$TMP/bad" --ids 256
bad_value --ids --pty "$TMP/bad" --ids 5-2
bad_value --ids --pty "$TMP/bad" --ids 1,x
bad_value --silent-interval --pty "$TMP/bad" --silent-interval 0
bad_value --td --pty "$TMP/bad" --td -1ms
bad_value --stroke --pty "$TMP/bad" --stroke 5:400
bad_value --stroke --pty "$TMP/bad" --stroke 400
bad_value --max-speed --pty "$TMP/bad" --max-speed 0
bad_value --initial-position --pty "$TMP/bad" --initial-position 500
bad_value --name --pty "$TMP/bad" --name "FIFTEEN-CHARS-X"
bad_value --drop-rate --pty "$TMP/bad" --drop-rate 2
bad_value --corrupt-rate --pty "$TMP/bad" --corrupt-rate -0.5
bad_value --tcp --pty "$TMP/bad" --tcp 127.0.0.1:99999
bad_value --pty --ids 1

# ---- the symlink: only once ready, gone at the end ---------------------------------
check "no link before the twin starts" [ ! -L "$PORT" ]
if start_twin link --pty "$PORT"; then
  check "the link exists when the ready line is out" [ -L "$PORT" ]
  check_sh "it points at a pseudo-terminal slave ($(readlink "$PORT"))" '[[ $(readlink "$PORT") == /dev/pts/* ]]'
  check_sh "the ready line names it and the default twin: $READY" '[[ $READY == "lec sim: ready on $PORT (ids 1, timing real, 38400 baud, profile default, busy-delay 20ms, busy-min 60ms, homing 50 mm/s, SETON cleared on re-home)" ]]'
  stop_twin "$TWIN_PID" TERM
  check "SIGTERM: exit status 0" [ "$STATUS" = 0 ]
  check "SIGTERM: link removed" [ ! -L "$PORT" ]
else
  fail "twin did not start"
fi
if start_twin link-int --pty "$PORT"; then
  stop_twin "$TWIN_PID" INT
  check "SIGINT: exit status 0" [ "$STATUS" = 0 ]
  check "SIGINT: link removed" [ ! -L "$PORT" ]
else
  fail "twin did not start"
fi
# A twin that cannot start never makes the link: a corrupt state file...
echo "this is not a state file" >"$TMP/corrupt.state"
RC=0
timeout 10 "$LEC" sim --pty "$PORT" --state "$TMP/corrupt.state" >"$TMP/corrupt.out" 2>&1 || RC=$?
check "a corrupt --state file: exit 1 ($(head -n 1 "$TMP/corrupt.out"))" [ "$RC" = 1 ]
check "  and no link" [ ! -L "$PORT" ]
# ... a regular file where the link should go (left alone).
echo keep >"$TMP/notalink"
RC=0
timeout 10 "$LEC" sim --pty "$TMP/notalink" >"$TMP/notalink.out" 2>&1 || RC=$?
check_sh "a regular file at the --pty path: exit 3, file kept ($(head -n 1 "$TMP/notalink.out"))" \
  '[ "$RC" = 3 ] && [ "$(cat "$TMP/notalink")" = keep ]'

# ---- state file ----------------------------------------------------------------------
STATE=$TMP/twin.state
if start_twin state1 --pty "$PORT" --state "$STATE"; then
  run_peer "pymodbus writes step 5" pymodbus "$PORT" write-step
  # The debounced save lands while the twin runs: wait (≤ 5 s) for it.
  saved_step5() { grep -q "^step 5 " "$STATE" 2>/dev/null; }
  wait_for 5 "the state file to have step 5" -- saved_step5 || true
  check "the state file has step 5 while the twin runs" grep -q "^step 5 writes 1 " "$STATE"
  stop_twin "$TWIN_PID"
  check "twin ends with status 0" [ "$STATUS" = 0 ]
else
  fail "twin with --state did not start"
fi
if start_twin state2 --pty "$PORT" --state "$STATE"; then
  run_peer "step 5 survived the restart (read through pymodbus)" pymodbus "$PORT" check-step
  stop_twin "$TWIN_PID"
else
  fail "twin did not restart from its state file"
fi

# A twin with fewer IDs keeps the others' EEPROM in the file it rewrites.
CSTATE=$TMP/carry.state
for id in 1 2; do
  if start_twin "carry$id" --pty "$PORT" --ids "$id" --state "$CSTATE"; then
    run_peer "ID $id alone writes its step 5" pymodbus "$PORT" write-step "$id"
    stop_twin "$TWIN_PID"
  else
    fail "twin --ids $id did not start"
  fi
done
if start_twin carry12 --pty "$PORT" --ids 1-2 --state "$CSTATE"; then
  run_peer "ID 1's step 5 survived a twin that only had ID 2" pymodbus "$PORT" check-step 1
  run_peer "ID 2's step 5 is there too" pymodbus "$PORT" check-step 2
  stop_twin "$TWIN_PID"
else
  fail "twin --ids 1-2 did not start"
fi

# SIGKILL in the middle of heavy step writes: the file is the old or the new
# one, never torn (the next twin loads it). Three rounds, killed at
# different moments (after 5, 20, 40 saved writes).
KSTATE=$TMP/kill.state
for after in 5 20 40; do
  if start_twin "kill$after" --pty "$PORT" --state "$KSTATE"; then
    pymodbus "$PORT" hammer 20 >"$TMP/hammer$after.out" 2>&1 &
    hammer=$!
    saved=0
    saved_writes() {
      saved=$(sed -n 's/^step 6 writes \([0-9]*\) .*/\1/p' "$KSTATE" 2>/dev/null)
      [[ -n $saved && $saved -ge $after ]]
    }
    wait_for 10 "$after saved writes of step 6" -- saved_writes || true
    stop_twin "$TWIN_PID" KILL
    check "SIGKILL after >= $after saved writes of step 6 (file had $saved): status 137" [ "$STATUS" = 137 ]
    # The hammer stops by itself at its first failed write (the port is gone).
    wait_bounded "$hammer" 30
    if start_twin "after-kill$after" --pty "$PORT" --state "$KSTATE"; then
      pass "  the state file left by SIGKILL loads ($(grep -c '' "$KSTATE") lines)"
      stop_twin "$TWIN_PID"
    else
      fail "  the state file left by SIGKILL does not load: $(cat "$TMP/after-kill$after.err")"
    fi
  else
    fail "twin for the SIGKILL round did not start"
  fi
done
check "  and the state file is complete (ends with 'end')" [ "$(tail -n 1 "$KSTATE")" = end ]

# ---- idle CPU --------------------------------------------------------------------------
# After traffic and a finished move, a waiting twin blocks: CPU time over ~2 s
# of idling must stay under 5 % of the wall time (a ratio; usually 0 ticks).
cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }
if start_twin idle --pty "$PORT" --ids 1-16 --ideal; then  # the manual's examples: the ideal twin
  run_peer "traffic before idling (the examples, with motion)" pymodbus "$PORT" examples
  tck=$(getconf CLK_TCK)
  c0=$(cpu_ticks "$TWIN_PID")
  t0=$(date +%s.%N)
  sleep 2 # the measurement window itself, not a synchronisation
  c1=$(cpu_ticks "$TWIN_PID")
  t1=$(date +%s.%N)
  ratio=$(awk -v c="$((c1 - c0))" -v k="$tck" -v a="$t0" -v b="$t1" 'BEGIN { printf "%.4f", (c / k) / (b - a) }')
  check_sh "idle CPU / wall time = $ratio ($((c1 - c0)) ticks of 1/$tck s) < 0.05" \
    'awk -v r="$ratio" "BEGIN { exit !(r < 0.05) }"'
  stop_twin "$TWIN_PID"
else
  fail "twin for the idle test did not start"
fi

# ---- timing: client-observed round trips against the limit ---------------------------
# From before the master's write to the reply's last byte, read-state (D9000 x7),
# as ratios to wire(query) + Ts + 4 ms + Td + wire(reply): never below 1 (holds
# under any load), the best of N within 1.5 (unloaded 1.01-1.03; scheduling
# only adds delay, so the best shows the twin's own timing, also on a loaded
# machine: 1.01-1.18 measured at a load average of 13 on 2 cores), the median under
# 4 (no systematic lateness). Exact timing is proved on a virtual clock
# (tests/sim, tests/client); the precise wall-clock figures are bench/compare's.
if start_twin timing --pty "$PORT"; then
  run_peer "real timing at 38400, k 1, Td 5 ms" pymodbus "$PORT" timing 38400 1 5 40 1.0 1.5
  stop_twin "$TWIN_PID"
fi
if start_twin timing2 --pty "$PORT" --baud 9600 --silent-interval 3 --td 12ms; then
  check_sh "the ready line names Td: $READY" '[[ $READY == *", Td 12ms, "* ]]'
  run_peer "real timing at 9600, k 3, Td 12 ms" pymodbus "$PORT" timing 9600 3 12 25 1.0 1.5
  stop_twin "$TWIN_PID"
fi
if start_twin fast --pty "$PORT" --timing fast; then
  check_sh "fast timing in the ready line" '[[ $READY == *"timing fast"* ]]'
  # Fast timing answers below the limit, which a real-timing reply never does.
  run_peer "fast timing: the best round trip under half the limit" \
    pymodbus "$PORT" timing 38400 1 5 40 0 0.5
  stop_twin "$TWIN_PID"
fi

# The spellings from before durations had units still work, with a hint.
if start_twin oldnames --pty "$PORT" --delay-ms 7 --busy-delay-ms 15 --busy-min-ms 60 \
  --extra-delay-ms 2 --delay-rate 0; then
  check_sh "old option names apply: $READY" \
    '[[ $READY == *", Td 7ms, busy-delay 15ms, busy-min 60ms, "* ]]'
  check_sh "each old name gets a hint" \
    '[[ $(grep -c "is deprecated; write --" "$TMP/oldnames.err") == 4 ]]'
  check_sh "the hint names the new spelling" \
    'grep -qF -- "--busy-delay-ms 15 is deprecated; write --busy-delay 15ms" "$TMP/oldnames.err"'
  stop_twin "$TWIN_PID"
fi

# ---- TCP ------------------------------------------------------------------------------
if start_twin tcp --pty "$PORT" --tcp 127.0.0.1:0; then
  URL=$(grep -o 'tcp://127\.0\.0\.1:[0-9]*' <<<"$READY")
  check_sh "ready line names the pty and the TCP port: $READY" '[[ $READY == *"$PORT and rtu+tcp://127.0.0.1:"* ]]'
  run_peer "pymodbus over TCP (RTU framer), two clients on one bus" pymodbus "$URL" tcp
  run_peer "the pty still serves alongside TCP" pymodbus "$PORT" echo-ids 1 2
  stop_twin "$TWIN_PID"
  check "TCP twin ends with status 0" [ "$STATUS" = 0 ]
fi

# ---- faults ----------------------------------------------------------------------------
if start_twin drop --pty "$PORT" --drop-rate 1; then
  run_peer "--drop-rate 1: ID 1 is silent" pymodbus "$PORT" echo-ids - 1
  stop_twin "$TWIN_PID"
fi
if start_twin corrupt --pty "$PORT" --corrupt-rate 1 --seed 7; then
  run_peer "--corrupt-rate 1: replies with a broken CRC" pymodbus "$PORT" bad-crc
  stop_twin "$TWIN_PID"
fi

finish
