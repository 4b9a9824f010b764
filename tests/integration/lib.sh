# Shared helpers for the integration scripts: start a twin on a real
# pseudo-terminal, wait for its ready line (bounded), count checks.
: "${LEC:?path of the lec binary}"
source "$(dirname "${BASH_SOURCE[0]}")/harness.sh"
need # json() below runs /usr/bin/python3

tmp=$(mktemp -d)
twin_pids=()
cleanup() {
  for p in "${twin_pids[@]}"; do kill "$p" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$tmp"
}
trap cleanup EXIT

# start_twin NAME [lec sim options...]: twin on $tmp/NAME; sets TWIN_PID.
start_twin() {
  local name=$1
  shift
  : >"$tmp/$name.out"  # emptied before the child starts (see step_cli_test.sh)
  "$LEC" sim --pty "$tmp/$name" "$@" >>"$tmp/$name.out" 2>"$tmp/$name.err" &
  TWIN_PID=$!
  twin_pids+=("$TWIN_PID")
  wait_for 10 "twin $name's ready line and $tmp/$name" -- twin_ready "$name" || true
  kill -0 "$TWIN_PID" 2>/dev/null && grep -q "ready" "$tmp/$name.out" && return 0
  echo "twin $name did not start:"; cat "$tmp/$name.err"
  exit 1
}
# twin_ready NAME: the ready line is out and the link exists (or the twin has
# exited: stop waiting, start_twin reports it).
twin_ready() {
  if grep -q "ready" "$tmp/$1.out" 2>/dev/null && [[ -e $tmp/$1 ]]; then return 0; fi
  kill -0 "$TWIN_PID" 2>/dev/null || return 0
  return 1
}

pass=0
fail=0
ok() { pass=$((pass + 1)); }
bad() { fail=$((fail + 1)); echo "FAIL: $*"; }
# expect_exit CODE NAME -- command...: runs it, checks the exit code; output in $out.
expect_exit() {
  local want=$1 name=$2
  shift 3
  set +e
  out=$("$@" 2>&1)
  local got=$?
  set -e
  if [[ $got -eq $want ]]; then ok; else bad "$name: exit $got, expected $want; output: $out"; fi
}
# contains NAME NEEDLE: $out contains NEEDLE.
contains() { if grep -qF -- "$2" <<<"$out"; then ok; else bad "$1: '$2' not in: $out"; fi; }
json() { /usr/bin/python3 -c "import json,sys; d=json.loads(sys.argv[1]); print(eval(sys.argv[2]))" "$out" "$1"; }
finish() {
  echo "$pass passed, $fail failed"
  [[ $fail -eq 0 ]]
}
