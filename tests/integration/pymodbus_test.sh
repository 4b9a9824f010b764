#!/usr/bin/env bash
# pymodbus (Debian's python3-pymodbus 3.0, a real third-party master) against
# `lec sim` on a real pseudo-terminal: the manual's operation examples 1-4,
# the exception rows of digest §3, and broadcast. Each part gets a freshly
# powered-on twin (the exception checks need parallel mode, as at power-on).

source "$(dirname "${BASH_SOURCE[0]}")/twin_lib.sh"
need --module pymodbus.client

PORT=$TMP/lec0

for part in examples exceptions broadcast; do
  # The manual's examples reply by reply: the manual's ideal twin (--ideal).
  if start_twin "$part" --pty "$PORT" --ideal; then
    pass "twin ready for $part: $READY"
    run_peer "pymodbus: $part" pymodbus "$PORT" "$part"
    stop_twin "$TWIN_PID"
    check "twin for $part ends with status 0 on SIGTERM" [ "$STATUS" = 0 ]
  else
    fail "twin for $part did not start"
  fi
done

finish
