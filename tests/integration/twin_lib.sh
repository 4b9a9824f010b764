# Sourced by the tests/integration/*_test.sh scripts of the twin program (not a test itself).
#
# Twins run as `$LEC sim ...` in the background; a script waits for the ready
# line (at most 10 s) instead of sleeping, every other wait is bounded too, and
# the twins are stopped (SIGTERM, then SIGKILL after 10 s) when the script ends.
#
# Environment (set by ctest): LEC (the lec binary), LEC6_BUILD_DIR, LEC6_TEST_DIR.

set -u
set -o pipefail

: "${LEC:?LEC must name the lec binary}"
: "${LEC6_BUILD_DIR:=$(dirname "$LEC")}"
IT_DIR=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
source "$IT_DIR/harness.sh"
# Debian's pymodbus is installed for the system interpreter, not a pyenv one.
PY=/usr/bin/python3
PEER_PY=$IT_DIR/pymodbus_peer.py

TMP=$(mktemp -d "${TMPDIR:-/tmp}/lec6-it-XXXXXX")
PASSED=0
FAILED=0
TWIN_PIDS=()

pass() {
  echo "ok   $*"
  PASSED=$((PASSED + 1))
}
fail() {
  echo "FAIL $*"
  FAILED=$((FAILED + 1))
}
# check WHAT COMMAND...: passes when COMMAND succeeds.
check() {
  local what=$1
  shift
  if "$@"; then pass "$what"; else fail "$what"; fi
}
# check_sh WHAT 'SHELL CONDITION': passes when the condition (eval'ed) holds.
check_sh() {
  local what=$1
  shift
  if eval "$*"; then pass "$what"; else fail "$what"; fi
}

# wait_bounded PID [SECONDS]: waits for the script's child PID to end, at
# most SECONDS (default 10; then SIGKILL). Sets STATUS to its exit status.
# Event driven: `wait` returns when the process ends. (Not in a $(...)
# subshell: only the parent shell can wait for its children.)
wait_bounded() {
  local pid=$1 limit=${2:-10}
  sleep "$limit" &
  local timer=$!
  # Whichever ends first: the twin or the timer.
  STATUS=0
  wait -n "$pid" "$timer" 2>/dev/null
  if kill -0 "$pid" 2>/dev/null; then
    echo "process $pid still running after ${limit} s: SIGKILL" >&2
    kill -KILL "$pid" 2>/dev/null
  fi
  wait "$pid" 2>/dev/null || STATUS=$?
  # SIGKILL, not TERM: a bash child killed before it has exec'ed `sleep` would
  # still run this script's EXIT trap (and clean up under our feet).
  kill -KILL "$timer" 2>/dev/null
  wait "$timer" 2>/dev/null
  return 0
}

# start_twin NAME ARGS...: runs `$LEC sim ARGS...` with stdout into
# $TMP/NAME.out and stderr into $TMP/NAME.err; waits for the ready line
# (≤ 10 s). Sets TWIN_PID and READY (the line). If it never came: counts a
# failure and returns 1.
start_twin() {
  local name=$1
  shift
  local fifo=$TMP/$name.fifo
  rm -f "$fifo"
  mkfifo "$fifo"
  "$LEC" sim "$@" >"$fifo" 2>"$TMP/$name.err" &
  TWIN_PID=$!
  TWIN_PIDS+=("$TWIN_PID")
  local fd
  exec {fd}<"$fifo"
  READY=""
  if ! IFS= read -r -t 10 -u "$fd" READY || [[ $READY != "lec sim: ready on "* ]]; then
    exec {fd}<&-
    # A failure, not a skip: the checks that needed this twin do not run.
    fail "twin '$name' did not get ready within 10 s; ready line: '$READY'"
    cat "$TMP/$name.err" >&2
    return 1
  fi
  echo "$READY" >"$TMP/$name.out"
  # Keep draining its stdout (nothing more is expected) until it exits.
  cat <&"$fd" >>"$TMP/$name.out" &
  exec {fd}<&-
  return 0
}

# stop_twin PID [SIGNAL]: signals the twin (TERM by default) and waits for it
# (≤ 10 s); sets STATUS to its exit status.
stop_twin() {
  local pid=$1 sig=${2:-TERM}
  kill -"$sig" "$pid" 2>/dev/null
  wait_bounded "$pid" 10
}

cleanup() {
  local pid
  for pid in "${TWIN_PIDS[@]}"; do
    if kill -0 "$pid" 2>/dev/null; then stop_twin "$pid" TERM; fi
  done
  wait 2>/dev/null
  rm -rf "$TMP"
}
trap cleanup EXIT

# Runs the pymodbus peer (bounded to 120 s): pymodbus PORT MODE [ARGS...].
pymodbus() {
  timeout 120 "$PY" "$PEER_PY" "$@"
}

# Last line "N passed, M failed" of a peer's output with M = 0 and N > 0.
peer_ok() {
  local out=$1
  local last
  last=$(tail -n 1 <<<"$out")
  [[ $last =~ ^([0-9]+)\ passed,\ 0\ failed$ ]] && ((BASH_REMATCH[1] > 0))
}

# run_peer WHAT COMMAND...: runs a peer, shows its output, counts it as one check.
run_peer() {
  local what=$1
  shift
  local out rc=0
  out=$("$@" 2>&1) || rc=$?
  sed 's/^/    /' <<<"$out"
  if [[ $rc -eq 0 ]] && peer_ok "$out"; then pass "$what"; else fail "$what (exit $rc)"; fi
}

finish() {
  echo "$PASSED passed, $FAILED failed"
  [[ $FAILED -eq 0 && $PASSED -gt 0 ]]
}

# start_serve NAME ARGS...: `lec serve --no-history ARGS...` in the background until
# its ready line (10 s); sets SERVE_PID and MB (its Modbus TCP port).
start_serve() {
  local name=$1
  shift
  mkfifo "$TMP/$name.fifo"
  "$LEC" serve --no-history "$@" >"$TMP/$name.fifo" 2>"$TMP/$name.err" &
  SERVE_PID=$!
  TWIN_PIDS+=("$SERVE_PID")
  local fd ready=""
  exec {fd}<"$TMP/$name.fifo"
  IFS= read -r -t 10 -u "$fd" ready || true
  cat <&"$fd" >"$TMP/$name.out" &
  exec {fd}<&-
  MB=$(grep -o 'tcp://127.0.0.1:[0-9]*' <<<"$ready" | head -1 | sed 's|.*:||')
  [[ -n $MB ]] || {
    fail "lec serve ($name) did not get ready: '$ready' $(cat "$TMP/$name.err")"
    return 1
  }
}
