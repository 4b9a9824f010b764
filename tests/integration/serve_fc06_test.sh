#!/usr/bin/env bash
# mbpoll's single-register write (FC06) through lec serve's Modbus TCP
# gateway (issue 33): lec serve writes it to the controller as the equivalent
# one-register FC10 and answers mbpoll with the FC06 echo; with `fc06: false`
# on the listener it answers exception 01, as the controller itself would.
# The twin behind the line runs on a real pty with --trace, so what reached
# the controller is read from its own log. mbpoll uses -0 (PDU addresses):
# -r 1058 is D0422 (step 2's position, low word).

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need --program mbpoll

PTY=$TMP/lec0
start_twin twin --pty "$PTY" --trace || {
  finish
  exit 1
}
TRACE=$TMP/twin.err


# mb ARGS... [-- VALUES...]: one mbpoll request to lec serve's Modbus TCP
# listener, unit 1 (values to write go after the host); output in OUT, status in RC.
mb() {
  local args=()
  while [[ $# -gt 0 && $1 != -- ]]; do
    args+=("$1")
    shift
  done
  [[ $# -gt 0 ]] && shift
  RC=0
  OUT=$(timeout 20 mbpoll -m tcp -p "$MB" -a 1 -0 -1 "${args[@]}" 127.0.0.1 "$@" 2>&1) || RC=$?
}
writes() { grep -cF -- "$1" "$TRACE" || true; }

# ---- fc06: true (the default) --------------------------------------------------------------
start_serve gw --port "$PTY" --ids 1 --modbus-tcp 127.0.0.1:0 --http "" || {
  finish
  exit 1
}
mb -t 4 -r 1058 -- 7
check_sh "mbpoll FC06 D0422 = 7 through lec serve succeeds: $(tail -n 1 <<<"$OUT")" \
  '[ "$RC" = 0 ] && grep -qF "Written 1 references" <<<"$OUT"'
check "  the controller received it as a one-register FC10: 01 10 04 22 00 01 02 00 07" \
  grep -qF "<- 01 10 04 22 00 01 02 00 07" "$TRACE"
check "  and answered the FC10 (01 10 04 22 00 01)" grep -qF -- "-> 01 10 04 22 00 01" "$TRACE"
check_sh "  no FC06 reached the controller" '! grep -qF "<- 01 06" "$TRACE"'
mb -t 4 -r 1058 -c 1
check_sh "FC03 reads D0422 = 7 back" '[ "$RC" = 0 ] && grep -qE "^\[1058\]:[[:space:]]+7$" <<<"$OUT"'
stop_twin "$SERVE_PID"
check "lec serve exits 0 on SIGTERM" [ "$STATUS" = 0 ]

# ---- fc06: false -----------------------------------------------------------------------------
cat >"$TMP/fc06-off.yaml" <<YAML
lines:
  - port: $PTY
    axes: [{id: 1, telemetry_hz: 0}]
    modbus_tcp: {listen: "127.0.0.1:0", fc06: false}
YAML
start_serve off --config "$TMP/fc06-off.yaml" || {
  finish
  exit 1
}
before=$(writes "<- 01 10 04 22")
mb -t 4 -r 1058 -- 9
check_sh "with fc06: false, mbpoll's FC06 fails with 'Illegal function' (exception 01): $(tail -n 1 <<<"$OUT")" \
  '[ "$RC" != 0 ] && grep -qF "Illegal function" <<<"$OUT"'
check_sh "  and nothing was written to the controller" \
  '[ "$(writes "<- 01 10 04 22")" = "$before" ] && ! grep -qF "<- 01 06" "$TRACE"'
mb -t 4 -r 1058 -c 1
check_sh "  D0422 still reads 7" '[ "$RC" = 0 ] && grep -qE "^\[1058\]:[[:space:]]+7$" <<<"$OUT"'
stop_twin "$SERVE_PID"

finish
